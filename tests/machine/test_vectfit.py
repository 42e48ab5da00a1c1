"""Common-pole rational fit (vector fitting) and the FRF noise estimate used before inverse RCSA."""

from __future__ import annotations

import numpy as np

from taptune.machine.dummy import frf_noise
from taptune.machine.vectfit import fit_frfs


def hysteretic_frfs(f):
    """Two FRFs sharing three hysteretic modes Σ φφ / (λ − ω²), λ = ω_r²(1 + iη): no conjugate pole pairs."""
    w2 = (2 * np.pi * f) ** 2
    lam = (2 * np.pi * np.array([900.0, 2600.0, 5100.0])) ** 2 * (1 + 1j * np.array([0.02, 0.01, 0.03]))
    modal = np.array([[1.0, -0.6, 0.3], [0.5, 0.8, -0.4]]) * 1e-2
    return np.stack([(m[None, :] / (lam[None, :] - w2[:, None])).sum(axis=1) for m in modal])


def test_fit_reproduces_a_hysteretic_modal_sum_exactly():
    f = np.linspace(100.0, 8000.0, 1200)
    g = hysteretic_frfs(f)
    fit = fit_frfs(f, g)
    assert np.max(np.abs(fit.evaluate(f) - g) / np.abs(g)) < 1e-7
    # The three poles i√λ are found (s = iω scaled by the largest ω).
    freq = np.sort(fit.poles.imag * fit.scale / (2 * np.pi))
    for fr in (900.0, 2600.0, 5100.0):
        assert np.min(np.abs(freq - fr)) < 0.02 * fr


def test_fit_removes_most_of_the_noise():
    f = np.linspace(100.0, 8000.0, 4000)
    g = hysteretic_frfs(f)
    rng = np.random.default_rng(3)
    noisy = g * (1 + 0.01 * (rng.standard_normal(g.shape) + 1j * rng.standard_normal(g.shape)) / np.sqrt(2))
    fit = fit_frfs(f, noisy)
    raw = np.median(np.abs(noisy - g) / np.abs(g))
    smooth = np.median(np.abs(fit.evaluate(f) - g) / np.abs(g))
    assert smooth < raw / 5


def test_noise_estimate_tells_noise_from_a_coarse_grid():
    f = np.linspace(100.0, 8000.0, 4000)
    g = hysteretic_frfs(f)
    assert frf_noise(g) < 1e-6
    assert frf_noise(g[:, ::20]) < 1e-4  # 40 Hz steps: rough, but not noisy
    rng = np.random.default_rng(4)
    noisy = g * (1 + 0.01 * (rng.standard_normal(g.shape) + 1j * rng.standard_normal(g.shape)) / np.sqrt(2))
    assert 0.005 < frf_noise(noisy) < 0.015
