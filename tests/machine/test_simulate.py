"""Time-domain milling with the regenerative delay (taptune.machine.simulate) and the modal fit.

The 1-DOF benchmark is Insperger & Stépán's (2 teeth, K_t 6e8 N/m², K_n 2e8 N/m²,
f_n 922 Hz, ζ 0.011, k 1.34e6 N/m, a/D = 0.05 down-milling): at 18,150 rpm its
period-doubling (flip) boundary lies near 1.1 mm, and 2.0 mm grows ≈ 1.07× per tooth
period with alternating sign.
"""

from __future__ import annotations

import numpy as np
import pytest

from taptune.errors import InputError
from taptune.machine.simulate import ModalSet, modal_fit, simulate_milling

MM = 1e-3
BENCH = ModalSet([922.0], [0.011], [1.34e6])
CUT = dict(teeth=2, ktc=6e8, krc=2e8, diameter=20 * MM, ae=1 * MM, milling="down")


def test_modal_set_receptance_is_the_viscous_mode():
    f = np.array([0.0, 500.0, 922.0, 2000.0])
    r = f / 922.0
    assert BENCH.frf(f) == pytest.approx(1 / (1.34e6 * (1 - r**2 + 2j * 0.011 * r)), rel=1e-12)
    assert BENCH.frf([300.0]).imag[0] < 0  # e^{iωt}: Im ≤ 0
    with pytest.raises(InputError, match="damping ratios"):
        ModalSet([900.0], [0.0], [1e6])


def test_benchmark_flip_at_18150_rpm_below_bounded_above_grows():
    """Linear runs (no contact loss): growth per tooth period is the critical multiplier's modulus."""
    run = simulate_milling(BENCH, None, rpm=18150, depth=np.array([0.8, 2.0]) * MM, duration_s=0.04, fs=20000,
                           feed_per_tooth=0.1 * MM, contact_loss=False, **CUT)
    assert run.growth[0] < 0.99
    assert run.growth[1] == pytest.approx(1.07, abs=0.02)
    assert run.flip.all()  # the critical multiplier is real and negative
    assert run.x_m.shape == (2, run.t_s.size)


def test_contact_loss_bounds_the_chatter_but_it_dwarfs_a_stable_cut():
    run = simulate_milling(BENCH, None, rpm=18150, depth=np.array([0.8, 2.0]) * MM, duration_s=0.06, fs=20000,
                           feed_per_tooth=0.1 * MM, **CUT)
    last = run.t_s > 0.04
    amp = np.ptp(run.x_m[:, last], axis=1)
    first = np.ptp(run.x_m[:, (run.t_s > 0.002) & (run.t_s < 0.01)], axis=1)
    assert amp[0] < 1.1 * first[0]  # stable: settles to the forced vibration
    assert amp[1] > 5 * amp[0]  # chatter: grows until the tooth leaves the cut
    assert np.all(np.isfinite(run.x_m))
    assert np.min(run.fx_n[1]) > -1e4  # forces stay bounded by the loss of contact


def test_finer_step_changes_the_growth_by_less_than_half_a_percent():
    common = dict(rpm=18150, depth=1.5 * MM, duration_s=0.03, fs=20000, feed_per_tooth=0.1 * MM,
                  contact_loss=False, **CUT)
    coarse = simulate_milling(BENCH, None, steps=200, **common)
    fine = simulate_milling(BENCH, None, steps=600, **common)
    assert coarse.growth[0] == pytest.approx(fine.growth[0], rel=5e-3)


def test_modal_fit_recovers_two_modes_and_refuses_a_flat_frf():
    f = np.arange(200.0, 8000.0, 2.0)
    truth = ModalSet([2900.0, 4300.0], [0.012, 0.02], [2.0e7, 6.0e7])
    g = truth.frf(f)
    fit = modal_fit(f, g)
    assert fit.rel_error < 1e-3
    assert fit.modes.freq_hz == pytest.approx(truth.freq_hz, rel=1e-4)
    assert fit.modes.damping_ratio == pytest.approx(truth.damping_ratio, rel=1e-2)
    assert fit.modes.stiffness_n_m == pytest.approx(truth.stiffness_n_m, rel=1e-2)
    noisy = g * (1 + 0.02 * np.random.default_rng(3).standard_normal(f.size))
    assert modal_fit(f, noisy).rel_error < 0.05
    with pytest.raises(InputError, match="tool.csv: no resonance peak"):
        modal_fit(f, np.full(f.size, -1e-8 + 0j), what="tool.csv")
