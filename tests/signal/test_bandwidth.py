"""Effective bandwidth: a codec's brick-wall low-pass is found; gentle roll-offs are not one."""

import numpy as np
import pytest

from taptune.signal.bandwidth import effective_bandwidth, hidden_modes
from taptune.signal.synth import modal_receptance

FS = 48000
FREQ = np.arange(0.0, FS / 2 + 0.5, 1.0)


def _noise(seed=0):
    """|FFT| of white noise on the 1 Hz grid (Rayleigh-distributed magnitudes)."""
    rng = np.random.default_rng(seed)
    return np.abs(rng.normal(size=FREQ.size) + 1j * rng.normal(size=FREQ.size))


def _butter_lp(order, corner_hz):
    s = 1j * FREQ / corner_hz
    h = np.ones_like(s)
    for k in range(order // 2):
        # Butterworth pole pairs: s² + 2 sin((2k+1)π/2n) s + 1.
        h = h / (s**2 + 2 * np.sin((2 * k + 1) * np.pi / (2 * order)) * s + 1)
    return np.abs(h)


@pytest.mark.parametrize("cut_hz", [8000.0, 12000.0, 15800.0, 19500.0])
def test_a_brick_wall_cut_is_found_to_one_band(cut_hz):
    # Noise and taps below, a residue 60 dB down above: what AAC/MP3 leave.
    mag = _noise() * np.where(FREQ < cut_hz, 1.0, 1e-3)
    bw, low_pass = effective_bandwidth(FREQ, mag, FS)
    assert low_pass and cut_hz - 250.0 <= bw <= cut_hz + 250.0


def test_a_transition_band_of_a_few_hundred_hz_is_still_a_cut():
    # A 48th-order Butterworth at 16 kHz: -3 dB at 16 kHz, -36 dB by 16.8 kHz.
    mag = _noise(1) * np.maximum(_butter_lp(48, 16000.0), 1e-4)
    bw, low_pass = effective_bandwidth(FREQ, mag, FS)
    assert low_pass and 15500.0 <= bw <= 16500.0


@pytest.mark.parametrize("corner_hz", [3000.0, 8000.0])
def test_a_microphone_roll_off_is_not_a_cut(corner_hz):
    # 2nd-order roll-off (12 dB per octave) from 3 kHz: 36 dB down at 24 kHz, but gently.
    mag = _noise(2) * _butter_lp(2, corner_hz) + 1e-6
    assert effective_bandwidth(FREQ, mag, FS) == (FS / 2, False)


def test_noise_free_modal_peaks_are_not_a_cut():
    # A tap's spectrum without noise: resonances and anti-resonances, skirts falling between.
    modes = [(3500.0, 0.003, 1e3), (11000.0, 0.002, 5e3), (17000.0, 0.003, 1e4)]
    mag = np.abs(modal_receptance(FREQ, modes)) * (2 * np.pi * FREQ) ** 2
    assert effective_bandwidth(FREQ, mag, FS) == (FS / 2, False)


def test_a_strong_peak_above_the_cut_moves_the_bandwidth_above_it():
    # Content above the cut-off (a loud partial the encoder kept) is carried: the
    # bandwidth is where everything stops, not where the floor first drops.
    mag = _noise(3) * np.where(FREQ < 12000.0, 1.0, 1e-3)
    mag[14000:14003] = 50.0
    band = (FREQ > 13000) & (FREQ < 15000)
    mag[band] = np.maximum(mag[band], 1.0)
    bw, low_pass = effective_bandwidth(FREQ, mag, FS)
    assert low_pass and bw >= 15000.0


def test_hidden_modes_by_cut_off_and_by_nyquist():
    # 0.9 x Nyquist = 21.6 kHz at 48 kHz; a 16 kHz cut-off with a 3 % edge margin = 15.52 kHz.
    assert hidden_modes([4000.0, 15000.0, 20000.0], 16000.0, FS) == [(3, 20000.0, pytest.approx(15520.0))]
    assert [m for m, *_ in hidden_modes([4000.0, 15600.0, 20000.0], 16000.0, FS)] == [2, 3]
    assert hidden_modes([4000.0, 12000.0, 22000.0], FS / 2, FS) == [(3, 22000.0, pytest.approx(21600.0))]
    assert hidden_modes([], 16000.0, FS) == []


def test_a_steep_low_pass_in_a_wav_hides_the_third_mode():
    """A recorder app's resampling filter (60 dB down from 12.5 kHz), then a WAV: f3 (15.3 kHz) is gone."""
    from scipy.signal import cheby2, sosfilt

    from taptune.io.audio import make_recording
    from taptune.signal.analysis import analyse_recording
    from tests.signal.synthetic import workshop_recording

    rec = workshop_recording(5)
    x = sosfilt(cheby2(12, 60, 12500.0, fs=rec.sample_rate, output="sos"), rec.samples, axis=0)
    a = analyse_recording(make_recording(x, rec.sample_rate, path="phone.wav", subtype="PCM_24"),
                          expected_hz=np.array([3600.0, 11000.0, 15500.0]))
    assert 11500.0 <= a.bandwidth_hz <= 13500.0
    hidden = [w for w in a.warnings if "low-pass" in w]
    assert len(hidden) == 1 and hidden[0].startswith("phone.wav: ") and "a phone's or an app's low-pass?" in hidden[0]
    assert "bending mode 3 expected near 15.5 kHz cannot be measured" in hidden[0]
