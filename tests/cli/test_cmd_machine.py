"""``taptune toolpoint``, ``lobes`` and ``spindle`` (docs/machine.md): contract, accuracy, bad inputs.

End to end on the bundled synthetic machine (recordings/machine/) and, when present, on
the independent check case /work/shared/cases-dev/machine-d01 (its truth files were made
by a separate implementation: a direct solve of the cut model with the spindle attached).
"""

from __future__ import annotations

import json
import shutil

import numpy as np
import pytest

from tests.conftest import REPO
from tests.cli_run import one_line_error, taptune

RECORDINGS = REPO / "recordings"
DEMO = [RECORDINGS / "er32_d16.toml", "--params", RECORDINGS / "er32_d16.params.json",
        "--machine", RECORDINGS / "machine" / "machine.toml"]
D01 = REPO.parent / "shared" / "cases-dev" / "machine-d01"
needs_d01 = pytest.mark.skipif(not D01.is_dir(), reason="the machine-d01 check case is not here")


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


def test_toolpoint_warns_of_a_catalogue_gauge_length_that_the_segments_contradict(tmp_path, capsys):
    toml = tmp_path / "x100.toml"
    text = (RECORDINGS / "er32_d16.toml").read_text()
    toml.write_text(text.replace('interface = "HSK-A63"', 'interface = "HSK-A63"\ngauge_length = 100.0', 1))
    code, out, err = taptune(capsys, "toolpoint", toml, *DEMO[1:], "--freq", 100, 8000, 50)
    assert code == 0, err
    assert "x100.toml: [holder] gauge_length = 100 mm puts the coupling plane 0 mm" in out + err


def test_outputs_never_overwrite_the_spindle_files_a_machine_file_names(tmp_path, capsys, monkeypatch):
    shutil.copytree(RECORDINGS / "machine", tmp_path / "m")
    monkeypatch.chdir(tmp_path / "m")
    before = (tmp_path / "m" / "spindle_x.csv").read_bytes()
    base = [RECORDINGS / "er32_d16.toml", "--params", RECORDINGS / "er32_d16.params.json", "--machine", "machine.toml"]
    err = one_line_error(capsys, "toolpoint", *base, "--csv", "spindle_x.csv")
    assert err.startswith("taptune toolpoint: spindle_x.csv: is also an input of this command"), err
    one_line_error(capsys, "lobes", *base, "--teeth", 3, "--ae", 5, "--milling", "down", "--material", "al7075",
                   "--json", tmp_path / "m" / "spindle_x.csv")
    assert (tmp_path / "m" / "spindle_x.csv").read_bytes() == before


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


# --------------------------------------------------------------------------- lobes


LOBES_KEYS = {"rpm", "a_lim_mm", "a_crit_mm", "pockets", "chatter_hz"}


def test_lobes_single_mode_slotting_matches_the_closed_form(tmp_path, capsys):
    """Closed form of the zero-order method (Altintas & Budak 1995): slotting, x flexible with one mode, y rigid: a_lim,min = 8 k ζ (1 + ζ) / (N K_rc)
    = 1.679 mm for k = 1e7 N/m, ζ = 0.02, N = 4, K_rc = 243 MPa (K_tc does not enter)."""
    k, zeta, fn = 1e7, 0.02, 1200.0
    f = np.arange(600.0, 2400.0 + 0.5, 1.0)
    w, wn = 2 * np.pi * f, 2 * np.pi * fn
    g = 1.0 / (k * (1 - (w / wn) ** 2) + 1j * 2 * zeta * k * w / wn)
    rigid = np.full_like(g, 1e-15 + 0j)
    path = tmp_path / "one_mode.csv"
    from taptune.io.machine import write_toolpoint_csv

    write_toolpoint_csv(path, f, g, rigid)
    out = tmp_path / "l.json"
    code, text, err = taptune(capsys, "lobes", "--frf", path, "--teeth", 4, "--ktc", 902, "--krc", 243,
                              "--diameter", 12, "--ae", 12, "--milling", "down", "--rpm", 2000, 20000, 5, "--json", out,
                              "--method", "zoa")
    assert code == 0, err
    assert "slotting" in text
    data = json.loads(out.read_text())
    assert set(data) >= LOBES_KEYS
    assert data["a_crit_mm"] == pytest.approx(8 * k * zeta * (1 + zeta) / (4 * 243e6) * 1e3, rel=2e-3)
    assert data["a_crit_mm"] == pytest.approx(1.679, rel=2e-3)
    assert data["rpm"][0] == 2000 and data["rpm"][-1] == 20000  # MAX on the grid is included
    # The k = 0 pocket of a single mode lies just above 60 f_n / N (the chatter frequency is above f_n).
    best = data["pockets"][0]
    assert 60 * fn / 4 < best["rpm"] < 1.1 * 60 * fn / 4


def test_lobes_of_a_two_line_frf_name_the_file(tmp_path, capsys):
    frf = tmp_path / "short.csv"
    frf.write_text("f_hz,xx_re,xx_im\n100,1e-7,-1e-9\n200,1e-7,-1e-9\n")
    err = one_line_error(capsys, "lobes", "--frf", frf, "--diameter", 16, "--material", "al6082", "--teeth", 4,
                         "--ae", 8, "--milling", "down")
    assert f"{frf}: the lobes need at least 4 frequencies of the tool-point FRF, got 2" in err


def test_lobes_of_a_tool_that_never_chatters_say_so(tmp_path, capsys):
    """A stiff, real FRF (no negative real part anywhere): no depth chatters — said, not a traceback."""
    f = np.arange(100.0, 5000.0, 10.0)
    frf = tmp_path / "stiff.csv"
    frf.write_text("f_hz,xx_re,xx_im\n" + "".join(f"{x},1e-7,0\n" for x in f))
    code, out, err = taptune(capsys, "lobes", "--frf", frf, "--diameter", 16, "--material", "al6082", "--teeth", 4,
                             "--ae", 8, "--milling", "down", "--json", tmp_path / "l.json", "--plot", tmp_path / "l.png")
    assert code == 0, err
    assert "critical depth (stable at every speed): none: no depth chatters" in out
    assert json.loads((tmp_path / "l.json").read_text())["a_crit_mm"] is None and (tmp_path / "l.png").is_file()


@needs_d01
def test_lobes_from_the_d01_frf_match_the_independent_truth(tmp_path, capsys):
    truth = json.loads((D01 / "lobes_truth.json").read_text())
    a = truth["args"]
    out = tmp_path / "l.json"
    code, _, err = taptune(capsys, "lobes", "--frf", D01 / "toolpoint_frf.csv", "--teeth", a["teeth"], "--ktc", a["ktc"],
                           "--krc", a["krc"], "--diameter", a["diameter"], "--ae", a["ae"], "--milling", a["milling"],
                           "--rpm", *a["rpm"], "--json", out, "--csv", tmp_path / "l.csv", "--method", "zoa")
    assert code == 0, err
    data = json.loads(out.read_text())
    np.testing.assert_allclose(data["rpm"], truth["rpm"])
    envelope = relative_error(data["a_lim_mm"], truth["a_lim_mm"])
    assert np.median(envelope) <= 0.01, np.median(envelope)
    assert data["a_crit_mm"] == pytest.approx(truth["a_crit_mm"], rel=0.01)
    rows = (tmp_path / "l.csv").read_text().splitlines()
    assert rows[0] == "rpm,a_lim_mm,a_lim_mm_safe,chatter_hz,instability" and len(rows) == len(truth["rpm"]) + 1


def test_lobes_on_the_machine_equal_lobes_from_the_toolpoint_csv(tmp_path, capsys):
    """The two routes of docs/machine.md (predicted on the machine, --frf of the written FRF) agree."""
    cut = ["--teeth", 4, "--material", "al6082", "--ae", 8, "--milling", "down", "--rpm", 8000, 20000, 20,
           "--method", "zoa"]
    code, text, err = taptune(capsys, "lobes", *DEMO, *cut, "--freq", 200, 8000, 2, "--json", tmp_path / "a.json",
                              "--plot", tmp_path / "lobes.png")
    assert code == 0, err
    assert "critical depth" in text and "safe pocket [rpm]" in text
    code, _, err = taptune(capsys, "toolpoint", *DEMO, "--freq", 200, 8000, 2, "--csv", tmp_path / "tp.csv")
    assert code == 0, err
    code, _, err = taptune(capsys, "lobes", "--frf", tmp_path / "tp.csv", "--diameter", 16, *cut, "--json", tmp_path / "b.json")
    assert code == 0, err
    a, b = (json.loads((tmp_path / n).read_text()) for n in ("a.json", "b.json"))
    # The CSV holds 10 significant digits; the lobes move by far less than that allows.
    np.testing.assert_allclose(a["a_lim_mm"], b["a_lim_mm"], rtol=1e-6)
    assert a["cut"]["diameter_mm"] == 16.0  # the assembly's flute diameter by default
    assert (tmp_path / "lobes.png").stat().st_size > 10_000


def test_lobes_default_speed_range_reaches_the_machine_top_speed(tmp_path, capsys):
    code, _, err = taptune(capsys, "lobes", *DEMO, "--teeth", 3, "--ktc", 800, "--krc", 200, "--ae", 4, "--milling", "up",
                           "--freq", 200, 8000, 4, "--json", tmp_path / "l.json", "--method", "zoa")
    assert code == 0, err
    rpm = json.loads((tmp_path / "l.json").read_text())["rpm"]
    assert rpm[0] == 500 and rpm[-1] == 24000  # [machine] max_rpm of the example


def test_lobes_bad_inputs_end_in_one_line(tmp_path, capsys):
    cut = ["--teeth", 4, "--ktc", 902, "--krc", 243, "--ae", 5, "--milling", "down"]
    bad = tmp_path / "dup.csv"
    bad.write_text("f_hz,xx_re,xx_im\n100,1e-8,-1e-9\n200,1e-8,-1e-9\n200,1e-8,-1e-9\n")
    assert "dup.csv: frequency 200 Hz appears twice (line 4)" in one_line_error(
        capsys, "lobes", "--frf", bad, "--diameter", 10, *cut)
    good = tmp_path / "good.csv"
    good.write_text("f_hz,xx_re,xx_im\n" + "".join(f"{f},1e-8,-1e-9\n" for f in range(100, 200, 10)))
    assert "--diameter" in one_line_error(capsys, "lobes", "--frf", good, *cut)
    assert "belong to the predicted one" in one_line_error(capsys, "lobes", *DEMO, "--frf", good, "--diameter", 10, *cut)
    assert "--material" in one_line_error(capsys, "lobes", "--frf", good, "--diameter", 10, "--teeth", 4, "--ae", 5,
                                          "--milling", "up")
    assert "unknown work material 'unobtainium'" in one_line_error(
        capsys, "lobes", "--frf", good, "--diameter", 10, "--teeth", 4, "--ae", 5, "--milling", "up", "--material", "unobtainium")
    assert "exceeds the tool diameter" in one_line_error(capsys, "lobes", "--frf", good, "--diameter", 4, *cut)
    assert "--rpm 500 100 10" in one_line_error(capsys, "lobes", "--frf", good, "--diameter", 10, *cut, "--rpm", 500, 100, 10)
    err = one_line_error(capsys, "lobes", "--frf", good, "--diameter", 10, *cut, "--rpm", 100, 1e9, 0.01)
    assert "--rpm 100 1e+09 0.01" in err and "too fine" in err  # not "needs 0 < MIN < MAX"
    assert "--frf FILE" in one_line_error(capsys, "lobes", *cut)
    # The cut is checked before the tool-point FRF is built, in the option's words.
    assert "--ae must be > 0 mm" in one_line_error(capsys, "lobes", *DEMO, "--teeth", 4, "--ktc", 902, "--krc", 243,
                                                   "--ae", -1, "--milling", "down")


# --------------------------------------------------------------------------- spindle


DUMMY = """
[holder]
name = "test dummy D50 x 100"
interface = "HSK-A63"
clamp_length = 1.0
segments = [
  { length = 32.0, od = 48.0, id = 24.0 },
  { length = 10.0, od = 63.0, id = 24.0 },
  { length = 100.0, od = 50.0, id = 0.0 },
]
"""


def dummy_measurements(folder, spindle, points_mm, freq_hz):
    """Hammer tests on the dummy in the spindle: G_ij = H_ij − H_ic (H_cc + H_S)⁻¹ H_cj (inverse RCSA,
    docs/machine.md),
    the dummy's free-free receptances by direct solution (the command uses the modal route).
    Written in three formats: G_aa as .frf text, G_ab as CSV, G_bb as UFF58 (or CSV without pyuff)."""
    from taptune.io.assembly import load_holder
    from taptune.machine.blocks import point_receptance
    from taptune.machine.dummy import dummy_model
    from taptune.model.params import HolderParams

    (folder / "dummy.toml").write_text(DUMMY)
    fe, dofs = dummy_model(load_holder(folder / "dummy.toml"), [p * 1e-3 for p in points_mm])
    h = point_receptance(fe, HolderParams(k_tt=1.0, k_rr=1.0, eta_tt=0.0, eta_rr=0.0), dofs, freq_hz, method="direct")
    x = np.linalg.inv(h[:, 2:, 2:] + spindle.at(freq_hz))
    g = {key: h[:, i, j] - np.einsum("nk,nkl,nl->n", h[:, i, 2:], x, h[:, 2:, j])
         for key, (i, j) in {"aa": (0, 0), "ab": (0, 1), "bb": (1, 1)}.items()}
    paths = {"aa": folder / "g_aa.frf", "ab": folder / "g_ab.csv", "bb": folder / "g_bb.csv"}
    paths["aa"].write_text("".join(f"{f!r}\t{v.real!r}\t{v.imag!r}\n" for f, v in zip(freq_hz.tolist(), g["aa"].tolist())))
    for key in ("ab", "bb"):
        paths[key].write_text("f_hz,re,im\n" + "".join(f"{f!r},{v.real!r},{v.imag!r}\n" for f, v in zip(freq_hz.tolist(), g[key].tolist())))
    try:
        from taptune.library.exchange import write_receptance_uff58

        paths["bb"] = folder / "g_bb.uff"
        write_receptance_uff58(paths["bb"], freq_hz, g["bb"], "G_bb")
    except Exception:  # noqa: BLE001 - without pyuff the CSV stays
        pass
    return paths


def test_spindle_recovers_the_bundled_spindle_from_dummy_tests(tmp_path, capsys):
    """Inverse RCSA identity through files: noise-free dummy FRFs made with the example
    spindle give it back (relative error < 1e-4 in every term; the UFF file holds 12 digits)."""
    from taptune.io.machine import read_spindle

    truth = read_spindle(RECORDINGS / "machine" / "spindle_x.csv")
    freq = np.arange(200.0, 6000.0 + 1, 20.0)
    paths = dummy_measurements(tmp_path, truth, (0.0, 70.0), freq)
    out = tmp_path / "spindle_x.csv"
    code, text, err = taptune(capsys, "spindle", "--dummy", tmp_path / "dummy.toml", "--aa", paths["aa"], "--ab", paths["ab"],
                              "--bb", paths["bb"], "--points", 0, 70, "--out", out, "--json", tmp_path / "s.json",
                              "--plot", tmp_path / "s.png", "--smooth", 0)  # noise-free: the identity, no fit
    assert code == 0, err
    assert "trusted at" in text
    got = read_spindle(out)
    np.testing.assert_allclose(got.freq_hz, freq)
    want = truth.at(freq)
    for i, j in ((0, 0), (0, 1), (1, 1)):
        assert np.median(relative_error(got.h[:, i, j], want[:, i, j])) < 1e-4, (i, j)
    summary = json.loads((tmp_path / "s.json").read_text())
    assert summary["points"] == len(freq) and 0 <= summary["trusted_share"] <= 1
    assert "dummy test dummy D50 x 100" in out.read_text().splitlines()[0]


@needs_d01
def test_spindle_from_the_d01_dummy_matches_its_spindle(tmp_path, capsys):
    from taptune.io.machine import read_spindle

    points = json.loads((D01 / "dummy_truth.json").read_text())["points_mm"]
    out = tmp_path / "sx.csv"
    code, _, err = taptune(capsys, "spindle", "--dummy", D01 / "dummy.toml", "--aa", D01 / "G_aa.csv", "--ab", D01 / "G_ab.csv",
                           "--bb", D01 / "G_bb.csv", "--points", *points, "--out", out)
    assert code == 0, err
    got, truth = read_spindle(out), read_spindle(D01 / "spindle_x.csv")
    for i, j in ((0, 0), (0, 1), (1, 1)):
        assert np.median(relative_error(got.h[:, i, j], truth.h[:, i, j])) <= 0.01, (i, j)


def test_spindle_bad_inputs_end_in_one_line(tmp_path, capsys):
    (tmp_path / "dummy.toml").write_text(DUMMY)
    a = tmp_path / "a.csv"
    a.write_text("f_hz,re,im\n100,1e-8,-1e-9\n200,1e-8,-1e-9\n300,1e-8,-1e-9\n")
    b = tmp_path / "b.csv"
    b.write_text("f_hz,re,im\n100,1e-8,-1e-9\n250,1e-8,-1e-9\n300,1e-8,-1e-9\n")
    base = ["spindle", "--dummy", tmp_path / "dummy.toml", "--points", 0, 60]
    assert "differs from" in one_line_error(capsys, *base, "--aa", a, "--ab", b, "--bb", a, "--out", tmp_path / "s.csv")
    assert "name the file .csv" in one_line_error(capsys, *base, "--aa", a, "--ab", a, "--bb", a, "--out", tmp_path / "s.uff")
    assert "--smooth" in one_line_error(capsys, *base, "--aa", a, "--ab", a, "--bb", a, "--out", tmp_path / "s.csv",
                                        "--smooth", "lots")
    # One file (or a copy) for two measurements: a mistake the inverse coupling would not notice.
    c = tmp_path / "c.csv"
    c.write_text(a.read_text().replace("-1e-9\n300", "-2e-9\n300"))
    assert f"{a}: --bb holds the same FRF as --aa ({a})" in one_line_error(
        capsys, *base, "--aa", a, "--ab", c, "--bb", a, "--out", tmp_path / "s.csv")
    assert "missing.frf: no such file" in one_line_error(capsys, *base, "--aa", tmp_path / "missing.frf", "--ab", a, "--bb", a,
                                                          "--out", tmp_path / "s.csv")
    bad = tmp_path / "bad.frf"
    bad.write_text("100\t1e-8\t-1e-9\n200\tabc\t-1e-9\n")
    assert "bad.frf: line 2, column real: 'abc' is not a number" in one_line_error(
        capsys, *base, "--aa", bad, "--ab", a, "--bb", a, "--out", tmp_path / "s.csv")
    assert "no such file" in one_line_error(capsys, "spindle", "--dummy", tmp_path / "none.toml", "--points", 0, 60,
                                            "--aa", a, "--ab", a, "--bb", a, "--out", tmp_path / "s.csv")
    assert not (tmp_path / "s.csv").exists()


def test_toolpoint_contact_models_differ_as_physics_says(tmp_path, capsys):
    """A rigidly tied tool is stiffer than one held by the identified compliant layer: its strongest
    tool mode on the machine is higher (comparison of `--contact`, docs/machine.md)."""
    tops = {}
    for contact in ("distributed", "rigid", "lumped"):
        out = tmp_path / f"{contact}.json"
        code, _, err = taptune(capsys, "toolpoint", *DEMO, "--freq", 2000, 6000, 4, "--contact", contact, "--json", out)
        assert code == 0, err
        pred = json.loads(out.read_text())["predictions"][0]
        assert pred["contact"] == contact
        g = complex_of(pred["x"])
        tops[contact] = pred["frequency_hz"][int(np.argmax(np.abs(g)))]
    assert tops["rigid"] > tops["distributed"]
    assert tops["lumped"] != tops["distributed"]


def test_holder_from_the_library_is_read_only_and_equals_its_params(tmp_path, capsys):
    """--holder takes the library entry's parameters (here the example's true ones): the same FRF as
    --params with that file, and the library file is not touched."""
    from taptune.cli.cmd_model import read_params_file
    from taptune.library import HolderLibrary
    from taptune.library.schema import HolderEntry
    from tests.library.entries import REFERENCE

    params = read_params_file(RECORDINGS / "er32_d16.params.json")
    entry = HolderEntry.create(REFERENCE.holder, params, param_sets=(params,))
    library = tmp_path / "lib.json"
    HolderLibrary(library).put(entry)
    before = library.read_bytes()
    grid = ["--freq", 1000, 6000, 10]
    code, _, err = taptune(capsys, "toolpoint", RECORDINGS / "er32_d16.toml", "--holder", entry.name, "--library", library,
                           "--machine", RECORDINGS / "machine" / "machine.toml", *grid, "--json", tmp_path / "lib.json.out")
    assert code == 0, err
    code, _, err = taptune(capsys, "toolpoint", *DEMO, *grid, "--json", tmp_path / "params.json.out")
    assert code == 0, err
    a, b = (json.loads((tmp_path / n).read_text())["predictions"][0] for n in ("lib.json.out", "params.json.out"))
    np.testing.assert_allclose(complex_of(a["x"]), complex_of(b["x"]), rtol=1e-9)
    assert library.read_bytes() == before


@pytest.mark.skipif(not hasattr(__import__("signal"), "SIGKILL"), reason="needs POSIX signals")
def test_ctrl_c_during_the_semi_discretization_ends_at_once_in_one_line():
    """Ctrl-C reaches the whole process group, the lobes' forked processes too: they leave it
    to the command, which stops them and says so in one line (exit 130), at once."""
    import os
    import signal
    import subprocess
    import sys
    import time

    env = dict(os.environ, OPENBLAS_NUM_THREADS="1", PYTHONPATH=str(REPO))
    proc = subprocess.Popen([sys.executable, "-m", "taptune", "lobes", str(RECORDINGS / "er32_d16.toml"),
                             "--params", str(RECORDINGS / "er32_d16.params.json"),
                             "--machine", str(RECORDINGS / "machine" / "machine.toml"), "--material", "al6082",
                             "--teeth", "4", "--ae", "8", "--milling", "down", "--method", "sdm"],
                            env=env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True,
                            start_new_session=True)
    try:
        time.sleep(2.0)  # imports done, the speed ranges' processes computing (about 7 s in all)
        assert proc.poll() is None
        os.killpg(proc.pid, signal.SIGINT)
        _, err = proc.communicate(timeout=5)
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
            proc.wait()
    assert proc.returncode == 130 and err.strip() == "taptune lobes: interrupted"
