"""``taptune toolpoint``, ``lobes`` and ``spindle`` (MACHINE.md): contract, accuracy, bad inputs.

End to end on the bundled synthetic machine (recordings/machine/) and, when present, on
the independent check case /work/shared/cases-dev/machine-d01 (its truth files were made
by a separate implementation: a direct solve of the cut model with the spindle attached).
"""

from __future__ import annotations

import json
import shutil

import numpy as np
import pytest

from taptune.cli import main
from tests.conftest import REPO

RECORDINGS = REPO / "recordings"
DEMO = [RECORDINGS / "er32_d16.toml", "--params", RECORDINGS / "er32_d16.params.json",
        "--machine", RECORDINGS / "machine" / "machine.toml"]
D01 = REPO.parent / "shared" / "cases-dev" / "machine-d01"
needs_d01 = pytest.mark.skipif(not D01.is_dir(), reason="the machine-d01 check case is not here")


def taptune(capsys, *argv) -> tuple[int, str, str]:
    code = main([str(a) for a in argv])
    out, err = capsys.readouterr()
    return code, out, err


def one_line_error(capsys, *argv) -> str:
    """Run a command that must fail on bad input: exit 2, one line on stderr, no traceback."""
    code, out, err = taptune(capsys, *argv)
    assert code == 2, (out, err)
    assert err.count("\n") == 1 and "Traceback" not in err, err
    return err


def relative_error(a, b) -> np.ndarray:
    return np.abs(np.asarray(a) - np.asarray(b)) / np.abs(np.asarray(b))


def complex_of(d: dict) -> np.ndarray:
    return np.asarray(d["re"]) + 1j * np.asarray(d["im"])


# --------------------------------------------------------------------------- toolpoint


def test_toolpoint_on_the_bundled_machine_writes_the_contract(tmp_path, capsys):
    out = tmp_path / "tp.json"
    code, text, err = taptune(capsys, "toolpoint", *DEMO, "--stickout", 53.5, 70, "--freq", 100, 8000, 5,
                              "--json", out, "--csv", tmp_path / "tp.csv")
    assert code == 0, err
    assert "mode [Hz]" in text and "coupling plane: 32 mm" in text
    data = json.loads(out.read_text())
    assert data["holder"] == "ER32 collet chuck HSK-A63 x 100"
    assert data["machine"] == "Example HSK-A63 spindle (synthetic)"
    first, second = data["predictions"]
    assert (first["stickout"], second["stickout"]) == (53.5, 70.0)
    f = np.asarray(first["frequency_hz"])
    assert f[0] == 100 and f[-1] == 8000 and len(f) == 1581  # STOP on the grid is included
    for p in data["predictions"]:
        assert set(p) >= {"stickout", "frequency_hz", "x", "y", "modes"}
        assert {m["direction"] for m in p["modes"]} == {"x", "y"}
        assert all(set(m) >= {"hz", "damping_ratio", "direction"} for m in p["modes"])
    # The y bearings are 5 % stiffer: x and y differ a little, not a lot.
    gx, gy = complex_of(first["x"]), complex_of(first["y"])
    assert 1e-4 < np.median(relative_error(gy, gx)) < 0.1
    # A longer tool is softer: its strongest mode is lower and higher.
    best = [max(p["modes"], key=lambda m: np.abs(complex_of(p["x"])[np.searchsorted(f, m["hz"])])) for p in (first, second)]
    assert best[1]["hz"] < best[0]["hz"]
    # Several stick-outs → one CSV each, named by the stick-out.
    assert (tmp_path / "tp_53.5mm.csv").is_file() and (tmp_path / "tp_70mm.csv").is_file()


def test_toolpoint_uff_export_reads_back(tmp_path, capsys):
    pytest.importorskip("pyuff")
    import pyuff

    out = tmp_path / "tp.uff"
    code, _, err = taptune(capsys, "toolpoint", *DEMO, "--freq", 1000, 6000, 10, "--uff", out, "--json", tmp_path / "t.json")
    assert code == 0, err
    sets = pyuff.UFF(str(out)).read_sets()
    data = json.loads((tmp_path / "t.json").read_text())["predictions"][0]
    assert [s["rsp_dir"] for s in sets] == [1, 2]
    np.testing.assert_allclose(sets[0]["x"], data["frequency_hz"])
    np.testing.assert_allclose(sets[1]["data"], complex_of(data["y"]), rtol=1e-9)


@needs_d01
def test_toolpoint_matches_the_independent_d01_truth(tmp_path, capsys):
    truth = json.loads((D01 / "toolpoint_truth.json").read_text())
    out = tmp_path / "tp.json"
    code, _, err = taptune(capsys, "toolpoint", D01 / "assembly.toml", "--params", D01 / "params.json",
                           "--machine", D01 / "machine.toml", "--freq", *truth["freq_arg"], "--json", out)
    assert code == 0, err
    pred = json.loads(out.read_text())["predictions"][0]
    np.testing.assert_allclose(pred["frequency_hz"], truth["frequency_hz"])
    for d in ("x", "y"):
        err = relative_error(complex_of(pred[d]), complex_of(truth[d]))
        assert np.median(err) <= 0.01, (d, np.median(err))


# --------------------------------------------------------------------------- bad inputs


def test_toolpoint_bad_inputs_end_in_one_line(tmp_path, capsys):
    machine = RECORDINGS / "machine" / "machine.toml"
    err = one_line_error(capsys, "toolpoint", RECORDINGS / "er32_d16.toml", "--params", RECORDINGS / "er32_d16.params.json",
                         "--machine", tmp_path / "none.toml")
    assert "none.toml: no such file" in err
    err = one_line_error(capsys, "toolpoint", *DEMO, "--freq", 10, 20000, 5)
    assert "cover 50–15000 Hz" in err
    err = one_line_error(capsys, "toolpoint", RECORDINGS / "er32_d16.toml", "--machine", machine)
    assert "--holder" in err  # argparse: one of --holder/--params is required
    err = one_line_error(capsys, "toolpoint", RECORDINGS / "er32_d16.toml", "--params", RECORDINGS / "er32_d16.params.json")
    assert "--machine" in err
    # A broken spindle file named by a good machine file: the message names the CSV and the line.
    folder = tmp_path / "m"
    folder.mkdir()
    shutil.copy(machine, folder / "machine.toml")
    shutil.copy(machine.parent / "spindle_x.csv", folder / "spindle_x.csv")
    lines = (machine.parent / "spindle_y.csv").read_text().splitlines()
    lines[10] = lines[10].replace(lines[10].split(",")[2], "nan", 1)
    (folder / "spindle_y.csv").write_text("\n".join(lines) + "\n")
    err = one_line_error(capsys, "toolpoint", RECORDINGS / "er32_d16.toml", "--params", RECORDINGS / "er32_d16.params.json",
                         "--machine", folder / "machine.toml")
    assert "spindle_y.csv: line 11, column h_wf_im: nan is not a finite number" in err
    # --holder reads the library and never writes it.
    library = tmp_path / "lib.json"
    err = one_line_error(capsys, "toolpoint", RECORDINGS / "er32_d16.toml", "--holder", "nothing", "--library", library,
                         "--machine", machine)
    assert "nothing" in err and not library.exists()
