"""Peaks: exact pole recovery, reflection-proof refinement, noise bumps rejected, skirt modes kept."""

import numpy as np
import pytest

from taptune.signal.peaks import (fit_poles, half_power_width, parabolic_peak, pick_peaks, refine_peaks,
                                  undamped, with_reflection)
from taptune.signal.spectrum import smooth_floor, spectra


def _ringdown(fs, modes, n, delay=0.0, gain=0.0):
    """Decaying sinusoids with the model's convention (f undamped, ζ = η/2) plus a reflection.

    The pole of 1/(ω_r²(1 + 2iζ) − ω²) is s = iω_r·sqrt(1 + 2iζ) = −σ + iω_d.
    """
    t = np.arange(n) / fs
    x = np.zeros(n)
    for f, z, a in modes:
        s = 1j * 2 * np.pi * f * np.sqrt(1 + 2j * z)
        sigma, wd = -s.real, s.imag
        for d, g in ((0.0, 1.0), (delay, gain)):
            td = t[t >= d] - d
            x[t >= d] += g * a * np.exp(-sigma * td) * np.cos(wd * td)
    return x


def test_parabolic_peak_of_a_parabola_is_exact():
    y = -((np.arange(10) - 4.3) ** 2)
    d, h = parabolic_peak(y, 4)
    assert d == pytest.approx(0.3) and h == pytest.approx(0.0)


def test_fit_recovers_frequency_and_damping_of_a_clean_ringdown_to_1e_7():
    fs, n = 48000, 12000
    modes = [(3517.3, 0.004, 1.0), (3630.0, 0.003, 0.5)]  # two close modes: one joint fit
    f, spec = spectra(_ringdown(fs, modes, n)[None, :], fs, 2 * n)
    fd, sig, std, ok, *_ = fit_poles(f, spec, fs, [3515.0, 3632.0], [80.0, 60.0], 3400.0, 3750.0)
    fu, z = undamped(fd, sig)
    assert ok
    assert fu == pytest.approx([3517.3, 3630.0], rel=1e-7)
    assert z == pytest.approx([0.004, 0.003], rel=1e-5)


def test_refinement_is_not_pulled_by_a_strong_early_reflection():
    # A 1.3 %-damped mode with a −11 dB reflection 1.13 ms later (a quarter period off
    # phase): the magnitude peak moves by ~0.1 %; fitting from after the reflection
    # gives the pole back.
    fs, n = 48000, 12000
    f0, z0 = 3771.0, 0.0133
    x = _ringdown(fs, [(f0, z0, 1.0)], n, delay=1.127e-3, gain=0.29)
    x += np.random.default_rng(0).normal(0, 1e-5, n)
    freq, spec = spectra(x[None, :], fs, 4 * n)
    mag = np.abs(spec[0])
    i = int(np.argmax(mag))
    par = freq[i] + parabolic_peak(20 * np.log10(mag), i)[0] * (freq[1] - freq[0])
    assert abs(par / f0 - 1) > 5e-4  # the naive peak is off by more than 0.05 %

    def fit_spectra(start_s):
        k = int(round(start_s * fs))
        seg = np.zeros(n)
        seg[:n - k] = x[k:]
        f, s = spectra(seg[None, :], fs, 2 * n)
        return f, s, 2 * n / (n - k)

    hz, zeta, std = refine_peaks(freq, mag, fit_spectra, fs, [i], [par], seg_s=n / fs, snr_db=[80.0])
    assert hz[0] == pytest.approx(f0, rel=5e-5)
    assert zeta[0] == pytest.approx(z0, rel=0.02)


def test_half_power_width_of_a_lorentzian():
    f = np.arange(0, 2000, 0.5)
    mag = 1 / np.abs(1j * (f - 1000) + 12.0)
    assert half_power_width(f, mag, 2000) == pytest.approx(12.0, abs=0.5)


def test_noise_bumps_are_not_peaks_but_a_mode_in_noise_is():
    fs, n = 48000, 12000
    rng = np.random.default_rng(2)
    x = _ringdown(fs, [(5000.0, 0.003, 0.05)], n) + rng.normal(0, 1e-3, n)
    f, spec = spectra(x[None, :], fs, 4 * n)
    mag = np.abs(spec[0])
    noise = np.abs(spectra(rng.normal(0, 1e-3, (4, n)), fs, 4 * n)[1]).mean(axis=0)
    idx, hz, lev, prom, local, over = pick_peaks(f, mag, smooth_floor(f, noise, q=50), fmax_hz=23000)
    assert hz == pytest.approx([5000.0], abs=2.0)


def test_a_mode_on_the_skirt_of_a_louder_one_is_picked_and_noise_is_not():
    # Mode 2 of a tool 3.5 % below a loud interface mode: its ring median sits on the
    # loud mode's skirt (≈ 10 dB) and it stands < 30 dB over the noise, yet it is 23 dB
    # prominent and clear over the side away from the skirt.
    fs, n = 48000, 12000
    rng = np.random.default_rng(5)
    x = _ringdown(fs, [(9800.0, 0.0015, 1.0), (9470.0, 0.002, 0.2)], n) + rng.normal(0, 0.02, n)
    f, spec = spectra(x[None, :], fs, 4 * n)
    noise = np.abs(spectra(rng.normal(0, 0.02, (4, n)), fs, 4 * n)[1]).mean(axis=0)
    idx, hz, lev, prom, local, over = pick_peaks(f, np.abs(spec[0]), smooth_floor(f, noise, q=50), fmax_hz=23000)
    assert hz == pytest.approx([9470.0, 9800.0], abs=15.0)
    k = int(np.argmin(np.abs(hz - 9470.0)))
    assert local[k] < 12.0 and over[k] < 30.0 and prom[k] > 20.0  # the case the lower side decides


def test_a_late_reflection_is_found_and_modelled():
    # A 0.3 %-damped mode at 15.3 kHz and a −26 dB echo 8 ms later: the plain fit is
    # 0.03 % off; with the echo found (delay to 0.05 ms) the pole comes back to 1e-5.
    fs, n, f0 = 48000, 12000, 15300.0
    rng = np.random.default_rng(0)
    x = _ringdown(fs, [(f0, 0.003, 1.0)], n, delay=8e-3, gain=0.05)
    taps = np.vstack([x + rng.normal(0, 1e-4, n), 0.7 * x + rng.normal(0, 1e-4, n)])
    f, spec = spectra(taps, fs, 2 * n)
    hw = f0 * 0.003
    lo, hi = f0 - 3 * hw, f0 + 3 * hw
    plain = fit_poles(f, spec, fs, [f0], [2 * np.pi * hw], lo, hi)
    assert abs(undamped(plain.fd, plain.sigma)[0][0] / f0 - 1) > 2e-4
    found = with_reflection(f, spec, fs, plain, lo, hi, 14e-3)
    assert found is not None and found.delays[0] == pytest.approx(8e-3, abs=5e-5)
    assert undamped(found.fd, found.sigma)[0][0] == pytest.approx(f0, rel=1e-5)
    # Without an echo there is none to find.
    clean = spectra(np.vstack([_ringdown(fs, [(f0, 0.003, 1.0)], n) + rng.normal(0, 1e-4, n)]), fs, 2 * n)[1]
    assert with_reflection(f, clean, fs, fit_poles(f, clean, fs, [f0], [2 * np.pi * hw], lo, hi), lo, hi, 14e-3) is None
