"""The two similarities the lobes' band is built on (taptune.machine.band), against the analytic 1-DOF lobes.

A tool point whose modes all move by a factor s in frequency with their stiffness × s²
(same modal mass), and whose FRF is divided by g (every modal stiffness × g, same
frequencies and damping), has the limit g·s²·a(n/s): the delay equation of the cut is
the same with time scaled by 1/s and the depth by g. For one mode in the feed direction
the zero-order limit is known in closed form (Tlusty; Altintas & Budak 1995):

    a_lim = 2π / (N K_tc α_xx Re G(ω_c)),   lowest at Re G = −1 / (4 k ζ (1 + ζ)),

so the critical depth is 8π k ζ (1 + ζ) / (N K_tc |α_xx|) and the speeds of the lobes
n_k = 60 ω_c / (N (ε + 2kπ)) move with the mode.
"""

from __future__ import annotations

import numpy as np
import pytest

from taptune.machine.band import LobeBand, lobe_band, sample_limits, scale_samples
from taptune.machine.lobes import directional_factors, stability_lobes
from taptune.machine.sdm import sdm_lobes
from taptune.machine.simulate import ModalSet

MM = 1e-3
# The classic 1-DOF benchmark's mode and cut (Insperger & Stépán): 922 Hz, ζ 0.011, k 1.34e6 N/m, 2 teeth.
F_N, ZETA, K = 922.0, 0.011, 1.34e6
CUT = dict(teeth=2, ktc=6e8, krc=2e8, diameter=20 * MM, milling="down")


def _rigid_y():
    return ModalSet([F_N], [ZETA], [1e15])  # a y direction that does not move


def _one_mode_zoa(freq_scale: float, magnitude: float, rpm):
    """Zero-order lobes of the benchmark mode × freq_scale in frequency, stiffness × magnitude·freq_scale²."""
    m = ModalSet([F_N * freq_scale], [ZETA], [K * magnitude * freq_scale**2])
    f = np.arange(100.0, 3000.0, 0.25) * freq_scale
    return stability_lobes(f, m.frf(f), _rigid_y().frf(f), rpm=rpm, ae=20 * MM, **CUT)


@pytest.mark.parametrize("s, g", [(1.0, 1.0), (1.04, 1.0), (0.97, 0.8), (1.0, 1.25)])
def test_zero_order_critical_depth_of_one_mode_is_the_closed_form_times_g_s2(s, g):
    """Slotting, one mode in x: a_crit = 8π k' ζ (1 + ζ) / (N K_tc |α_xx|) with k' = g s² k."""
    rpm = np.arange(2000.0, 12000.0, 5.0) * s
    lobes = _one_mode_zoa(s, g, rpm)
    axx = directional_factors(20 * MM, 20 * MM, "down", CUT["krc"] / CUT["ktc"])[0]
    exact = 8 * np.pi * g * s**2 * K * ZETA * (1 + ZETA) / (CUT["teeth"] * CUT["ktc"] * abs(axx))
    assert lobes.a_lim.min() == pytest.approx(exact, rel=1e-4)


def test_zero_order_lobes_of_a_moved_mode_are_g_s2_a_of_n_over_s():
    rpm = np.arange(3000.0, 9000.0, 5.0)
    s, g = 1.03, 0.85
    base = _one_mode_zoa(1.0, 1.0, rpm / s)
    moved = _one_mode_zoa(s, g, rpm)
    predicted = g * sample_limits(rpm / s, base.a_lim, rpm, [s])[0]
    assert np.median(np.abs(predicted / moved.a_lim - 1)) < 1e-3


def test_semi_discretization_of_a_moved_mode_is_g_s2_a_of_n_over_s():
    """The same similarity for the SDM of an intermittent cut (flip lobes included): the
    discretisation follows the mode's period, so it holds to rounding."""
    rpm = np.array([9000.0, 12000.0, 15000.0, 18200.0, 21000.0])
    s, g = 1.05, 0.8
    cut = dict(CUT, ae=0.05 * 20 * MM)
    base = sdm_lobes(ModalSet([F_N], [ZETA], [K]), None, rpm=rpm, workers=1, **cut)
    moved = sdm_lobes(ModalSet([F_N * s], [ZETA], [K * g * s**2]), None, rpm=rpm * s, workers=1, **cut)
    assert base.flip[2:4].all()  # 15,000 and 18,200 rpm lie on flip lobes (1.08 mm at 18,200: the benchmark)
    np.testing.assert_allclose(moved.a_lim, g * s**2 * base.a_lim, rtol=1e-6)


def test_safe_depth_of_a_magnitude_band_alone_is_its_quantile():
    """With no frequency spread, the safe depth is the (1 − P) quantile of the g samples times the central limit."""
    rpm = np.arange(3000.0, 9000.0, 10.0)
    a = _one_mode_zoa(1.0, 1.0, rpm).a_lim
    scales = np.ones(64)
    mags = np.exp(0.2 * np.linspace(-2, 2, 64))
    band = lobe_band(rpm, a, slice(0, rpm.size), scales, 0.9, magnitudes=mags)
    assert isinstance(band, LobeBand)
    q = np.quantile(mags, 0.1, method="inverted_cdf")
    np.testing.assert_allclose(band.a_safe, q * a, rtol=1e-12)
    assert scale_samples(0.0).size == 1
