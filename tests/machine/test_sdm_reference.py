"""taptune's semi-discretization held to an independent reference (benchmarks/sdm_reference.py).

The reference is piecewise Chebyshev collocation of the milling delay equation, written
from the papers (Insperger & Stépán 2004 for the model; Butcher et al. 2004 and
Khasawneh & Mann 2013 for the method) and sharing no code with taptune.machine; it
converges exponentially with the polynomial degree. The full sweep over 5,000–25,000 rpm
is ``benchmarks/validate_sdm.py`` (500–5,000 rpm: ``--low``); here a few speeds per case at a
coarser but still converged resolution.
"""

from __future__ import annotations

import numpy as np
import pytest

from benchmarks import sdm_reference as ref
from benchmarks.validate_sdm import (ASYM_MODES, BENCH_CUT, BENCH_MODES, MILL_CUT, MILL_MODES, TOOL3_CUT, TOOL3_MODES,
                                     taptune_sdm)

MM = 1e-3
#: Resolution of the reference here: 2 elements of degree 8 per period of the fastest mode
#: (within 1e-5 of the finest in the benchmark's convergence table).
RES = dict(per_period=2, degree=8)


def _cut(tool, teeth, ratio, milling):
    return ref.Cut(teeth=teeth, ae=ratio * tool["diameter"], milling=milling, **tool)


def test_reference_converges_and_matches_the_published_benchmark():
    """1-DOF benchmark, a/D 0.05 down-milling: the lowest limit 1.09 mm, flip, near 18,200 rpm
    (Insperger & Stépán 2004); the limit there settles to 1e-6 as the collocation is refined."""
    cut = _cut(BENCH_CUT, 2, 0.05, "down")
    at = [ref.limit_at(ref.Monodromy(BENCH_MODES, cut, 18190.0, per_period=e, degree=p), 0.8 * MM, rtol=1e-8)
          for e, p in ((1, 6), (2, 8), (3, 12))]
    assert abs(at[1][0] / at[2][0] - 1) < 1e-6
    assert abs(at[0][0] / at[2][0] - 1) < 1e-3
    lim = ref.limits(BENCH_MODES, cut, np.arange(18000.0, 18401.0, 20.0), floor=0.8 * MM, **RES)
    i = int(np.argmin(lim.a_lim))
    assert lim.a_lim[i] == pytest.approx(1.09 * MM, rel=0.015)
    assert lim.rpm[i] == pytest.approx(18200.0, abs=100)
    assert lim.kind[i] == "flip"


def _constant_force_limit(modes, cut, rpm):
    """Exact limit of a cut whose directional matrix W is constant: 4 teeth slotting gives
    W = [[−K_n, −K_t], [K_t, −K_n]] (two teeth a quarter turn apart), and with equal x and y
    modes r = a G(iω) W (1 − e^{−iωτ}) r splits along W's eigenvalues λ = −K_n ± iK_t into
    1 = a λ G(iω)(1 − e^{−iωτ}): the least real a > 0 over the chatter frequencies ω."""
    tau = 60.0 / (cut.teeth * rpm)
    f = np.linspace(1500.0, 6000.0, 200001)
    g, _ = ref.frf(modes, f)
    best = np.inf
    for lam in (complex(-cut.kn, cut.kt), complex(-cut.kn, -cut.kt)):
        for sign in (1.0, -1.0):  # ω > 0 and ω < 0 (G(−iω) = conj G(iω))
            w = sign * 2 * np.pi * f
            gg = g if sign > 0 else np.conj(g)
            h = 1.0 / (lam * gg * (1 - np.exp(-1j * w * tau)))
            ok = (h.real > 0) & (np.abs(h) < 1.0)  # a real depth below 1 m (not a pole of h)
            k = np.flatnonzero((np.sign(h.imag[:-1]) != np.sign(h.imag[1:])) & ok[:-1] & ok[1:])
            for i in k:
                t = h.imag[i] / (h.imag[i] - h.imag[i + 1])
                best = min(best, float(h.real[i] + t * (h.real[i + 1] - h.real[i])))
    return best


@pytest.mark.parametrize("rpm", [9000.0, 15000.0, 24000.0])
def test_reference_is_exact_where_the_force_is_constant(rpm):
    """4-tooth slotting with equal x and y modes: the delay equation has constant
    coefficients and its limit a closed form; the reference agrees to 1e-5, up = down."""
    cut = _cut(MILL_CUT, 4, 1.0, "down")
    got = ref.limits(MILL_MODES, cut, [rpm], **RES)
    assert got.a_lim[0] == pytest.approx(_constant_force_limit(MILL_MODES, cut, rpm), rel=1e-5)
    up = ref.limits(MILL_MODES, _cut(MILL_CUT, 4, 1.0, "up"), [rpm], **RES)
    assert up.a_lim[0] == pytest.approx(got.a_lim[0], rel=1e-9)


CASES = [
    ("1-DOF", BENCH_MODES, BENCH_CUT, 2, 0.05, "down", (6000.0, 9750.0, 14000.0, 18190.0, 22500.0)),
    ("1-DOF", BENCH_MODES, BENCH_CUT, 2, 0.05, "up", (6000.0, 9750.0, 14000.0, 18190.0, 22500.0)),
    ("1-DOF", BENCH_MODES, BENCH_CUT, 2, 0.1, "down", (6000.0, 9750.0, 14000.0, 18130.0, 22500.0)),
    ("1-DOF", BENCH_MODES, BENCH_CUT, 2, 0.1, "up", (6000.0, 9750.0, 14000.0, 18130.0, 22500.0)),
    ("1-DOF", BENCH_MODES, BENCH_CUT, 2, 1.0, "down", (6000.0, 9750.0, 14000.0, 18130.0, 22500.0)),
    ("end mill", MILL_MODES, MILL_CUT, 2, 0.05, "down", (5500.0, 11000.0, 16500.0, 23000.0)),
    ("end mill", MILL_MODES, MILL_CUT, 2, 0.1, "down", (5500.0, 11000.0, 16500.0, 23000.0)),
    ("end mill", MILL_MODES, MILL_CUT, 2, 1.0, "down", (17500.0, 21000.0, 24500.0)),
    ("end mill", MILL_MODES, MILL_CUT, 4, 0.05, "down", (5500.0, 11000.0, 16500.0, 23000.0)),
    ("end mill", MILL_MODES, MILL_CUT, 4, 0.1, "up", (5500.0, 11000.0, 16500.0, 23000.0)),
    ("end mill", MILL_MODES, MILL_CUT, 4, 1.0, "down", (9000.0, 15000.0, 24000.0)),
    ("x ≠ y", ASYM_MODES, MILL_CUT, 2, 0.05, "down", (5500.0, 11000.0, 16500.0, 23000.0)),
    ("x ≠ y", ASYM_MODES, MILL_CUT, 2, 0.05, "up", (5500.0, 11000.0, 16500.0, 23000.0)),
    ("x ≠ y", ASYM_MODES, MILL_CUT, 2, 0.1, "down", (5500.0, 11000.0, 16500.0, 23000.0)),
    ("x ≠ y", ASYM_MODES, MILL_CUT, 2, 0.1, "up", (5500.0, 11000.0, 16500.0, 23000.0)),
]


@pytest.mark.parametrize("name, modes, tool, teeth, ratio, milling, speeds", CASES,
                         ids=[f"{c[0]}-{c[3]}t-aD{c[4]:g}-{c[5]}" for c in CASES])
def test_sdm_limit_and_kind_match_the_reference(name, modes, tool, teeth, ratio, milling, speeds):
    cut = _cut(tool, teeth, ratio, milling)
    speeds = np.array(speeds)
    want = ref.limits(modes, cut, speeds, **RES)
    a, flip, _, _ = taptune_sdm(modes, cut, speeds)
    assert np.all(np.isfinite(a)), "a speed was left to the zero-order lobes"
    np.testing.assert_array_less(np.abs(a / want.a_lim - 1), 0.03)
    assert list(flip) == [k == "flip" for k in want.kind]


@pytest.mark.slow
def test_sdm_covers_a_wide_cut_at_low_speed():
    cut = _cut(MILL_CUT, 2, 1.0, "down")
    speeds = np.array([6000.0, 9000.0, 13000.0])
    want = ref.limits(MILL_MODES, cut, speeds, **RES)
    a, flip, _, _ = taptune_sdm(MILL_MODES, cut, speeds)
    np.testing.assert_array_less(np.abs(a / want.a_lim - 1), 0.03)
    assert list(flip) == [k == "flip" for k in want.kind]


ISLANDS = [  # the speed grid (lowest, highest, step) as the lobes are computed: where main was wrong
    ("1-DOF", BENCH_MODES, BENCH_CUT, 0.1, "up", 8500.0, (8000.0, 9000.0, 250.0)),  # Hopf 3.96 mm over flip from 2.81
    ("1-DOF", BENCH_MODES, BENCH_CUT, 0.1, "up", 11750.0, (11250.0, 12250.0, 250.0)),  # 3.72 mm against 2.49 mm
    ("x ≠ y", ASYM_MODES, MILL_CUT, 0.1, "up", 23250.0, (22750.0, 23750.0, 250.0)),  # 33.6 mm against 25.4 mm
    ("1-DOF", BENCH_MODES, BENCH_CUT, 1.0, "down", 18750.0, (15000.0, 25000.0, 250.0)),  # flip 3.0 over Hopf from 1.44
    ("3+3 modes", TOOL3_MODES, TOOL3_CUT, 0.05, "down", 9740.0, (9740.0, 9740.0, 1.0)),  # Hopf 7.63 over flip from 6.17
]


@pytest.mark.parametrize("name, modes, tool, ratio, milling, rpm, grid", ISLANDS,
                         ids=[f"{c[0]}-aD{c[3]:g}-{c[5]:.0f}" for c in ISLANDS])
def test_sdm_finds_the_island_where_lobes_meet(name, modes, tool, ratio, milling, rpm, grid):
    """Where a flip lobe meets a Hopf lobe, depths in a band below one kind's crossing chatter
    by the other kind; the limit is the band's lower edge, as the reference finds it (at
    18,750 rpm the Hopf band's |μ| barely passes 1.001). The 3+3-mode tool's band starts
    within 10 rpm of 9,740 rpm: a speed alone (no interpolation across that edge)."""
    cut = _cut(tool, 4 if modes is TOOL3_MODES else 2, ratio, milling)
    want = ref.limits(modes, cut, [rpm], **RES)
    speeds = np.arange(grid[0], grid[1] + 1.0, grid[2])
    a, flip, _, _ = taptune_sdm(modes, cut, speeds)
    i = int(np.argmin(np.abs(speeds - rpm)))
    assert a[i] == pytest.approx(want.a_lim[0], rel=0.03)
    assert bool(flip[i]) == (want.kind[0] == "flip")


LOW = [  # many history nodes: 82 (2 teeth, a/D 0.05, 800 rpm) and 60 (4 teeth, a/D 0.1, 1,600 rpm)
    ("end mill", MILL_MODES, MILL_CUT, 2, 0.05, (800.0,)),
    ("end mill", MILL_MODES, MILL_CUT, 4, 0.1, (1600.0,)),
]


@pytest.mark.parametrize("name, modes, tool, teeth, ratio, speeds", LOW,
                         ids=[f"{c[0]}-{c[3]}t-aD{c[4]:g}-{c[5][0]:.0f}" for c in LOW])
def test_sdm_matches_the_reference_at_low_speed(name, modes, tool, teeth, ratio, speeds):
    """At low speed one tooth's cut spans many vibration periods (18 and 13 of the 3.4 kHz
    mode): the multipliers at the speed itself cross the unit circle within 0.5 % of the
    reference's limit, by the same kind (benchmarks/validate_sdm.py --low: 0.02-0.07 %). The
    lobes there are narrower than the ±1.5 % window, so the limit reported for the speed is the
    window's lowest: never above the speed's own, and not far below it."""
    from benchmarks.validate_sdm import taptune_modes
    from taptune.machine.sdm import _is_flip, sdm_growth

    cut = _cut(tool, teeth, ratio, "down")
    speeds = np.array(speeds)
    want = ref.limits(modes, cut, speeds, **RES)
    mx, my = taptune_modes(modes)
    kw = dict(teeth=cut.teeth, ktc=cut.kt, krc=cut.kn, diameter=cut.diameter, ae=cut.ae, milling=cut.milling)
    for rpm, limit, kind in zip(speeds, want.a_lim, want.kind):
        rho, mu = sdm_growth(mx, my, rpm=rpm, depth=np.array([0.995, 1.005]) * limit, **kw)
        assert rho[0] < 1.0 <= rho[1] and bool(_is_flip(mu[1])) == (kind == "flip"), (rpm, rho)
    a, _, _, _ = taptune_sdm(modes, cut, speeds)
    assert np.all((a <= 1.005 * want.a_lim) & (a >= 0.97 * want.a_lim)), a / want.a_lim  # (0.987, 1.000)


@pytest.mark.slow
def test_sdm_lowest_in_the_window_matches_the_reference():
    """Where the lobes are narrower than the speed window a machinist can hold, taptune reports
    the lowest limit within ±DENSE_WINDOW: it must not lie above the reference's lowest in
    that window (found by sampling each lobe and refining its bottom) by more than 1 %.
    The 3+3-mode tool at 1,010 rpm: lobes of its 2.9 kHz modes 2.3 % of the speed wide (samples
    every 1 % of speed alone missed the lobe bottom there: 9 % too deep)."""
    from benchmarks.validate_sdm import ReferenceCache, window_min
    from taptune.machine.sdm import DENSE_WINDOW

    cut = _cut(TOOL3_CUT, 4, 0.05, "down")
    grid = np.arange(900.0, 1121.0, 10.0)
    a, _, _, _ = taptune_sdm(TOOL3_MODES, cut, grid)
    want = window_min(ReferenceCache(None), TOOL3_MODES, cut, 1010.0 * (1 - DENSE_WINDOW), 1010.0 * (1 + DENSE_WINDOW))
    assert a[grid == 1010.0][0] <= 1.01 * want["a"]
