"""Machine files (docs/machine.md): every reader on good input and on each kind of bad input.

Good files round-trip through the writers to the writers' precision (10 significant
digits); every bad file is one InputError that names the file and the problem.
"""

import numpy as np
import pytest

from taptune.errors import InputError
from taptune.io.machine import (
    SpindleReceptance,
    load_machine,
    read_frf,
    read_spindle,
    read_toolpoint_csv,
    write_spindle_csv,
    write_toolpoint_csv,
)
from tests.conftest import REPO

HEADER = "f_hz,h_wf_re,h_wf_im,h_wm_re,h_wm_im,h_tm_re,h_tm_im"


def spindle(n=40):
    """A one-mode spindle: h_wf = 1/(k − mω² + icω), h_wm, h_θm scaled copies [SI]."""
    f = np.linspace(100.0, 5000.0, n)
    w = 2 * np.pi * f
    g = 1.0 / (2e8 - 5.0 * w**2 + 1j * w * 2e3)
    return SpindleReceptance.from_terms(f, g, 8.0 * g, 90.0 * g, "example")


def write(tmp_path, name, text):
    p = tmp_path / name
    p.write_text(text, encoding="utf-8")
    return p


def test_spindle_csv_round_trip(tmp_path):
    s = spindle()
    path = tmp_path / "sub" / "spindle.csv"
    write_spindle_csv(path, s, comments=["made in a test"])
    assert path.read_text().startswith("# made in a test\n" + HEADER)
    back = read_spindle(path)
    np.testing.assert_allclose(back.freq_hz, s.freq_hz, rtol=1e-14)
    np.testing.assert_allclose(back.h, s.h, rtol=1e-9)
    assert np.array_equal(back.h[:, 0, 1], back.h[:, 1, 0])  # reciprocity
    assert back.source == str(path)


def test_spindle_at_interpolates_and_refuses_to_extrapolate(tmp_path):
    s = spindle()
    mid = 0.5 * (s.freq_hz[3] + s.freq_hz[4])
    np.testing.assert_allclose(s.at([mid])[0], 0.5 * (s.h[3] + s.h[4]), rtol=1e-12)
    with pytest.raises(InputError, match=r"example: covers 100–5000 Hz, but 50–6000 Hz was requested"):
        s.at([50.0, 6000.0])


def test_spindle_csv_accepts_comments_blank_lines_extra_columns(tmp_path):
    p = write(tmp_path, "s.csv", "# note\n\n" + HEADER + ",extra\n"
              "100,1e-8,2e-8,3e-7,4e-7,5e-6,6e-6,7\n# mid comment\n200,1e-8,2e-8,3e-7,4e-7,5e-6,6e-6,7\n")
    s = read_spindle(p)
    assert s.h.shape == (2, 2, 2)
    assert s.h[1, 1, 1] == 5e-6 + 6e-6j


@pytest.mark.parametrize("body, message", [
    ("", r"is empty"),
    ("# only a comment\n", r"is empty"),
    (HEADER + "\n", r"has a header but no data rows"),
    ("f_hz,h_wf_re,h_wf_im,h_wm_re,h_wm_im,h_tm_re\n100,1,2,3,4,5\n", r"missing column h_tm_im"),
    (HEADER + "\n100,1,2,3,4,5,6\n200,1,x,3,4,5,6\n", r"line 3, column h_wf_im: 'x' is not a number"),
    (HEADER + "\n100,1,2,3,4,5,6\n200,1,nan,3,4,5,6\n", r"line 3, column h_wf_im: nan is not a finite number"),
    (HEADER + "\n100,1,2,3,4,5,6\n200,1,2,3\n", r"line 3 has 4 values, the header 7"),
    (HEADER + "\n200,1,2,3,4,5,6\n100,1,2,3,4,5,6\n", r"frequencies must ascend, 100 Hz follows 200 Hz \(line 3\)"),
    (HEADER + "\n100,1,2,3,4,5,6\n100,1,2,3,4,5,6\n", r"frequency 100 Hz appears twice \(line 3\)"),
    (HEADER + "\n0,1,2,3,4,5,6\n100,1,2,3,4,5,6\n", r"frequencies must be > 0 Hz, the first is 0 \(line 2\)"),
    (HEADER + "\n100,1,2,3,4,5,6\n", r"needs at least two frequencies, got 1"),
])
def test_spindle_csv_bad_inputs(tmp_path, body, message):
    p = write(tmp_path, "bad.csv", body)
    with pytest.raises(InputError, match=message) as err:
        read_spindle(p)
    assert str(err.value).startswith(str(p)) and "\n" not in str(err.value)


def test_missing_and_unreadable_files(tmp_path):
    with pytest.raises(InputError, match=r"nope.csv: no such file"):
        read_spindle(tmp_path / "nope.csv")
    with pytest.raises(InputError, match=r"is a folder"):
        read_frf(tmp_path)
    p = tmp_path / "binary.csv"
    p.write_bytes(b"\xff\xfe\x00bad")
    with pytest.raises(InputError, match=r"not a UTF-8 text file"):
        read_toolpoint_csv(p)


# --------------------------------------------------------------------------- machine TOML


MACHINE = '[machine]\nname = "M1"\ninterface = "HSK-A63"\n\n[spindle]\nx = "sx.csv"\n'


def test_machine_relative_paths_and_y_defaults_to_x(tmp_path):
    folder = tmp_path / "m"
    write_spindle_csv(folder / "sx.csv", spindle())
    toml = write(folder, "machine.toml", MACHINE)
    m = load_machine(toml)
    assert (m.name, m.interface, m.y_from_x) == ("M1", "HSK-A63", True)
    assert m.y is m.x and m.x.source == str(folder / "sx.csv")
    write_spindle_csv(folder / "sy.csv", spindle(30))
    m = load_machine(write(folder, "two.toml", MACHINE + 'y = "sy.csv"\n'))
    assert not m.y_from_x and m.y.h.shape == (30, 2, 2)
    assert m.to_dict()["spindle_y"] == str(folder / "sy.csv")


@pytest.mark.parametrize("text, message", [
    ("[machine\n", r"not valid TOML"),
    ('[spindle]\nx = "sx.csv"\n', r"\[machine\] is missing"),
    ('[machine]\nname = "M"\ninterface = "HSK-A63"\n', r"\[spindle\] is missing"),
    ('[machine]\ninterface = "HSK-A63"\n[spindle]\nx = "sx.csv"\n', r"\[machine\] name is missing"),
    ('[machine]\nname = "M"\ninterface = "HSK-A63"\n[spindle]\ny = "sx.csv"\n', r"\[spindle\] x is missing"),
    ('[machine]\nname = "M"\ninterface = "HSK-A63"\n[spindle]\nx = 3\n', r"\[spindle\] x must be a non-empty string"),
    (MACHINE + 'z = "sx.csv"\n', r"\[spindle\] z is not a direction"),
    (MACHINE.replace("[spindle]", "max_rpm = -5\n[spindle]"), r"\[machine\] max_rpm must be > 0, got -5"),
    (MACHINE.replace("[spindle]", "max_rpm = 'fast'\n[spindle]"), r"\[machine\] max_rpm must be a number"),
    # Before, a misspelt max_rpm was ignored and the lobes kept their default top speed.
    (MACHINE.replace("[spindle]", "max_rmp = 12000\n[spindle]"),
     r"\[machine\] max_rmp is not a known key; did you mean 'max_rpm'\?"),
])
def test_machine_bad_toml(tmp_path, text, message):
    write_spindle_csv(tmp_path / "sx.csv", spindle())
    p = write(tmp_path, "machine.toml", text)
    with pytest.raises(InputError, match=message) as err:
        load_machine(p)
    assert str(err.value).startswith(str(p))


def test_machine_names_the_missing_spindle_file(tmp_path):
    p = write(tmp_path, "machine.toml", MACHINE)
    with pytest.raises(InputError, match=r"sx.csv: no such file"):
        load_machine(p)


def test_bundled_example_machine():
    m = load_machine(REPO / "recordings" / "machine" / "machine.toml")
    assert m.interface == "HSK-A63" and not m.y_from_x and m.max_rpm == 24000
    for s in (m.x, m.y):
        assert s.freq_hz[0] <= 100 and s.freq_hz[-1] >= 12000
        # A spindle nose on bearings: static compliance of a few nm/N (100-500 N/µm).
        assert 2e-9 < abs(s.h[0, 0, 0]) < 1e-8
    # y bearings 5 % stiffer: smaller static compliance.
    assert abs(m.y.h[0, 0, 0]) < abs(m.x.h[0, 0, 0])
    for name in ("spindle_x.csv", "spindle_y.csv"):
        assert (REPO / "recordings" / "machine" / name).stat().st_size < 200_000


# --------------------------------------------------------------------------- single FRFs


def test_frf_csv_and_frf_text_agree(tmp_path):
    f = np.array([100.0, 150.0, 200.0])
    h = np.array([1e-8 - 2e-9j, 2e-8 - 5e-9j, -1e-8 - 3e-9j])
    csv = write(tmp_path, "g.csv", "f_hz,re,im\n" + "".join(f"{a},{b.real},{b.imag}\n" for a, b in zip(f, h)))
    txt = write(tmp_path, "g.frf", "% CutPro FRF\n" + "".join(f"{a}\t{b.real}\t{b.imag}\n" for a, b in zip(f, h)))
    for p in (csv, txt):
        g = read_frf(p)
        np.testing.assert_array_equal(g.freq_hz, f)
        np.testing.assert_array_equal(g.h, h)
    with pytest.raises(InputError, match=r"g.frf: covers 100–200 Hz, but 90–200 Hz was requested"):
        read_frf(txt).at([90.0, 200.0])


@pytest.mark.parametrize("body, message", [
    ("", r"holds no data"),
    ("100\t1\n", r"line 1 has 2 values, expected frequency, real, imaginary"),
    ("100\t1\t2\n200\tabc\t2\n", r"line 2, column real: 'abc' is not a number"),
    ("100\t1\t2\n90\t1\t2\n", r"frequencies must ascend"),
    ("100\t1\t2\n200\tinf\t2\n", r"not a finite number"),
])
def test_frf_text_bad_inputs(tmp_path, body, message):
    p = write(tmp_path, "g.frf", body)
    with pytest.raises(InputError, match=message):
        read_frf(p)


def uff_set(f, h, rsp_dir, ref_dir):
    from taptune.library.exchange import uff58_dataset

    s = uff58_dataset(f, h, "spindle", "test")
    s.update(rsp_dir=rsp_dir, ref_dir=ref_dir)
    return s


def write_uff(path, sets):
    import pyuff

    pyuff.UFF(str(path)).write_sets(sets, mode="add")  # "add" into a new file (ENV-NOTES.md)
    return path


def test_uff58_spindle_and_frf(tmp_path):
    pytest.importorskip("pyuff")
    s = spindle(25)
    h = s.h
    # h_wm given as θ/f (rotation response, force reference) and with a flipped direction.
    sets = [uff_set(s.freq_hz, h[:, 0, 0], 1, 1), uff_set(s.freq_hz, -h[:, 1, 0], -5, 1),
            uff_set(s.freq_hz, h[:, 1, 1], 5, 5)]
    back = read_spindle(write_uff(tmp_path / "s.uff", sets))
    np.testing.assert_allclose(back.h, h, rtol=1e-9)
    g = read_frf(write_uff(tmp_path / "g.unv", sets[:1]))
    np.testing.assert_allclose(g.h, h[:, 0, 0], rtol=1e-9)
    with pytest.raises(InputError, match=r"needs exactly one FRF dataset 58, found 3"):
        read_frf(tmp_path / "s.uff")
    with pytest.raises(InputError, match=r"missing h_tm"):
        read_spindle(write_uff(tmp_path / "two.uff", sets[:2]))
    with pytest.raises(InputError, match=r"not a readable universal file|needs three FRF datasets"):
        read_spindle(write(tmp_path, "junk.uff", "    -1\n    58\nrubbish\n"))


# --------------------------------------------------------------------------- tool-point FRF


def test_a_toolpoint_frf_of_the_other_sign_convention_is_refused(tmp_path):
    """A direct receptance of a damped tool has Im ≤ 0 (e^{iωt}); a conjugated file gave
    lobes of 0.06 mm. Noise above 0 and a rigid (zero) direction are accepted."""
    f = np.arange(105.0, 5000.0, 10.0)
    h = 1e-7 / (1 - (f / 2000) ** 2 + 0.1j * f / 2000)
    noisy = h + 2e-9j * np.random.default_rng(0).standard_normal(f.size)
    assert np.any(noisy.imag > 0)
    rows = "".join(f"{x},{v.real},{v.imag},0,0\n" for x, v in zip(f, noisy))
    read_toolpoint_csv(write(tmp_path, "ok.csv", "f_hz,xx_re,xx_im,yy_re,yy_im\n" + rows))
    rng = np.random.default_rng(1)
    for k in range(20):  # a rigid direction given as measurement noise: half of these were refused
        rigid = 1e-12 * (rng.standard_normal(f.size) + 1j * rng.standard_normal(f.size))
        rows = "".join(f"{x},{v.real},{v.imag},{r.real},{r.imag}\n" for x, v, r in zip(f, h, rigid))
        read_toolpoint_csv(write(tmp_path, f"rigid{k}.csv", "f_hz,xx_re,xx_im,yy_re,yy_im\n" + rows))
    flip = write(tmp_path, "flip.csv", "f_hz,xx_re,xx_im,yy_re,yy_im\n" + "".join(
        f"{x},{v.real},{v.imag},{v.real},{-v.imag}\n" for x, v in zip(f, h)))
    with pytest.raises(InputError, match=r"flip.csv: yy has mostly positive imaginary parts.*conjugate"):
        read_toolpoint_csv(flip)


def test_toolpoint_round_trip_and_y_from_x(tmp_path):
    f = np.linspace(200.0, 400.0, 5)
    xx = (1 - 2j) * 1e-8 * np.arange(1, 6)  # Im < 0, as a damped tool's direct FRF
    yy = (3 - 1j) * 1e-8 * np.arange(1, 6)
    p = tmp_path / "tp.csv"
    write_toolpoint_csv(p, f, xx, yy, comments=["stick-out 50 mm"])
    t = read_toolpoint_csv(p)
    np.testing.assert_allclose(t.xx, xx, rtol=1e-9)
    np.testing.assert_allclose(t.yy, yy, rtol=1e-9)
    assert not t.y_from_x
    gx, gy = t.at([225.0])
    np.testing.assert_allclose(gx, 0.5 * (xx[0] + xx[1]), rtol=1e-9)
    only_x = write(tmp_path, "x.csv", "f_hz,xx_re,xx_im\n200,1e-8,-1e-9\n300,2e-8,-2e-9\n")
    t = read_toolpoint_csv(only_x)
    assert t.y_from_x and np.array_equal(t.yy, t.xx)
    half = write(tmp_path, "half.csv", "f_hz,xx_re,xx_im,yy_re\n200,1e-8,2e-8,3e-8\n300,1e-8,2e-8,3e-8\n")
    with pytest.raises(InputError, match=r"half.csv: has only one of yy_re, yy_im"):
        read_toolpoint_csv(half)
    with pytest.raises(InputError, match=r"missing column xx_im"):
        read_toolpoint_csv(write(tmp_path, "m.csv", "f_hz,xx_re\n200,1\n"))


def test_writer_refuses_bad_arrays_and_unwritable_paths(tmp_path):
    with pytest.raises(ValueError, match=r"values of shape"):
        write_toolpoint_csv(tmp_path / "a.csv", [1.0, 2.0], [1j], [1j, 2j])
    (tmp_path / "dir.csv").mkdir()
    with pytest.raises(InputError, match=r"dir.csv: cannot write the tool-point FRF"):
        write_toolpoint_csv(tmp_path / "dir.csv", [1.0, 2.0], [1j, 1j], [1j, 2j])


PLAUSIBLE = "1e-8,-2e-8,3e-7,-4e-7,5e-6,-6e-6"


@pytest.mark.parametrize("rows, message", [
    # 1e300 m/N, kHz written as Hz, µm/N written as m/N: refused with the file, the line and the term.
    ([f"100,{PLAUSIBLE}", f"200,1e300,0,3e-7,0,5e-6,0"], r"bad.csv: line 3: \|h_wf\| = 1e\+300 m/N is not a plausible"),
    ([f"100,{PLAUSIBLE}", f"2e9,{PLAUSIBLE}"], r"bad.csv: frequency 2e\+09 Hz \(line 3\) is above 1e\+06 Hz"),
    ([f"100,{PLAUSIBLE}", f"200,0.05,-0.02,3e-7,0,5e-6,0"], r"line 3: \|h_wf\| = 0.0539 m/N .* in SI, m/N"),
    ([f"100,1e-8,0,2e3,0,5e-6,0", f"200,{PLAUSIBLE}"], r"line 2: \|h_wm\| = 2e\+03 1/N"),
    ([f"100,1e-8,0,3e-7,0,-1e9,0", f"200,{PLAUSIBLE}"], r"line 2: \|h_tm\| = 1e\+09 rad/\(N·m\)"),
    ([f"-100,{PLAUSIBLE}", f"200,{PLAUSIBLE}"], r"frequencies must be > 0 Hz, the first is -100 \(line 2\)"),
    ([f"100,{PLAUSIBLE}", f"200,nan,0,0,0,0,0"], r"line 3, column h_wf_re: nan is not a finite number"),
])
def test_absurd_spindle_numbers_are_refused_naming_file_and_row(tmp_path, rows, message):
    p = write(tmp_path, "bad.csv", HEADER + "\n" + "\n".join(rows) + "\n")
    with pytest.raises(InputError, match=message) as err:
        read_spindle(p)
    assert "\n" not in str(err.value)


@pytest.mark.parametrize("name, text, message", [
    ("g.csv", "f_hz,re,im\n100,1e-8,0\n200,1e300,0\n", r"g.csv: line 3: \|w/f\| = 1e\+300 m/N"),
    ("g.frf", "100 1e-8 0\n200 -3 0\n", r"g.frf: line 2: \|w/f\| = 3 m/N"),
    ("t.csv", "f_hz,xx_re,xx_im,yy_re,yy_im\n100,1e-8,0,1e-8,0\n200,1e-8,0,0,7\n", r"t.csv: line 3: \|yy\| = 7 m/N"),
])
def test_absurd_frf_values_are_refused_in_every_reader(tmp_path, name, text, message):
    from taptune.io.machine import read_toolpoint_csv

    reader = read_toolpoint_csv if name.startswith("t") else read_frf
    with pytest.raises(InputError, match=message):
        reader(write(tmp_path, name, text))


def test_a_uff_spindle_with_an_absurd_value_names_the_frequency(tmp_path):
    pytest.importorskip("pyuff")
    s = spindle(5)
    h = s.h.copy()
    h[2, 0, 0] = 1e300
    path = write_uff(tmp_path / "s.uff", [uff_set(s.freq_hz, h[:, 0, 0], 1, 1), uff_set(s.freq_hz, h[:, 0, 1], 1, 5),
                                          uff_set(s.freq_hz, h[:, 1, 1], 5, 5)])
    with pytest.raises(InputError, match=rf"s.uff: at {s.freq_hz[2]:g} Hz: \|h_wf\| = 1e\+300 m/N"):
        read_spindle(path)
