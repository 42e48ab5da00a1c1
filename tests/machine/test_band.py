"""The holder's uncertainty carried to the lobes (taptune.machine.band) and the FRF files
peers write (CutPro-style .frf with header words and a 0 Hz row, one file per direction)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from taptune.cli import main
from taptune.errors import InputError
from taptune.io.machine import read_toolpoint, write_toolpoint_csv
from taptune.machine import stability_lobes
from taptune.machine.band import (WINDOW_MIN_RPM, WINDOW_REL, check_confidence, lobes_with_band, sample_limits,
                                  scale_samples)
from taptune.machine.simulate import ModalSet

MM = 1e-3
DATA = Path(__file__).parent / "data"
CUT = dict(teeth=3, ktc=902e6, krc=243e6, diameter=12 * MM, ae=3 * MM, milling="down")


def test_a_shifted_and_stiffened_tool_point_is_exactly_the_scaled_lobes():
    """Similarity: modes × s in frequency and × s² in stiffness give s² a(n/s) (here the ZOA, to 0.3 %)."""
    f = np.arange(500.0, 9000.0, 1.0)
    m = ModalSet([2900.0, 4300.0], [0.02, 0.03], [2.0e7, 6.0e7])
    s = 1.03
    rpm = np.arange(15000.0, 30000.0, 10.0)
    base = stability_lobes(f, m.frf(f), m.frf(f), rpm=rpm / s, **CUT)
    moved = m.scaled(s, s * s)
    shifted = stability_lobes(f, moved.frf(f), moved.frf(f), rpm=rpm, **CUT)
    predicted = sample_limits(rpm / s, base.a_lim, rpm, [s])[0]
    assert np.median(np.abs(predicted / shifted.a_lim - 1)) < 3e-3


def test_safe_depth_and_pockets_from_a_two_percent_band():
    f = np.arange(500.0, 9000.0, 2.0)
    m = ModalSet([2900.0, 4300.0], [0.02, 0.03], [2.0e7, 6.0e7])
    g = m.frf(f)
    rpm = np.arange(20000.0, 40000.0, 20.0)
    lobes, band = lobes_with_band(f, g, g, rpm=rpm, method="zoa", confidence=0.9, band=(0.02, 0.9, "test band"),
                                  **CUT)
    assert band.samples >= 50 and band.sources == "test band"
    np.testing.assert_array_equal(lobes.rpm, rpm)
    assert np.all(band.a_safe <= lobes.a_lim * (1 + 1e-9))
    assert np.median(band.a_safe / lobes.a_lim) < 0.95  # the band costs depth somewhere
    assert band.safe_pockets, "a 2 % band leaves safe pockets"
    depths = [p.a for p in band.safe_pockets]
    assert depths == sorted(depths, reverse=True)
    for p in band.safe_pockets:
        assert p.rpm_high - p.rpm_low >= 2 * max(WINDOW_REL * p.rpm, WINDOW_MIN_RPM) - 2 * 20.0
        inside = (rpm >= p.rpm_low) & (rpm <= p.rpm_high)
        assert p.a <= band.a_safe[inside].min() * (1 + 1e-9)  # stable over the whole window
    # Without a band the safe depth is the central one.
    _, none = lobes_with_band(f, g, g, rpm=rpm, method="zoa", **CUT)
    assert none.samples == 1
    np.testing.assert_allclose(none.a_safe, lobes.a_lim)
    assert scale_samples(0.02).std() == pytest.approx(0.02 / 1.645, rel=0.05)


@pytest.mark.parametrize("p", [0.5, 1.0, 1.2, -0.1])
def test_confidence_outside_the_open_interval_is_refused(p):
    with pytest.raises(InputError, match="between 0.5 and 1"):
        check_confidence(p)


def test_peer_frf_files_load_and_give_the_lobes_of_the_same_csv(tmp_path):
    """A CutPro-style pair (header words after the first row, a 0 Hz row) and a CSV of the same data."""
    t = read_toolpoint(DATA / "end_mill_x.frf", DATA / "end_mill_y.frf")
    assert t.freq_hz[0] == 20.0 and not t.y_from_x  # the 0 Hz row dropped
    csv = tmp_path / "same.csv"
    write_toolpoint_csv(csv, t.freq_hz, t.xx, t.yy)
    c = read_toolpoint(csv)
    rpm = np.arange(20000.0, 21000.0, 50.0)
    a = stability_lobes(t.freq_hz, t.xx, t.yy, rpm=rpm, method="sdm", **CUT)
    b = stability_lobes(c.freq_hz, c.xx, c.yy, rpm=rpm, method="sdm", **CUT)
    assert a.method == b.method == "sdm"
    np.testing.assert_allclose(a.a_lim, b.a_lim, rtol=1e-6)
    with pytest.raises(InputError, match="is the x FRF's file too"):
        read_toolpoint(DATA / "end_mill_x.frf", DATA / "end_mill_x.frf")


def run(capsys, *argv):
    code = main([str(a) for a in argv])
    out, err = capsys.readouterr()
    return code, out, err


def test_lobes_command_with_a_tolerance_writes_the_band_keys(tmp_path, capsys):
    out = tmp_path / "l.json"
    code, text, err = run(capsys, "lobes", "--frf", DATA / "end_mill_x.frf", "--frf-y", DATA / "end_mill_y.frf",
                          "--frf-tolerance", 2, "--flute-length", 4, "--diameter", 12, "--teeth", 3, "--ktc", 902,
                          "--krc", 243, "--ae", 3, "--milling", "down", "--rpm", 24000, 30000, 20,
                          "--method", "zoa", "--json", out, "--plot", tmp_path / "l.png")
    assert code == 0, err
    d = json.loads(out.read_text())
    for key in ("rpm", "a_lim_mm", "a_crit_mm", "pockets", "chatter_hz", "cut", "warnings", "method", "instability",
                "confidence", "a_lim_mm_safe", "safe_pockets", "depth_cap_mm", "band_sources"):
        assert key in d, key
    assert d["method"] == "zoa" and d["confidence"] == 0.9 and d["depth_cap_mm"] == 4.0
    assert "--frf-tolerance ±2 %" in d["band_sources"]
    assert max(a for a in d["a_lim_mm"] if a is not None) <= 4.0
    assert all(s <= a + 1e-9 for s, a in zip(d["a_lim_mm_safe"], d["a_lim_mm"]) if s is not None and a is not None)
    assert set(d["safe_pockets"][0]) == {"rpm_low", "rpm_high", "rpm", "a_mm"}
    assert text.index("safe pocket [rpm]") < text.index("critical depth")  # safe pockets first
    assert (tmp_path / "l.png").stat().st_size > 10_000
    code, _, err = run(capsys, "lobes", "--frf", DATA / "end_mill_x.frf", "--diameter", 12, "--teeth", 3, "--ktc", 902,
                       "--krc", 243, "--ae", 3, "--milling", "down", "--confidence", 1.5)
    assert code == 2 and err.count("\n") == 1 and "--confidence must lie strictly between 0.5 and 1" in err


def test_a_band_of_three_has_no_stiffness_part_and_the_damping_spread_adds_in_quadrature():
    from taptune.machine.band import DEPTH_MODEL_FORM, band_parts, band_samples, depth_band

    assert band_parts((0.02, 0.9, "x")) == (0.02, 0.9, "x", 0.0)
    assert band_parts((0.02, 0.9, "x", 0.3))[3] == 0.3
    assert depth_band(0.002, 0.0015) == pytest.approx(np.hypot(0.75, DEPTH_MODEL_FORM))
    s, g = band_samples(0.02, 0.9, 0.3)
    assert s.size == g.size == 64 and abs(np.corrcoef(s, np.log(g))[0, 1]) < 0.1  # independent
    # ±30 % read as a 90 % band of ln g: 90 % of the samples inside [1/1.3, 1.3].
    assert np.mean((g > 1 / 1.3) & (g < 1.3)) == pytest.approx(0.9, abs=0.04)
    s1, g1 = band_samples(0.02, 0.9, 0.0)
    np.testing.assert_array_equal(g1, 1.0)


def test_a_depth_cap_only_cuts_the_band_it_does_not_hide_softer_samples():
    """The central lobes stable up to the flute length say nothing of a softer sample
    (g·s² < 1), whose limit lies below it: with a cap the band must equal the uncapped band,
    then capped. 1-DOF tool (922 Hz, Insperger & Stépán 2004's benchmark) slotting with 4
    teeth, a constant-force cut whose limit has one branch per speed."""
    mode = ModalSet([922.0], [0.011], [1.34e6])
    f = np.arange(100.0, 3000.0, 0.5)
    cut = dict(teeth=4, ktc=6e8, krc=2e8, diameter=20e-3, ae=20e-3, milling="down")
    rpm = np.arange(12000.0, 15000.0, 100.0)
    band = (0.01, 0.9, "test", 0.6)
    res = {}
    for cap in (0.3e-3, np.inf):
        _, b = lobes_with_band(f, mode.frf(f), mode.frf(f), rpm=rpm, method="sdm", depth_cap=cap, band=band,
                               modes=(mode, mode), **cut)
        res[cap] = b.a_safe
    capped, free = res[0.3e-3], np.minimum(res[np.inf], 0.3e-3)
    assert (free < 0.3e-3).any() and (res[np.inf] > 0.3e-3).any()  # the cap bites somewhere, not everywhere
    np.testing.assert_allclose(capped, free, rtol=2e-3)
