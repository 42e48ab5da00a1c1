"""Observed cuts move the holder's band: simulated observations of a tool point shifted by a known factor."""

from __future__ import annotations

import numpy as np
import pytest

from taptune.machine.band import extended_grid, sample_limits, scale_samples
from taptune.machine.lobes import stability_lobes
from taptune.machine.observed import comparable, lobes_with_observations, observed_band
from taptune.machine.simulate import ModalSet

MODES = ModalSet((1500.0,), (0.02,), (6e6,))
CUT = dict(teeth=2, ktc=800e6, krc=200e6, diameter=12e-3, ae=3e-3, milling="up")
RPM = np.arange(6000.0, 20001.0, 50.0)
BAND = (0.06, 0.9, "test band ±6 %")


@pytest.fixture(scope="module")
def central():
    """The central lobes (ZOA) on the grid extended for a ±6 % band."""
    f = np.linspace(200, 5000, 961)
    g = MODES.frf(f)
    scales = scale_samples(*BAND[:2])
    ext, inner = extended_grid(RPM, scales)
    lobes = stability_lobes(f, g, g, rpm=ext, method="zoa", **CUT)
    return f, g, ext, inner, scales, np.asarray(lobes.a_lim)


def observe(central, s_true, n, seed):
    """``n`` cuts at random speeds and depths (0.4–2.5 × the true limit), verdicts from the true tool point."""
    _, _, ext, inner, _, a = central
    rng = np.random.default_rng(seed)
    rpm = rng.uniform(RPM[0], RPM[-1], n)
    true = sample_limits(ext, a, rpm, [s_true])[0]
    depth = true * np.exp(rng.uniform(np.log(0.4), np.log(2.5), n))
    return [(float(r), float(d), "stable" if d < t else "chatter") for r, d, t in zip(rpm, depth, true)]


@pytest.mark.parametrize("s_true", [0.95, 1.04])
def test_observations_find_the_true_shift_and_narrow_the_band(central, s_true):
    f, g, ext, inner, scales, a = central
    ob = observed_band(ext, a, inner, scales, observe(central, s_true, 10, seed=3), 0.9, sources="test")
    assert ob.cuts == 10
    assert abs(ob.shift - (s_true - 1)) < 0.012
    assert ob.narrowing > 0.5
    # The weighted safe depth is truly stable almost everywhere; the prior's, on a shifted tool, less often.
    true = sample_limits(ext, a, RPM, [s_true])[0]
    assert np.mean(ob.band.a_safe <= true * 1.001) >= 0.95
    # The band now holds the truth more tightly, though never tighter than the limit's own scatter σ
    # (the next cut varies as the observed ones did): its mean width (a_high - a_low) shrank.
    assert np.mean(ob.band.a_high - ob.band.a_low) < 0.8 * np.mean(ob.prior.a_high - ob.prior.a_low)
    assert ob.depth_narrowing > 0.3


def test_a_chatter_the_band_called_safe_is_warned_and_no_cuts_leave_the_band_as_it_was(central):
    f, g, ext, inner, scales, a = central
    ob = observed_band(ext, a, inner, scales, [], 0.9)
    assert ob.cuts == 0 and ob.narrowing == 0 and ob.band is ob.prior and not ob.warnings
    # Chatter at a quarter of the safe depth: ≥ 90 % of the samples say stable.
    i = len(RPM) // 2
    cut = (float(RPM[i]), 0.25 * float(ob.prior.a_safe[i]), "chatter")
    ob = observed_band(ext, a, inner, scales, [cut, (15000.0, 1e-3, "unclear")], 0.9)
    assert ob.cuts == 1
    assert any("chatter observed at" in w and "confidence" in w for w in ob.warnings)
    # Far outside the band: no sample explains it, and the user is told so.
    assert any("no tool point within the holder's band explains" in w for w in ob.warnings)


def test_lobes_with_observations_is_the_band_with_the_cuts(central):
    f, g, *_ = central
    cuts = observe(central, 1.04, 8, seed=5)
    lobes, ob = lobes_with_observations(f, g, g, rpm=RPM, method="zoa", cuts=cuts, band=BAND, **CUT)
    assert len(lobes.a_lim) == len(RPM) and ob.cuts == 8 and ob.shift > 0.02
    assert ob.band.safe_pockets and "weighed by 8 observed cut(s)" in ob.band.sources


class Obs:
    def __init__(self, **kw):
        self.__dict__.update(dict(teeth=2, milling="up", ae_mm=3.0, ktc_mpa=800.0, krc_mpa=200.0) | kw)


def test_only_the_same_cut_counts():
    obs = [Obs(), Obs(teeth=3), Obs(milling="down"), Obs(ae_mm=6.0), Obs(ktc_mpa=1500.0), Obs(ae_mm=3.05)]
    kept = comparable(obs, teeth=2, ae_mm=3.0, milling="up", ktc_mpa=800.0, krc_mpa=200.0)
    assert kept == [obs[0], obs[5]]
