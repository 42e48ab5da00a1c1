"""Tap detection: every tap found, clipped taps and double hits flagged, channels mixed."""

import numpy as np
import pytest

from taptune.signal.taps import find_taps, moving_average, to_mono

from .synthetic import workshop_recording


def test_moving_average_matches_direct_windows_at_the_ends_too():
    x = np.random.default_rng(1).normal(size=50)
    for n in (1, 2, 5, 6, 50):
        ref = np.array([x[max(i - n // 2, 0):min(i - n // 2 + n, 50)].mean() for i in range(50)])
        assert np.allclose(moving_average(x, n), ref)


@pytest.mark.parametrize("times", [(0.3,), (0.2, 0.8, 1.4), tuple(0.1 + 0.31 * k for k in range(12))])
def test_every_tap_is_found(times):
    strengths = tuple(1.0 - 0.5 * (k % 3) / 2 for k in range(len(times)))
    rec = workshop_recording(3, tap_times_s=times, tap_strengths=strengths, duration_s=times[-1] + 0.4)
    taps = find_taps(to_mono(rec.samples, rec.sample_rate), rec.sample_rate, raw=rec.samples)
    assert [t.time_s for t in taps] == pytest.approx(list(times), abs=1.5e-3)
    assert all(t.used and not t.clipped and not t.double_hit for t in taps)


def test_clipped_taps_are_left_out():
    # The first tap is the loudest: at level 0.6 and clip 0.5 only it clips.
    rec = workshop_recording(4, level=0.6, clip=0.5, tap_strengths=(1.0, 0.6, 0.7))
    taps = find_taps(to_mono(rec.samples, 48000), 48000, raw=rec.samples, subtype=rec.subtype)
    assert [t.clipped for t in taps] == [True, False, False]
    assert [t.used for t in taps] == [False, True, True]


def test_clipping_with_dc_offset_and_integer_full_scale():
    rec = workshop_recording(5, level=1.3, clip=1.0, dc_offset=0.0)
    x = np.round(np.clip(rec.samples, -1, 1 - 2**-15) * 32768) / 32768
    taps = find_taps(to_mono(x, 48000), 48000, raw=x, subtype="PCM_16")
    assert taps[0].clipped


@pytest.mark.parametrize("delay_s,strength", [(0.004, 0.5), (0.012, 0.8), (0.025, 0.45)])
def test_double_hit_is_left_out(delay_s, strength):
    # A strong reflection (0.3 at 0.9 ms) is not a double hit; the bounce is.
    rec = workshop_recording(6, double_hits=((1, delay_s, strength),), reflections=((0.9e-3, 0.3), (8e-3, 0.1)))
    taps = find_taps(to_mono(rec.samples, 48000), 48000, raw=rec.samples)
    assert len(taps) == 3
    assert [t.double_hit for t in taps] == [False, True, False]
    assert [t.used for t in taps] == [True, False, True]


def test_all_taps_bad_are_used_anyway():
    rec = workshop_recording(7, tap_times_s=(0.3,), tap_strengths=(1.0,), level=0.6, clip=0.5)
    taps = find_taps(to_mono(rec.samples, 48000), 48000, raw=rec.samples)
    assert taps[0].clipped and taps[0].used


def test_noise_alone_has_no_tap():
    x = np.random.default_rng(0).normal(0, 0.01, 96000)
    assert find_taps(x, 48000) == []


def test_mono_mix_survives_an_inverted_and_a_dead_channel():
    rec = workshop_recording(8)
    x = rec.samples[:, 0]
    for other in (-0.7 * x, np.zeros_like(x), 0.01 * np.random.default_rng(0).normal(size=x.size)):
        mono = to_mono(np.column_stack([other, x]), 48000)
        # The mix is the good channel (no cancellation, no dilution by the other's noise).
        assert abs(np.corrcoef(mono, x)[0, 1]) > 0.999
