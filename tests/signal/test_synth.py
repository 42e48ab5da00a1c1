"""Synthesis: clean recordings carry exactly the modes they were made from."""

import numpy as np
import pytest

from taptune.signal.synth import Nuisances, half_sine_spectrum, modal_receptance, synthesize_recording, tap_grid
from taptune.signal.taps import find_taps, to_mono

from .synthetic import receptance


def test_half_sine_spectrum_is_one_at_dc_and_zero_at_its_first_null():
    c = 70e-6
    # The half-sine's first spectral zero is at 1.5 / c.
    s = half_sine_spectrum(np.array([0.0, 1.5 / c]), c)
    assert abs(s[0]) == pytest.approx(1.0)
    assert abs(s[1]) < 1e-9


def test_modal_receptance_static_value_is_sum_of_flexibilities():
    # H(0) = Σ r / ω_r² (the hysteretic term 1 + 2iζ adds an imaginary part).
    h = modal_receptance(np.array([0.0]), [(1000.0, 0.0, 2.0), (3000.0, 0.0, 1.0)])
    assert h[0].real == pytest.approx(2 / (2 * np.pi * 1000) ** 2 + 1 / (2 * np.pi * 3000) ** 2)


def test_taps_land_at_their_times_with_their_strengths():
    nu = Nuisances(sample_rate=48000, duration_s=1.5, tap_times_s=(0.1, 0.6, 1.1), tap_strengths=(1.0, 0.5, 0.25),
                   snr_db=60.0, hum_hz=None, reflections=())
    g = tap_grid(48000)
    rec = synthesize_recording(g, receptance(g), nu, np.random.default_rng(0))
    taps = find_taps(to_mono(rec.samples, 48000), 48000)
    # The centred 0.5 ms envelope crosses the threshold up to 0.25 ms before the impact.
    assert [t.time_s for t in taps] == pytest.approx([0.1, 0.6, 1.1], abs=5e-4)
    peaks = np.array([t.peak for t in taps])
    assert peaks / peaks[0] == pytest.approx([1.0, 0.5, 0.25], rel=0.02)
    assert peaks[0] == pytest.approx(0.5, rel=0.01)


def test_stereo_clip_and_dc_offset():
    nu = Nuisances(channels=2, gain2=0.5, clip=0.4, dc_offset=0.02, level=0.5, snr_db=40.0)
    g = tap_grid(48000)
    rec = synthesize_recording(g, receptance(g), nu, np.random.default_rng(1))
    x = rec.samples
    assert rec.channels == 2
    assert np.max(x[:, 0]) == pytest.approx(0.42)
    assert np.mean(x[:, 0]) == pytest.approx(0.02, abs=2e-3)
    assert np.max(np.abs(x[:, 1] - 0.02)) < 0.3
