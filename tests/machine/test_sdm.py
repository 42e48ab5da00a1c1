"""Semi-discretization lobes (taptune.machine.sdm) against published benchmark values and
against the time-domain simulation of taptune.machine.simulate, never against the ZOA.

1-DOF benchmark (Insperger & Stépán 2004; Insperger et al. 2008): 2 teeth, K_t 6e8 N/m²,
K_n 2e8 N/m², f_n 922 Hz, ζ 0.011, k 1.34e6 N/m, down-milling. At a/D = 0.05 its lowest
limit is ≈ 1.09 mm on a flip lobe near 18,200 rpm; at a/D = 0.1 ≈ 0.75 mm.
"""

from __future__ import annotations

import numpy as np
import pytest

from taptune.machine import stability_lobes
from taptune.errors import InputError, TaptuneError
from taptune.machine.sdm import sdm_growth, sdm_lobes
from taptune.machine.simulate import ModalSet, simulate_milling

MM = 1e-3
BENCH = ModalSet([922.0], [0.011], [1.34e6])
CUT = dict(teeth=2, ktc=6e8, krc=2e8, diameter=20 * MM, milling="down")
END_MILL_X = ModalSet([2900.0, 4300.0], [0.012, 0.02], [2.0e7, 6.0e7])
END_MILL_Y = ModalSet([2880.0, 4350.0], [0.012, 0.02], [1.8e7, 6.5e7])


@pytest.mark.parametrize("ae, a_min, rpm_min", [(1 * MM, 1.09 * MM, 18200.0), (2 * MM, 0.75 * MM, 18150.0)])
def test_benchmark_lowest_limit_is_a_flip_lobe_near_18000_rpm(ae, a_min, rpm_min):
    lobes = sdm_lobes(BENCH, None, ae=ae, rpm=np.arange(17000.0, 19500.0, 10.0), **CUT)
    i = np.argmin(lobes.a_lim)
    assert lobes.a_lim[i] == pytest.approx(a_min, rel=0.015)
    assert lobes.rpm[i] == pytest.approx(rpm_min, abs=150)
    assert lobes.flip[i]
    assert lobes.chatter_hz[i] == pytest.approx(1.5 * lobes.rpm[i] * 2 / 60, rel=1e-6)  # 3 f_T / 2


@pytest.mark.slow
def test_time_domain_confirms_the_boundary_flip_and_hopf():
    """3 % below the SDM limit the simulated vibration decays, 3 % above it grows, with the kind of chatter SDM says."""
    cases = [(BENCH, None, dict(ae=1 * MM, **CUT), 18150.0, True),
             (END_MILL_X, END_MILL_Y, dict(ae=2 * MM, teeth=3, ktc=902e6, krc=243e6, diameter=12 * MM, milling="up"),
              21000.0, False)]
    for mx, my, cut, rpm, flip in cases:
        lobes = sdm_lobes(mx, my, rpm=np.array([rpm]), **cut)
        a = lobes.a_lim[0]
        assert bool(lobes.flip[0]) is flip
        run = simulate_milling(mx, my, rpm=rpm, depth=np.array([0.97 * a, 1.03 * a]), duration_s=0.05, fs=10000,
                               feed_per_tooth=0.1 * MM, contact_loss=False, **cut)
        assert run.growth[0] < 1 < run.growth[1]
        assert bool(run.flip[1]) is flip


def test_finer_steps_and_more_history_nodes_move_the_multiplier_by_less_than_0_1_percent():
    """Convergence on the end mill at a/D = 0.05, where a fixed coarse step is several % off."""
    cut = dict(teeth=2, ktc=902e6, krc=243e6, diameter=20 * MM, ae=1 * MM, milling="down")
    depths = np.array([1.0, 2.0, 4.0]) * MM
    for rpm in (9000.0, 17000.0, 25000.0):
        base, _ = sdm_growth(END_MILL_X, END_MILL_Y, rpm=rpm, depth=depths, **cut)
        fine, _ = sdm_growth(END_MILL_X, END_MILL_Y, rpm=rpm, depth=depths, steps_per_mode=96, nodes=48, **cut)
        assert np.max(np.abs(base / fine - 1)) < 1e-3


def test_auto_is_sdm_and_sdm_refuses_a_frf_no_mode_reproduces():
    f = np.arange(100.0, 3000.0, 2.0)
    g = BENCH.frf(f)
    args = dict(ae=1 * MM, rpm=np.arange(17000.0, 18000.0, 50.0), **CUT)
    out = stability_lobes(f, g, np.zeros_like(g), method="auto", **args).to_dict()
    assert out["method"] == "sdm" and set(out["instability"]) <= {"hopf", "flip"} and "flip" in out["instability"]
    flat = np.full(f.size, -1e-7 + 0j)
    with pytest.raises(InputError, match="no resonance peak"):
        stability_lobes(f, flat, None, method="sdm", **args)
    with pytest.raises(InputError, match="method must be one of"):
        stability_lobes(f, g, None, method="mf", **args)


def test_depth_cap_limits_what_is_reported_stable():
    f = np.arange(100.0, 3000.0, 2.0)
    g = BENCH.frf(f)
    lobes = stability_lobes(f, g, np.zeros_like(g), method="sdm", depth_cap=3 * MM, ae=1 * MM,
                            rpm=np.arange(13000.0, 16000.0, 50.0), **CUT)
    out = lobes.to_dict()
    assert out["depth_cap_mm"] == pytest.approx(3.0)
    assert max(a for a in out["a_lim_mm"] if a is not None) <= 3.0
    assert all(p["a_lim_mm"] <= 3.0 for p in out["pockets"])


def test_a_slot_at_low_speed_is_semi_discretized_and_converged():
    """Slotting with 2 teeth at 6,000 rpm: ~22 periods of the 4.3 kHz mode in one tooth's cut
    (once handed to the zero-order lobes). The limit holds with 2x finer steps and 1.5x the nodes."""
    cut = dict(teeth=2, ktc=902e6, krc=243e6, diameter=20 * MM, ae=20 * MM, milling="down")
    lobes = sdm_lobes(END_MILL_X, END_MILL_Y, rpm=np.array([6000.0]), **cut)
    a = lobes.a_lim[0]
    assert not lobes.warnings and 0.1 * MM < a < 50 * MM
    fine, _ = sdm_growth(END_MILL_X, END_MILL_Y, rpm=6000.0, depth=np.array([0.99, 1.01]) * a, steps_per_mode=48,
                         nodes=150, **cut)
    assert fine[0] < 1 < fine[1]


def test_the_largest_multiplier_of_a_large_map_is_that_of_all_eigenvalues():
    """Large monodromy maps get their largest multiplier from a few Arnoldi steps."""
    from taptune.machine import sdm

    cut = dict(teeth=2, ktc=902e6, krc=243e6, diameter=20 * MM, ae=20 * MM, milling="up")
    cols = sdm._modal(END_MILL_X, END_MILL_Y)
    geom = sdm._geometry(2, 902e6, 243e6, 20 * MM, 20 * MM, "up")
    tau = 60.0 / (2 * 8000.0)
    plan = sdm._plan(*sdm._resolution(geom[2] * tau, sdm._f_resolve(cols), None, None))
    depth = np.geomspace(0.2, 20.0, 12) * MM
    phi = sdm._monodromy(sdm._steps(cols, geom, 2, cut["ktc"], cut["krc"], np.full(depth.size, tau), plan), depth, plan)
    assert phi.shape[-1] >= sdm.ARNOLDI_MIN
    rho, mu = sdm._critical(phi)
    every = np.linalg.eigvals(phi)
    top = every[np.arange(depth.size), np.argmax(np.abs(every), axis=1)]
    assert rho == pytest.approx(np.abs(top), rel=1e-7)
    assert np.all(np.abs(np.abs(mu.imag) - np.abs(top.imag)) < 1e-6)


@pytest.mark.parametrize("size", [6, 40])
def test_the_flip_and_hopf_branches_are_read_from_the_multipliers(size):
    """The check for a band below a limit reads, besides the largest multiplier, how far the
    multipliers reach along the negative real axis (flip) and the largest complex one (Hopf),
    from all eigenvalues of a small map and from the Arnoldi Ritz values of a large one."""
    from taptune.machine import sdm

    rng = np.random.default_rng(3)
    d = np.zeros(size)
    d[2:] = rng.uniform(-0.3, 0.3, size - 2)
    m = np.diag(d)
    m[0, 0] = -0.95  # a real, negative multiplier (flip branch)
    c, s = 0.9 * np.cos(2.0), 0.9 * np.sin(2.0)  # a complex pair of modulus 0.9 (Hopf branch)
    m[size - 2:, size - 2:] = [[c, -s], [s, c]]
    q, _ = np.linalg.qr(rng.standard_normal((size, size)))
    phi = (q @ m @ q.T)[None]
    rho, mu, neg, cplx = sdm._critical(phi, branches=True)
    assert rho[0] == pytest.approx(0.95, rel=1e-6) and mu[0].real == pytest.approx(-0.95, rel=1e-6)
    assert neg[0] == pytest.approx(0.95, rel=1e-6)
    assert cplx[0] == pytest.approx(0.9, rel=1e-6)


def test_auto_keeps_to_its_time_budget_and_says_below_which_speed():
    """`auto` leaves the slowest speeds of a costly job to the zero-order lobes, with a warning
    naming the speed; `sdm` (no budget) computes them."""
    cut = dict(teeth=2, ktc=902e6, krc=243e6, diameter=20 * MM, ae=20 * MM, milling="down")
    rpm = np.array([5000.0, 24000.0])
    tight = sdm_lobes(END_MILL_X, END_MILL_Y, rpm=rpm, budget=1.0, **cut)
    assert np.isnan(tight.a_lim[0]) and "below" in tight.warnings[0] and "--method sdm" in tight.warnings[0]
    free = sdm_lobes(END_MILL_X, END_MILL_Y, rpm=np.array([5000.0]), **cut)
    assert np.isfinite(free.a_lim[0]) and not free.warnings


TOOL3_X = ModalSet([2900.0, 4300.0, 6100.0], [0.012, 0.02, 0.03], [2.0e7, 6.0e7, 9.0e7])
TOOL3_Y = ModalSet([2880.0, 4350.0, 6000.0], [0.012, 0.02, 0.03], [1.8e7, 6.5e7, 9.0e7])
TOOL3_CUT = dict(teeth=4, ktc=902e6, krc=243e6, diameter=20 * MM, ae=1 * MM, milling="down")


@pytest.mark.parametrize("rpm, band_mm", [(8250.0, (28.9, 30.3)), (12750.0, (14.0, 15.3)), (17750.0, (11.8, 17.3))])
def test_no_depth_below_the_limit_chatters_where_a_weak_band_lies_under_a_stable_one(rpm, band_mm):
    """On a 3+3-mode tool point (4 teeth, a/D 0.05) the largest multiplier lingers near the
    unit circle over wide depth ranges: a weakly unstable band (|μ| ≤ 1.06: 28.7-30.5 mm at
    8,250 rpm, 13.9-15.5 mm at 12,750 rpm, 11.6-17.5 mm at 17,750 rpm) lies under a stable
    band, and a search that steps over it reports 15-300 % too deep. The limit must be the
    smallest depth that chatters on a fine depth scan of the multipliers themselves."""
    from taptune.machine.lobes import zoa_lobes

    f = np.arange(100.0, 9000.0, 2.0)
    speeds = np.arange(5000.0, 25000.0 + 1, 250.0)  # as the validation runs it: one limit per speed
    zoa = zoa_lobes(f, TOOL3_X.frf(f), TOOL3_Y.frf(f), rpm=speeds, **TOOL3_CUT)
    guide = lambda r: np.interp(r, zoa.rpm, np.where(np.isfinite(zoa.a_lim), zoa.a_lim, zoa.a_crit))  # noqa: E731
    lobes = sdm_lobes(TOOL3_X, TOOL3_Y, rpm=speeds, guide=guide, **TOOL3_CUT)
    a = lobes.a_lim[np.flatnonzero(speeds == rpm)[0]]
    inside = np.linspace(*band_mm, 5) * MM
    rho_band, _ = sdm_growth(TOOL3_X, TOOL3_Y, rpm=rpm, depth=inside, **TOOL3_CUT)
    assert np.all(rho_band > 1.0)  # the band is there
    scan = np.geomspace(1.0 * MM, 0.98 * a, 40)
    rho, _ = sdm_growth(TOOL3_X, TOOL3_Y, rpm=rpm, depth=scan, **TOOL3_CUT)
    assert np.all(rho < 1.0), f"chatters at {scan[rho >= 1][0] / MM:.2f} mm below the limit {a / MM:.2f} mm"
    assert a <= band_mm[0] * MM * 1.02


def test_the_grid_across_a_jump_of_the_limit_takes_the_lower_side():
    """Where a weak band ends between two sampled speeds the limit jumps (15.7 mm at 12,780
    rpm, 27.7 mm at 12,790 rpm, 51 mm at 12,810 rpm on the 3+3-mode tool); a straight line
    between samples claimed up to 58 % more depth than the speed's own limit. The jump is
    narrowed down by extra samples and the grid across it takes the lower side: nowhere
    above the point-by-point limit."""
    from taptune.machine.lobes import zoa_lobes

    f = np.arange(100.0, 9000.0, 2.0)
    grid = np.arange(12000.0, 13600.0 + 1, 10.0)
    zoa = zoa_lobes(f, TOOL3_X.frf(f), TOOL3_Y.frf(f), rpm=grid, **TOOL3_CUT)
    guide = lambda r: np.interp(r, zoa.rpm, np.where(np.isfinite(zoa.a_lim), zoa.a_lim, zoa.a_crit))  # noqa: E731
    lobes = sdm_lobes(TOOL3_X, TOOL3_Y, rpm=grid, guide=guide, **TOOL3_CUT)
    near = np.flatnonzero((grid >= 12740.0) & (grid <= 12840.0))
    point = np.array([sdm_lobes(TOOL3_X, TOOL3_Y, rpm=grid[i:i + 1], guide=guide, **TOOL3_CUT).a_lim[0] for i in near])
    assert np.max(point[1:] / point[:-1]) > 1.5  # the jump is there
    assert np.all(lobes.a_lim[near] <= 1.02 * point), np.c_[grid[near], lobes.a_lim[near] / MM, point / MM]


def test_where_lobes_are_denser_than_the_window_its_lowest_limit_is_found():
    """Below ~2,700 rpm the 3+3-mode tool's lobes are 1-2.5 % of the speed wide and the
    reported limit is the lowest within ±1.5 %. Samples 1 % apart stepped over a lobe's narrow
    bottom: at 1,010 rpm 4.12 mm was reported where 1,018.5 rpm (inside the window) chatters
    from 3.77 mm (9 % too deep; the independent reference agrees to 0.01 %). Each local minimum
    now gets samples beside it: the reported depth is within 1 % of that lobe's bottom."""
    from taptune.machine.lobes import zoa_lobes

    f = np.arange(100.0, 8000.0, 1.0)
    grid = np.arange(900.0, 1150.0 + 1, 10.0)
    zoa = zoa_lobes(f, TOOL3_X.frf(f), TOOL3_Y.frf(f), rpm=grid, **TOOL3_CUT)
    guide = lambda r: np.interp(r, zoa.rpm, np.where(np.isfinite(zoa.a_lim), zoa.a_lim, zoa.a_crit))  # noqa: E731
    lobes = sdm_lobes(TOOL3_X, TOOL3_Y, rpm=grid, guide=guide, **TOOL3_CUT)
    a = lobes.a_lim[grid == 1010.0][0]
    rho, _ = sdm_growth(TOOL3_X, TOOL3_Y, rpm=1018.5, depth=np.array([a / 1.01, a / 0.97]), **TOOL3_CUT)
    assert rho[0] < 1.0 <= rho[1], f"{a / MM:.3f} mm reported; |mu| at 1,018.5 rpm: {rho}"


def test_the_lowest_in_the_window_does_not_depend_on_where_the_grid_or_the_budget_ends():
    """Where lobes are denser than the window the limit reported is the lowest within ±1.5 %.
    A speed alone and the ends of a grid had only the samples on their own side of the window:
    1,010 rpm alone read 5.59 mm where the grid 900-1,150 rpm reads 3.77 mm; a grid ending at
    2,750 rpm, just above where the lobes get that dense, read 4.02 mm at 2,740 rpm where
    2,769.6 rpm chatters from 3.70 mm; a lobe's bottom between the last two samples was not
    looked for (+5.8 % at 1,888 rpm), nor one between two samples that were neither a local
    minimum (+7.6 % at 826.1 rpm). The speeds just above where `auto`'s budget hands over
    to the zero-order lobes keep their whole window too, computed in one process or two, and so
    do the speeds beside the seam between two processes."""
    from taptune.machine.lobes import zoa_lobes
    from taptune.machine.sdm import _budgeted_work

    f = np.arange(100.0, 8000.0, 1.0)
    wide = np.arange(900.0, 1150.0 + 1, 10.0)
    zoa = zoa_lobes(f, TOOL3_X.frf(f), TOOL3_Y.frf(f), rpm=wide, **TOOL3_CUT)
    guide = lambda r: np.interp(r, zoa.rpm, np.where(np.isfinite(zoa.a_lim), zoa.a_lim, zoa.a_crit))  # noqa: E731
    ref = sdm_lobes(TOOL3_X, TOOL3_Y, rpm=wide, guide=guide, **TOOL3_CUT)
    at = lambda lobes, r: lobes.a_lim[lobes.rpm == r][0]  # noqa: E731
    for grid in (np.array([1010.0]), np.array([1010.0, 1020.0]), np.arange(1010.0, 1060.0 + 1, 10.0)):
        part = sdm_lobes(TOOL3_X, TOOL3_Y, rpm=grid, guide=guide, **TOOL3_CUT)
        assert at(part, 1010.0) <= 1.005 * at(ref, 1010.0), (grid, at(part, 1010.0) / MM, at(ref, 1010.0) / MM)
    # a budget that stops the semi-discretization at about 1,010 rpm
    cut = dict(TOOL3_CUT, depth_cap=np.inf)
    samples, work, _ = _budgeted_work(TOOL3_X, TOOL3_Y, wide, cut, np.inf)
    budget = float(np.sum(work[samples >= 1008.0]))
    cheap = sdm_lobes(TOOL3_X, TOOL3_Y, rpm=wide, guide=guide, budget=budget, workers=1, **TOOL3_CUT)
    kept = np.isfinite(cheap.a_lim)
    assert 1000.0 <= wide[kept].min() <= 1060.0 and np.isnan(cheap.a_lim[wide < 1000.0]).all()
    assert np.all(cheap.a_lim[kept] <= 1.005 * ref.a_lim[kept]), cheap.a_lim[kept][:4] / ref.a_lim[kept][:4]
    two = sdm_lobes(TOOL3_X, TOOL3_Y, rpm=wide, guide=guide, budget=budget, workers=2, **TOOL3_CUT)
    assert np.array_equal(np.isfinite(two.a_lim), kept) and len(two.warnings) == 1, two.warnings
    # Two processes, their seam at ~910 rpm: a lobe bottom just across it, found by one part, is
    # kept (it was dropped: 0.5 % deeper than one process at 910 rpm).
    wide = np.arange(700.0, 1000.0 + 1, 10.0)
    samples, work, _ = _budgeted_work(TOOL3_X, TOOL3_Y, wide, cut, np.inf)
    budget = float(np.sum(work[samples >= 838.0]))
    one, two = (sdm_lobes(TOOL3_X, TOOL3_Y, rpm=wide, guide=guide, budget=budget, workers=w, **TOOL3_CUT) for w in (1, 2))
    assert np.nanmax(two.a_lim / one.a_lim) < 1.001
    # … and where the grid has no speed near the seam: each process sampled only up to its own
    # last speed (2,386.9 rpm of the two read 24 % too deep)
    sparse = np.array([1794.5, 2386.9])
    one, two = (sdm_lobes(TOOL3_X, TOOL3_Y, rpm=sparse, guide=guide, workers=w, **TOOL3_CUT) for w in (1, 2))
    assert np.max(two.a_lim / one.a_lim) < 1.005, two.a_lim / one.a_lim
    # the grid's upper end, just above where the lobes become denser than the window
    wide = np.arange(2500.0, 3000.0 + 1, 10.0)
    ref = sdm_lobes(TOOL3_X, TOOL3_Y, rpm=wide, guide=guide, **TOOL3_CUT)
    for grid in (np.array([2740.0]), np.array([2740.0, 2750.0]), np.arange(2600.0, 2750.0 + 1, 10.0)):
        part = sdm_lobes(TOOL3_X, TOOL3_Y, rpm=grid, guide=guide, **TOOL3_CUT)
        assert at(part, 2740.0) <= 1.005 * at(ref, 2740.0), (grid, at(part, 2740.0) / MM, at(ref, 2740.0) / MM)
    # a lobe's bottom between the last two samples, past the grid's end but inside its last
    # windows (1,915 rpm, in the window of 1,888 rpm): 1,888 read 5.8 % too deep
    grid = np.arange(1800.0, 1896.0 + 1, 4.0)
    part = sdm_lobes(TOOL3_X, TOOL3_Y, rpm=grid, guide=guide, **TOOL3_CUT)
    rho, _ = sdm_growth(TOOL3_X, TOOL3_Y, rpm=1915.0, depth=np.array([0.995 * at(part, 1888.0)]), **TOOL3_CUT)
    assert rho[0] < 1.0, at(part, 1888.0) / MM
    # a lobe's bottom (825.5 rpm) between two samples that were neither a local minimum (runs of
    # samples settled from below on either side): 826.1 rpm read 7.6 % too deep
    grid = np.r_[np.arange(763.1, 996.9, 9.0), 996.9]
    part = sdm_lobes(TOOL3_X, TOOL3_Y, rpm=grid, guide=guide, workers=1, **TOOL3_CUT)
    rho, _ = sdm_growth(TOOL3_X, TOOL3_Y, rpm=825.5, depth=np.array([0.995 * at(part, 826.1)]), **TOOL3_CUT)
    assert rho[0] < 1.0, at(part, 826.1) / MM


def test_samples_settled_from_below_do_not_make_the_window_read_shallow():
    """Where lobes are denser than the window, a sample stable at a depth already computed
    nearby is settled there with one evaluation (its limit is at least that). Just below where
    the lobes get that dense (2,745 rpm on the 3+3-mode tool) a run of them on a lobe's flank
    gave windows their lowest: 14 of 72 speeds over 2,030-2,740 rpm read more than 5 %
    shallower than the lowest of the limits computed every 2 rpm (down to 0.78 of it). Those
    samples are searched now (10 of 72 left: where a window's edge falls in a jump between two
    samples, whose lower side is taken there)."""
    from taptune.machine.lobes import zoa_lobes
    from taptune.machine.sdm import DENSE_WINDOW, _f_resolve, _geometry, _islands, _limits, _modal

    f = np.arange(100.0, 8000.0, 1.0)
    grid = np.arange(2000.0, 2800.0 + 1, 10.0)
    zoa = zoa_lobes(f, TOOL3_X.frf(f), TOOL3_Y.frf(f), rpm=grid, **TOOL3_CUT)
    guide = lambda r: np.interp(r, zoa.rpm, np.where(np.isfinite(zoa.a_lim), zoa.a_lim, zoa.a_crit))  # noqa: E731
    lobes = sdm_lobes(TOOL3_X, TOOL3_Y, rpm=grid, guide=guide, **TOOL3_CUT)
    # the limit every 2 rpm, each searched on its own
    fine = np.arange(1995.0, 2815.0, 2.0)
    cols = _modal(TOOL3_X, TOOL3_Y)
    run = (cols, _geometry(4, 902e6, 243e6, 20 * MM, 1 * MM, "down"), 4, 902e6, 243e6, _f_resolve(cols), np.inf)
    tau = 60.0 / (4 * fine)
    a, fl, ch = _limits(run, tau, guide(fine), np.ones(fine.size, bool))
    _islands(run, tau, a, fl, ch, guide(fine), np.ones(fine.size, bool))
    check = (grid >= 2030.0) & (grid <= 2740.0)
    lowest = np.array([a[np.abs(fine / g - 1) <= DENSE_WINDOW].min() for g in grid[check]])
    ratio = lobes.a_lim[check] / lowest
    assert ratio.max() < 1.005 and np.sum(ratio < 0.95) <= 11, np.round(ratio, 3)  # (10 now, the lowest 0.80)


def test_a_weak_band_under_the_flute_length_is_found_too():
    """With the flute length as the depth cap a speed stable up to the cap was never checked
    for a weak band below it, and a search restarted from such a band began at half the cap
    and stepped over it: 12,750 rpm read 'stable to the 20 mm cap' where 13.9-15.5 mm chatters."""
    from taptune.machine.lobes import zoa_lobes

    f = np.arange(100.0, 9000.0, 2.0)
    speeds = np.arange(5000.0, 25000.0 + 1, 250.0)
    zoa = zoa_lobes(f, TOOL3_X.frf(f), TOOL3_Y.frf(f), rpm=speeds, **TOOL3_CUT)
    guide = lambda r: np.interp(r, zoa.rpm, np.where(np.isfinite(zoa.a_lim), zoa.a_lim, zoa.a_crit))  # noqa: E731
    lobes = sdm_lobes(TOOL3_X, TOOL3_Y, rpm=speeds, guide=guide, depth_cap=20 * MM, **TOOL3_CUT)
    a = lobes.a_lim[speeds == 12750.0][0]
    rho, _ = sdm_growth(TOOL3_X, TOOL3_Y, rpm=12750.0, depth=np.array([0.98 * a, 14.5 * MM]), **TOOL3_CUT)
    assert a < 14.2 * MM and rho[0] < 1.0 < rho[1]


def test_a_single_speed_left_to_the_zero_order_lobes_is_not_called_stable():
    """Alone on the grid, a speed below the history's reach read inf (stable at any depth)
    beside the warning that the zero-order lobes stand in there; it is NaN (not computed)."""
    lobes = sdm_lobes(TOOL3_X, TOOL3_Y, rpm=np.array([300.0]), **TOOL3_CUT)
    assert np.isnan(lobes.a_lim[0]) and "zero-order" in lobes.warnings[0]
    f = np.arange(100.0, 9000.0, 2.0)
    full = stability_lobes(f, TOOL3_X.frf(f), TOOL3_Y.frf(f), rpm=np.array([300.0]), method="sdm",
                           modes=(TOOL3_X, TOOL3_Y), **TOOL3_CUT)
    assert np.isfinite(full.a_lim[0])  # the zero-order limit, with the warning


def _part_or_error(k):
    if k == 1:
        raise InputError("part 1 cannot be computed")
    return k * k


def test_forked_parts_return_in_order_raise_what_a_part_raised_and_leave_no_process():
    """The speed ranges' processes (sdm._forked): results in order; a part's exception is
    raised here as it was; a process that dies is an error, not a wait for ever."""
    import multiprocessing
    import os

    from taptune.machine import sdm

    before = set(multiprocessing.active_children())
    assert sdm._forked(lambda k: k * k, 3) == [0, 1, 4]
    with pytest.raises(InputError, match="part 1 cannot"):
        sdm._forked(_part_or_error, 3)
    with pytest.raises(TaptuneError, match=r"ended without its result \(exit code 3\)"):
        sdm._forked(lambda k: os._exit(3), 2)
    assert set(multiprocessing.active_children()) <= before
