"""The app on a real X server (Xvfb, Qt's ``xcb`` platform), not only the offscreen one.

The other GUI tests render offscreen, which needs none of the X libraries Qt's ``xcb``
plugin loads; a machine without them aborts (SIGABRT, "Could not load the Qt platform
plugin "xcb"") the moment a user starts ``taptune gui`` on the desktop. Here one app
process starts on a fresh Xvfb display and pictures every view at 1366×768.

Without Xvfb the test is skipped, unless ``CI`` is set: there it fails (CI must prove it).
"""

from __future__ import annotations

import os
import shutil
import signal
import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]
MACHINE = REPO / "recordings" / "machine" / "machine.toml"
SIZE = (1366, 768)
VIEWS = ("record", "spectrum", "fit", "predict", "machine", "library", "check")


def start_xvfb():
    """A new Xvfb server on a free display: ``(process, ":N")``; skip (or fail on CI) without Xvfb."""
    xvfb = shutil.which("Xvfb")
    if xvfb is None:
        message = "Xvfb is not installed (./dev installs it: apt-get install xvfb)"
        if os.environ.get("CI"):
            pytest.fail(f"{message}; on CI the app must be tried on a real X server")
        pytest.skip(message)
    read, write = os.pipe()
    # -displayfd: the server picks a free display and writes its number when it is ready.
    server = subprocess.Popen([xvfb, "-displayfd", str(write), "-screen", "0", "1920x1080x24", "-nolisten", "tcp"],
                              pass_fds=(write,), stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    os.close(write)
    with os.fdopen(read) as f:
        number = f.readline().strip()
    if not number:
        server.kill()
        pytest.fail(f"Xvfb did not start: {server.communicate(timeout=10)[1].decode(errors='replace')[-800:]}")
    return server, f":{number}"


def diagnose(returncode: int, stderr: str) -> str | None:
    """Why an app process on the X display failed, in one clear message (None: it did not)."""
    if returncode == 0:
        return None
    tail = stderr.strip()[-1500:]
    if returncode == -signal.SIGABRT or "Could not load the Qt platform plugin" in stderr:
        return ("the app aborted on the X display (SIGABRT): Qt could not load its 'xcb' platform plugin, "
                "so a user's `taptune gui` would abort the same way. Install the X libraries Qt needs "
                "(./dev does: libxcb-cursor0 libxcb-icccm4 libxcb-keysyms1 libxcb-image0 libxcb-render-util0 "
                "libxcb-xkb1 libxkbcommon-x11-0 …; QT_DEBUG_PLUGINS=1 names the missing one).\n" + tail)
    return f"the app on the X display ended with exit status {returncode}:\n{tail}"


def run_app_on(display: str, script: str, settings_dir: Path, timeout_s: float = 120.0, extra_env=None):
    """Run ``python -c script`` as the app would run on ``display`` (xcb platform): ``(returncode, stderr)``.

    Its settings live in ``settings_dir``: the user's remembered choices are neither read nor changed.
    """
    env = {k: v for k, v in os.environ.items() if k not in ("WAYLAND_DISPLAY", "QT_QPA_PLATFORM")}
    env.update(DISPLAY=display, QT_QPA_PLATFORM="xcb", PYTHONPATH=str(REPO), XDG_CONFIG_HOME=str(settings_dir),
               **(extra_env or {}))
    proc = subprocess.run([sys.executable, "-c", script], cwd=REPO, env=env, capture_output=True, text=True,
                          timeout=timeout_s)
    return proc.returncode, proc.stderr


@pytest.fixture
def xserver():
    server, display = start_xvfb()
    yield display
    server.terminate()
    try:
        server.wait(timeout=10)
    except subprocess.TimeoutExpired:
        server.kill()


@pytest.fixture
def library_with_holder_a(tmp_path, reference_assembly):
    """A library holding holder A (published parameters), identified at the reference stick-out."""
    from taptune.library import HolderEntry, HolderLibrary
    from taptune.model.params import HolderParams

    from tests.gui.conftest import HOLDER_A
    from tests.library.entries import make_record

    path = tmp_path / "library" / "holders.json"
    record = make_record(stickout_mm=reference_assembly.stickout * 1e3)
    HolderLibrary(path).put(HolderEntry.create(reference_assembly.holder, HolderParams(**HOLDER_A),
                                               identifications=(record,)))
    return path, reference_assembly.holder.name


def png_problems(path: Path, size) -> list[str]:
    """What is wrong with a screenshot: missing, wrong size, blank or nearly so."""
    from PIL import Image

    if not path.is_file():
        return [f"{path.name}: not written"]
    image = Image.open(path).convert("RGB")
    problems = []
    if image.size != tuple(size):
        problems.append(f"{path.name}: {image.size[0]}×{image.size[1]} pixels, expected {size[0]}×{size[1]}")
    colours = image.getcolors(maxcolors=1 << 16)
    if colours is not None and len(colours) < 16:
        problems.append(f"{path.name}: only {len(colours)} colours (a blank window?)")
    lo, hi = image.convert("L").getextrema()
    if hi - lo < 100:
        problems.append(f"{path.name}: no contrast (grey levels {lo}–{hi})")
    return problems


def test_the_app_starts_on_a_real_x_display_and_pictures_every_view(xserver, tmp_path, generated_recording,
                                                                  library_with_holder_a):
    from PIL import Image, ImageChops

    wav, toml, _ = generated_recording
    library, holder = library_with_holder_a
    out = tmp_path / "shots"
    out.mkdir()
    script = f"""
import sys
from taptune.gui.app import run
from taptune.library import HolderLibrary
holder = HolderLibrary({str(library)!r}).get({holder!r})
sys.exit(run({str(wav)!r}, {str(toml)!r}, {str(library)!r}, {str(out / "{view}.png")!r}, {SIZE!r},
             {list(VIEWS)!r}, holder=holder, machine={str(MACHINE)!r}, check=True))
"""
    returncode, stderr = run_app_on(xserver, script, tmp_path / "settings", extra_env={"TAPTUNE_LIBRARY": str(library)})
    problem = diagnose(returncode, stderr)
    assert problem is None, problem
    problems = [p for view in VIEWS for p in png_problems(out / f"{view}.png", SIZE)]
    assert not problems, "\n".join(problems)
    # Each picture shows its own view: the tab pages differ pairwise.
    pages = {v: Image.open(out / f"{v}.png").convert("RGB").crop((420, 60, SIZE[0], SIZE[1] - 30)) for v in VIEWS}
    same = [(a, b) for i, a in enumerate(VIEWS) for b in VIEWS[i + 1:]
            if ImageChops.difference(pages[a], pages[b]).getbbox() is None]
    assert not same, f"views pictured alike (the view did not change): {same}"


def test_a_qt_that_cannot_load_xcb_is_reported_in_plain_words(xserver, tmp_path):
    # An empty libxcb-icccm.so.4 first on the library path: the loader cannot use it, as on a
    # machine without libxcb-icccm4 (the library a fresh Debian lacked), and Qt aborts.
    (tmp_path / "libxcb-icccm.so.4").write_bytes(b"")
    returncode, stderr = run_app_on(xserver, "from taptune.gui.app import application; application()",
                                    tmp_path / "settings", timeout_s=60, extra_env={"LD_LIBRARY_PATH": str(tmp_path)})
    assert returncode == -signal.SIGABRT, (returncode, stderr[-500:])
    problem = diagnose(returncode, stderr)
    assert problem.startswith("the app aborted on the X display (SIGABRT): Qt could not load its 'xcb'")
    assert 'Could not load the Qt platform plugin "xcb"' in problem  # Qt's own words follow
