"""Make the app's screenshots in docs/screenshots/ (what the README and docs show).

Every picture is ``taptune gui --screenshot`` of the app as a user sees it, on the bundled
``er32_d16`` example: its recording identified into a temporary holder library, the same
holder tapped again at 63.5 mm and once with both contact stiffnesses halved (a worn
collet; both synthetic, from the example's true parameters, as scripts/make_recordings.py
makes the examples), and the example machine. Each view at 1366×768, the spectrum, fit and
predictor at 1920×1080 too; saved as 256-colour PNGs (a screenshot has few colours).

Run: ``python scripts/make_screenshots.py [--only NAME …] [--out DIR]`` (a minute or two;
the window is rendered offscreen where there is no display). Nothing outside ``--out``
(default docs/screenshots/) is changed: the library, the settings and the recordings
live in the temporary folder taptune-screenshots (removed at the end).
"""

from __future__ import annotations

import argparse
import json
import os
import re
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

EXAMPLE = REPO / "recordings"
MACHINE = EXAMPLE / "machine" / "machine.toml"
HOLDER = "ER32 collet chuck HSK-A63 x 100"
SMALL, LARGE = "1366x768", "1920x1080"
# name -> (sizes, arguments of `taptune gui` with {in} the inputs folder)
SHOTS = {
    "record": ((SMALL,), ["--view", "record"]),
    "spectrum": ((SMALL, LARGE), ["{in}/er32_d16_tap.wav", "--view", "spectrum"]),
    "spectrum_two_stickouts": ((SMALL,), ["{in}/er32_d16_tap.wav", "--second", "{in}/er32_d16_63.5mm_tap.wav",
                                          "--view", "spectrum"]),
    "fit": ((SMALL, LARGE), ["{in}/er32_d16_tap.wav", "--identify", "--view", "fit"]),
    "fit_two_stickouts": ((SMALL,), ["{in}/er32_d16_tap.wav", "--second", "{in}/er32_d16_63.5mm_tap.wav",
                                     "--identify", "--view", "fit"]),
    "predict": ((SMALL, LARGE), ["--assembly", "{in}/er32_d16.toml", "--holder", HOLDER, "--view", "predict"]),
    "machine": ((SMALL,), ["--assembly", "{in}/er32_d16.toml", "--holder", HOLDER, "--machine", str(MACHINE),
                           "--view", "machine"]),
    "library": ((SMALL,), ["--view", "library"]),
    "check_differs": ((SMALL,), ["{in}/er32_d16_worn.wav", "--holder", HOLDER, "--check", "--view", "check"]),
}


def make_inputs(folder: Path) -> None:
    """The example tap, the same holder at 63.5 mm and worn (contact stiffnesses × 0.5), with their assemblies."""
    from taptune.io.assembly import load_assembly
    from taptune.model.params import HolderParams
    from taptune.synthetic import write_tap_recording

    truth = json.loads((EXAMPLE / "er32_d16.truth.json").read_text())
    params = HolderParams(**truth["true_params"])
    # The example's own workshop (noise, hum, taps), another noise seed per take.
    nuisances = {k: tuple(v) if isinstance(v, list) else v for k, v in truth["nuisances"].items()
                 if k not in ("seed", "subtype")}
    toml = (EXAMPLE / "er32_d16.toml").read_text()
    for name in ("er32_d16_tap.wav", "er32_d16.toml"):
        shutil.copyfile(EXAMPLE / name, folder / name)
    (folder / "er32_d16_63.5mm_tap.toml").write_text(re.sub(r"(?m)^stickout\s*=.*$", "stickout = 63.5", toml))
    (folder / "er32_d16_worn.toml").write_text(toml)
    worn = HolderParams(**{**params.to_dict(), "k_tt": 0.5 * params.k_tt, "k_rr": 0.5 * params.k_rr})
    for name, p, seed in (("er32_d16_63.5mm_tap", params, 21), ("er32_d16_worn", worn, 22)):
        write_tap_recording(folder / f"{name}.wav", load_assembly(folder / f"{name}.toml"), p, seed=seed,
                            subtype="PCM_16", **nuisances)


def taptune(args, env) -> None:
    subprocess.run([sys.executable, "-m", "taptune", *args], cwd=REPO, env=env, check=True,
                   stdout=subprocess.DEVNULL)


def save_small(png: Path) -> None:
    """Rewrite ``png`` with a 256-colour palette, undithered: a screenshot has few colours, and the
    house colours stay exact (a median-cut palette turned the red peak labels orange at 1920x1080)."""
    from PIL import Image

    image = Image.open(png).convert("RGB")
    image.quantize(256, method=Image.Quantize.FASTOCTREE, dither=Image.Dither.NONE).save(png, optimize=True)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--only", nargs="+", choices=sorted(SHOTS), help="make only these pictures")
    parser.add_argument("--out", type=Path, default=REPO / "docs" / "screenshots")
    args = parser.parse_args()
    args.out.mkdir(parents=True, exist_ok=True)
    # A fixed, plain folder: the pictures show its paths (library, recordings).
    tmp = Path(tempfile.gettempdir()) / "taptune-screenshots"
    shutil.rmtree(tmp, ignore_errors=True)
    try:
        inputs = tmp / "taps"
        inputs.mkdir(parents=True)
        make_inputs(inputs)
        # A user's view of it: a plain home folder (the Record view shows where recordings go),
        # settings and library of its own.
        env = {**os.environ, "HOME": "/home/you", "XDG_CONFIG_HOME": str(tmp / "config"),
               "TAPTUNE_LIBRARY": str(tmp / "library" / "holders.json")}
        taptune(["identify", str(inputs / "er32_d16_tap.wav"), "--assembly", str(inputs / "er32_d16.toml")], env)
        library = tmp / "library" / "holders.json"
        for name in args.only or SHOTS:
            sizes, gui_args = SHOTS[name]
            for size in sizes:
                shot_env = env
                if name == "check_differs":  # the check goes into the holder's history: a copy of the library
                    copy = tmp / "check" / "holders.json"
                    copy.parent.mkdir(exist_ok=True)
                    shutil.copyfile(library, copy)
                    shot_env = {**env, "TAPTUNE_LIBRARY": str(copy)}
                png = args.out / f"{name}_{size}.png"
                taptune(["gui", *(a.replace("{in}", str(inputs)) for a in gui_args), "--size", size,
                         "--screenshot", str(png)], shot_env)
                save_small(png)
                print(f"{png.relative_to(REPO) if png.is_relative_to(REPO) else png}: {png.stat().st_size / 1024:.0f} kB")
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


if __name__ == "__main__":
    main()
