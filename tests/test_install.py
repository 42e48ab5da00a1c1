"""The installed package stands alone: built as a wheel and installed into a fresh
environment, ``taptune demo`` and ``taptune examples`` run from an empty folder; the
source distribution carries the docs, the examples and the tests.

Slow (a wheel and an sdist are built, a venv is made, the demo identifies a holder):
``.ci/run`` runs it explicitly. No network: the build uses this environment's setuptools
and the new venv borrows this environment's installed dependencies (a ``.pth`` file),
never its taptune.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import sysconfig
import tarfile
import venv
from pathlib import Path

import pytest

from tests.conftest import REPO

pytestmark = pytest.mark.slow

JUNK = shutil.ignore_patterns(".git", ".venv", "build", "dist", "*.egg-info", "__pycache__", ".pytest_cache")


def _setuptools_version() -> tuple[int, ...]:
    try:
        from importlib.metadata import version

        return tuple(int(x) for x in version("setuptools").split(".")[:2])
    except Exception:  # not installed, or an odd version string
        return (0,)


@pytest.fixture(scope="module")
def dist(tmp_path_factory) -> Path:
    """The sdist and the wheel, built from a copy of the checkout (the checkout stays clean)."""
    if _setuptools_version() < (77,):
        pytest.skip("building needs setuptools >= 77 (pip install -e '.[dev]')")
    root = tmp_path_factory.mktemp("build")
    src = root / "src"
    shutil.copytree(REPO, src, symlinks=True, ignore=JUNK)
    out = root / "dist"
    code = "from setuptools import build_meta as b; b.build_sdist(r'%s'); b.build_wheel(r'%s')" % (out, out)
    done = subprocess.run([sys.executable, "-c", code], cwd=src, capture_output=True, text=True)
    assert done.returncode == 0, done.stderr[-3000:]
    return out


def test_the_sdist_carries_docs_examples_and_tests(dist):
    (sdist,) = dist.glob("taptune-*.tar.gz")
    with tarfile.open(sdist) as tar:
        names = {n.split("/", 1)[1] for n in tar.getnames() if "/" in n}
    for path in ("LICENSE", "README.md", "dev", "docs/physics.md", "docs/cli.md", "assets/er32_hsk63_d16.toml",
                 "recordings/demo.json", "recordings/er32_d16_tap.wav", "recordings/machine/machine.toml",
                 "tests/conftest.py", "scripts/make_recordings.py", "taptune/examples/recordings/demo.json"):
        assert path in names, path


def test_a_wheel_built_from_the_sdist_carries_the_examples(dist, tmp_path):
    import zipfile

    (sdist,) = dist.glob("taptune-*.tar.gz")
    with tarfile.open(sdist) as tar:
        tar.extractall(tmp_path, filter="data")
    (src,) = tmp_path.glob("taptune-*")
    code = "from setuptools import build_meta as b; print(b.build_wheel(r'%s'))" % (tmp_path / "dist")
    done = subprocess.run([sys.executable, "-c", code], cwd=src, capture_output=True, text=True)
    assert done.returncode == 0, done.stderr[-3000:]
    (wheel,) = (tmp_path / "dist").glob("taptune-*.whl")
    names = set(zipfile.ZipFile(wheel).namelist())
    for rel in ("recordings/demo.json", "recordings/er32_d16_tap.wav", "recordings/machine/spindle_y.csv",
                "assets/hydraulic_hsk63_d20.toml"):
        assert f"taptune/examples/{rel}" in names, rel


def test_the_installed_wheel_runs_the_demo_and_copies_the_examples(dist, tmp_path):
    (wheel,) = dist.glob("taptune-*.whl")
    env_dir = tmp_path / "venv"
    venv.EnvBuilder(with_pip=False).create(env_dir)
    python = env_dir / "bin" / "python"
    site = Path(subprocess.check_output([python, "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])"],
                                        text=True).strip())
    # The dependencies from this environment; its own taptune (an editable install's
    # finder is a .pth that a plain path line does not run) stays out of reach.
    (site / "borrowed.pth").write_text(sysconfig.get_paths()["purelib"] + "\n")
    subprocess.run([sys.executable, "-m", "pip", "--python", str(python), "install", "-q", "--no-deps",
                    "--no-index", str(wheel)], check=True, capture_output=True)
    empty = tmp_path / "empty"
    empty.mkdir()
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "TAPTUNE_LIBRARY")}
    env.update(HOME=str(tmp_path / "home"), XDG_CACHE_HOME=str(tmp_path / "cache"), TAPTUNE_CACHE_DIR="off")

    def taptune(*argv):
        return subprocess.run([env_dir / "bin" / "taptune", *argv], cwd=empty, env=env, capture_output=True,
                              text=True, timeout=300)

    where = subprocess.run([python, "-c", "import taptune; print(taptune.__file__)"], cwd=empty, env=env,
                           capture_output=True, text=True, check=True).stdout
    assert Path(where.strip()).is_relative_to(site), where
    demo = taptune("demo")
    assert demo.returncode == 0, demo.stderr
    assert "identified in" in demo.stdout and "truth f1 f2 f3" in demo.stdout
    copied = taptune("examples", "ex")
    assert copied.returncode == 0, copied.stderr
    for rel in ("assets/er32_hsk63_d16.toml", "recordings/er32_d16_tap.wav", "recordings/machine/spindle_x.csv"):
        assert (empty / "ex" / rel).is_file(), rel
    model = taptune("model", "ex/assets/shrinkfit_hsk63_d12.toml")
    assert model.returncode == 0 and "f [Hz]" in model.stdout, model.stderr
    assert list(empty.iterdir()) == [empty / "ex"]  # nothing else written into the working folder
