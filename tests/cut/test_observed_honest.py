"""The band weighed by observed cuts is honest: over many simulated tool points inside the
holder's band, its safe depth stays at or below the true limit, and the cuts still raise it."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.special import ndtri

from taptune.machine.band import band_samples, extended_grid, sample_limits
from taptune.machine.lobes import stability_lobes
from taptune.machine.observed import observed_band
from taptune.machine.simulate import ModalSet

MODES = ModalSet((1500.0,), (0.02,), (6e6,))
CUT = dict(teeth=2, ktc=800e6, krc=200e6, diameter=12e-3, ae=3e-3, milling="up")
RPM = np.arange(6000.0, 20001.0, 100.0)
#: The band: tool-point frequencies ±6 %, dynamic stiffness ×/÷ 1.6 (90 % bands).
REL, DEPTH = 0.06, 0.6
SCENARIOS = 60


@pytest.fixture(scope="module")
def central():
    f = np.linspace(200, 5000, 961)
    frf = MODES.frf(f)
    s, g = band_samples(REL, 0.9, DEPTH)
    ext, inner = extended_grid(RPM, s)
    return s, g, ext, inner, np.asarray(stability_lobes(f, frf, frf, rpm=ext, method="zoa", **CUT).a_lim)


def scenario(central, seed):
    """A true tool point (s, g) drawn from the band inside its 90 % intervals, 3–15 cuts at random
    speeds and at 0.4–2.5 × its limit, verdicts from its limit; (cuts, true limit on RPM)."""
    _, _, ext, _, a = central
    rng = np.random.default_rng(seed)
    z = rng.standard_normal(64)
    z = z[np.abs(z) < ndtri(0.95)]
    s_true = 1 + REL / ndtri(0.95) * z[0]
    g_true = np.exp(np.log1p(DEPTH) / ndtri(0.95) * z[1])
    n = int(rng.integers(3, 16))
    rpm = rng.uniform(RPM[0], RPM[-1], n)
    limit = g_true * sample_limits(ext, a, rpm, [s_true])[0]
    depth = limit * np.exp(rng.uniform(np.log(0.4), np.log(2.5), n))
    cuts = [(float(r), float(d), "stable" if d < t else "chatter") for r, d, t in zip(rpm, depth, limit)]
    return cuts, g_true * sample_limits(ext, a, RPM, [s_true])[0]


def test_the_weighed_safe_depth_holds_in_nine_scenarios_of_ten_and_rises(central):
    s, g, ext, inner, a = central
    held, prior_held, before, after, narrowed = [], [], [], [], []
    for seed in range(SCENARIOS):
        cuts, true = scenario(central, seed)
        ob = observed_band(ext, a, inner, s, cuts, 0.9, magnitudes=g)
        held.append(np.mean(ob.band.a_safe <= true * 1.001))
        prior_held.append(np.mean(ob.prior.a_safe <= true * 1.001))
        before.append(np.median(ob.prior.a_safe / true))
        after.append(np.median(ob.band.a_safe / true))
        narrowed.append(ob.stiffness_narrowing)
    held, prior_held = np.array(held), np.array(prior_held)
    # Safe at ≥ 90 % of the speeds in ≥ 90 % of the scenarios (the band alone: fewer).
    assert np.mean(held >= 0.9) >= 0.9
    assert np.mean(held >= 0.9) > np.mean(prior_held >= 0.9)
    # The cuts are informative: the safe depth comes closer to the true limit, the stiffness band narrows.
    assert np.median(after) > np.median(before) + 0.05
    assert np.median(narrowed) > 0.2


@pytest.mark.parametrize("g_true", [0.75, 1.3])
def test_cuts_on_a_stiffer_or_softer_tool_move_and_narrow_the_stiffness_band(central, g_true):
    s, g, ext, inner, a = central
    rng = np.random.default_rng(7)
    rpm = rng.uniform(RPM[0], RPM[-1], 12)
    limit = g_true * sample_limits(ext, a, rpm, [1.0])[0]
    depth = limit * np.exp(rng.uniform(np.log(0.5), np.log(2.0), 12))
    cuts = [(float(r), float(d), "stable" if d < t else "chatter") for r, d, t in zip(rpm, depth, limit)]
    ob = observed_band(ext, a, inner, s, cuts, 0.9, magnitudes=g)
    # The weighted median g moves towards the true factor (12 cuts: 0.71 for 0.75, 1.16 for 1.3, the
    # band's prior pulling it towards 1); its band and the limit's narrow.
    assert np.sign(ob.stiffness_shift) == np.sign(g_true - 1)
    assert abs(np.log1p(ob.stiffness_shift) - np.log(g_true)) < 0.15
    assert ob.stiffness_narrowing > 0.3 and ob.depth_narrowing > 0.2
    d = ob.to_dict()
    assert d["toolpoint_stiffness_shift_pct"] == pytest.approx(100 * ob.stiffness_shift)
    assert d["stiffness_band_width_after_pct"] < d["stiffness_band_width_before_pct"]


def test_one_clean_cut_alone_does_not_deepen_the_safe_depth():
    """A single 'stable' verdict may be misheard: at 1.5× the true limit it lifted the safe
    depth above the truth at 43 % of the speeds. The safe depth stays the band's own until a
    second clean cut; chatter still lowers it. 1-DOF tool at 3 kHz, 4 teeth, truth at the
    band's centre (zero-order lobes: exact for this regular cut's envelope in the test's use)."""
    from taptune.machine.band import band_samples, extended_grid
    from taptune.machine.lobes import stability_lobes
    from taptune.machine.observed import observed_band

    rpm = np.linspace(8000, 22000, 281)
    scales, mags = band_samples(0.03, 0.9, 0.6)
    ext, inner = extended_grid(rpm, scales)
    f = np.linspace(100, 12000, 12000)
    w, wn = 2 * np.pi * f, 2 * np.pi * 3000.0
    phi = 1 / (2e7 * (1 - (w / wn) ** 2 + 2j * 0.02 * w / wn))
    a_ext = stability_lobes(f, phi, phi, teeth=4, ktc=700e6, krc=200e6, diameter=0.016, ae=0.004, milling="down",
                            rpm=ext, method="zoa").a_lim
    truth = a_ext[inner]
    i = int(np.argmin(abs(rpm - 14000)))
    one = observed_band(ext, a_ext, inner, scales, [(rpm[i], 1.5 * truth[i], "stable")], 0.9, magnitudes=mags)
    assert np.all(one.band.a_safe <= one.prior.a_safe * (1 + 1e-12))
    assert np.mean(one.band.a_safe > truth) == 0.0
    assert "not raised until two cuts were clean" in one.band.sources
    chatter = observed_band(ext, a_ext, inner, scales, [(rpm[i], 0.8 * truth[i], "chatter")], 0.9, magnitudes=mags)
    assert np.median(chatter.band.a_safe / chatter.prior.a_safe) < 1.0  # chatter lowers it at once
