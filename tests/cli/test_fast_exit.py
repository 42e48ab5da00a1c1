"""``taptune identify`` as a process ends without the interpreter's teardown (0.1–0.2 s
with numpy and scipy loaded), and still says everything and exits with its status."""

import os
import subprocess
import sys

from tests.conftest import REPO

SCRIPT = """
import atexit, sys
class Teardown:
    def __del__(self):
        print("teardown ran", flush=True)
keep = Teardown()
atexit.register(lambda: print("atexit ran", flush=True))
{before}
sys.argv = ["taptune"] + {argv!r}
from taptune.cli import entry, main
if {in_process!r}:
    print("main returned", main(sys.argv[1:]), flush=True)
try:
    entry()
except SystemExit as exc:
    print("entry returned", exc.code, flush=True)
    raise
"""


def run(argv, before="", in_process=False):
    env = dict(os.environ, OPENBLAS_NUM_THREADS="1", PYTHONPATH=str(REPO))
    return subprocess.run([sys.executable, "-c", SCRIPT.format(argv=argv, before=before, in_process=in_process)], env=env,
                          capture_output=True, text=True, timeout=60)


def test_identify_ends_the_process_after_flushing_and_the_atexit_handlers():
    proc = run(["identify", "--help"])
    assert proc.returncode == 0
    assert "--assembly" in proc.stdout and proc.stdout.rstrip().endswith("atexit ran")
    assert "entry returned" not in proc.stdout and "teardown ran" not in proc.stdout  # no teardown


def test_bad_input_still_says_why_and_exits_2(tmp_path):
    proc = run(["identify", str(tmp_path / "missing.wav"), "--assembly", str(tmp_path / "a.toml"), "--no-save"])
    assert proc.returncode == 2
    assert proc.stderr.strip().splitlines() == [f"taptune identify: {tmp_path / 'a.toml'}: no such file"]
    assert proc.stdout.splitlines() == ["atexit ran"]


def test_other_commands_and_profiled_runs_return_to_the_caller():
    proc = run(["model", "--help"])
    assert proc.returncode == 0 and "entry returned 0" in proc.stdout and "teardown ran" in proc.stdout
    # A profiler writes its results after the entry returns: identify then returns too.
    proc = run(["identify", "--help"], before="sys.setprofile(lambda *a: None)")
    assert proc.returncode == 0 and "entry returned 0" in proc.stdout


def test_main_called_in_process_always_returns():
    proc = run(["identify", "--help"], in_process=True)
    assert proc.returncode == 0 and "main returned 0" in proc.stdout


def test_predict_ends_the_process_with_everything_said_and_the_library_closed(tmp_path, reference_toml):
    import json

    from taptune.library.store import HolderLibrary
    from tests.library.entries import make_entry

    db = tmp_path / "holders.db"
    lib = HolderLibrary(db)
    lib.put(make_entry("A"))
    lib.close()
    out = tmp_path / "p.json"
    proc = run(["predict", str(reference_toml), "--holder", "A", "--library", str(db), "--json", str(out)])
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.rstrip().endswith("atexit ran") and "teardown ran" not in proc.stdout
    assert "holder: A" in proc.stdout and json.loads(out.read_text())["holder"] == "A"
    # Closed before the process ended: the last connection of a WAL database removes the WAL.
    assert not (tmp_path / "holders.db-wal").exists()
