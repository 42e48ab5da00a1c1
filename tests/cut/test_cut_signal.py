"""Chatter from the sound of a cut (taptune.signal.cut): verdicts, the speed heard, the shop's noises, bad input."""

from __future__ import annotations

import numpy as np
import pytest

from benchmarks.cut.sounds import as_recording, lines_cut, shop_sound
from taptune.errors import InputError
from taptune.signal.cut import analyse_cut, smith_tlusty_speeds


def test_a_stable_cut_is_stable_and_its_speed_is_heard_to_a_tenth_of_a_percent():
    rec, truth = lines_cut(8000, 3, seed=1)
    a = analyse_cut(rec, 8000, 3)
    assert a.verdict == "stable" and a.chatter_hz is None
    assert abs(a.spindle_rpm / 8000 - 1) < 1e-3
    assert a.tooth_passing_hz == pytest.approx(400.0, rel=1e-3)
    assert a.idle_s > 1.0  # the idle before and after the cut was found
    assert 1.0 < a.cut_s[0] < a.cut_s[1] < 4.0


@pytest.mark.parametrize("chatter_hz, level_db, codec", [(1234.0, 10.0, None), (2817.0, 20.0, None), (987.0, 10.0, "aac")])
def test_chatter_is_heard_and_its_frequency_within_1_percent(chatter_hz, level_db, codec):
    rec, truth = lines_cut(8000, 3, seed=2, chatter_hz=chatter_hz, chatter_db=level_db, codec=codec)
    a = analyse_cut(rec, 8000, 3)
    assert a.verdict == "chatter"
    assert abs(a.chatter_hz / chatter_hz - 1) < 0.01
    # The sound carries the forced force harmonics too, so the level in the sound is near the vibration's.
    assert a.chatter_level_db == pytest.approx(level_db, abs=6.0)
    # Its family f_c ± f_tp is found, and is no second chatter.
    assert any(abs(f - (chatter_hz + 400.0)) < 2 for f in a.family_hz)


def test_growing_chatter_is_chatter():
    rec, truth = lines_cut(9000, 4, seed=3, chatter_hz=2345.0, chatter_db=20.0, growth_s=0.2)
    a = analyse_cut(rec, 9000, 4)
    assert a.verdict == "chatter" and abs(a.chatter_hz / 2345.0 - 1) < 0.01


def test_an_override_is_heard_and_said():
    rec, truth = lines_cut(10000, 2, seed=4, override=1.06)
    a = analyse_cut(rec, 10000, 2)
    assert a.spindle_rpm == pytest.approx(10600, rel=1e-3)
    assert a.verdict == "stable"
    assert any("+6.0 %" in w for w in a.warnings)


def test_a_loud_fan_tone_present_at_idle_is_no_chatter():
    rng = np.random.default_rng(5)
    t = np.arange(int(3 * 44100)) / 44100
    from benchmarks.cut.sounds import lines_vibration

    vib = lines_vibration(t, 8000, 3, rng=rng)
    x = shop_sound(vib, 8000, 3, rng=rng, fans=0)
    fan = 0.3 * np.max(np.abs(x)) * np.cos(2 * np.pi * 1777.0 * np.arange(len(x)) / 44100)
    a = analyse_cut(as_recording(x + fan), 8000, 3)
    assert a.verdict == "stable"
    assert any(abs(f - 1777.0) < 2 for f in a.excluded_hz)


def test_a_flip_chatter_on_an_odd_multiple_of_half_the_tooth_passing_is_chatter():
    # Two teeth: f_tp/2 multiples are spindle harmonics, where a period-doubling chatter sounds.
    rec, truth = lines_cut(12000, 2, seed=6, chatter_hz=1400.0, chatter_db=15.0)
    a = analyse_cut(rec, 12000, 2)
    assert a.verdict == "chatter" and abs(a.chatter_hz - 1400.0) < 3


def test_a_given_window_is_used(tmp_path):
    rec, truth = lines_cut(8000, 3, seed=7, chatter_hz=1500.0, chatter_db=15.0)
    a = analyse_cut(rec, 8000, 3, start_s=1.5, end_s=3.5)
    assert a.cut_s == pytest.approx((1.5, 3.5), abs=0.05) and a.verdict == "chatter"
    with pytest.raises(InputError, match="--from/--to"):
        analyse_cut(rec, 8000, 3, start_s=3.0, end_s=2.0)


@pytest.mark.parametrize("rpm, teeth, why", [(5000, 3, "3rd harmonic"), (8000, 4, "at 400.0 Hz"),
                                             (8000, 2, "3rd harmonic"), (4000, 3, "2nd harmonic"),
                                             (8000, 5, "tooth passing is at 400.0 Hz"), (11000, 3, "at 400.0 Hz")])
def test_a_speed_or_tooth_count_that_cannot_be_right_is_refused(rpm, teeth, why):
    rec, truth = lines_cut(8000, 3, seed=8, chatter_hz=1234.0, chatter_db=10.0)
    with pytest.raises(InputError, match=why):
        analyse_cut(rec, rpm, teeth)


def test_a_recording_without_a_cut_is_refused():
    rng = np.random.default_rng(9)
    idle = shop_sound(np.zeros(3 * 44100), 8000, 3, rng=rng, idle_before_s=0.5, idle_after_s=0.5)
    with pytest.raises(InputError, match="no cut|no tooth|no tooth cuts"):
        analyse_cut(as_recording(idle), 8000, 3)
    with pytest.raises(InputError, match="too short|lasts only"):
        analyse_cut(as_recording(np.zeros(1000)), 8000, 3)


def test_smith_tlusty_puts_the_tooth_passing_or_a_sub_multiple_on_the_chatter():
    speeds = smith_tlusty_speeds(1000.0, 2, 11000.0, min_rpm=500, max_rpm=40000)
    assert speeds[0] == pytest.approx(10000.0)  # 60·1000/(2·3): nearest the present speed
    assert set(np.round(speeds)) <= {30000.0, 15000.0, 10000.0, 7500.0, 6000.0, 5000.0}
    assert max(smith_tlusty_speeds(1000.0, 2, 11000.0, max_rpm=20000.0)) <= 20000.0
