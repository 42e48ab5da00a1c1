"""Test set-up: one BLAS thread, offscreen Qt when there is no display, shared fixtures."""

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("OMP_NUM_THREADS", "1")
if not os.environ.get("DISPLAY"):
    os.environ.setdefault("QT_QPA_PLATFORM", "offscreen")
os.environ.setdefault("MPLBACKEND", "Agg")

import atexit  # noqa: E402
import shutil  # noqa: E402
import tempfile  # noqa: E402
from pathlib import Path  # noqa: E402

# The reduced models' disk cache (taptune.io.cache) of this run, never the user's.
os.environ["TAPTUNE_CACHE_DIR"] = tempfile.mkdtemp(prefix="taptune-test-cache-")
atexit.register(shutil.rmtree, os.environ["TAPTUNE_CACHE_DIR"], True)

import pytest  # noqa: E402

REPO = Path(__file__).resolve().parents[1]
# The example assembly of docs/assembly-format.md (the reference assembly of the tests).
REFERENCE_TOML = """
[holder]
name = "ER32 collet chuck HSK-A63 x 100"
interface = "HSK-A63"
clamp_length = 40.0
segments = [
  { length = 32.0, od = 48.0, id = 24.0 },
  { length = 10.0, od = 63.0, id = 24.0 },
  { length = 58.0, od = 50.0, id = 16.0 },
]

[tool]
name = "solid carbide end mill D16 4FL"
total_length = 93.5
shank_diameter = 16.0
flute_length = 32.0
flute_diameter = 16.0

[setup]
stickout = 53.5
"""


@pytest.fixture
def reference_toml(tmp_path) -> Path:
    """The reference assembly (the example of docs/assembly-format.md) written to a temporary file."""
    path = tmp_path / "reference.toml"
    path.write_text(REFERENCE_TOML)
    return path


@pytest.fixture
def reference_assembly(reference_toml):
    from taptune.io.assembly import load_assembly

    return load_assembly(reference_toml)
