"""Cuts whose forced lines are weak (an ideal 4-tooth slot), a ring that dies out, a comb twice too high."""

from __future__ import annotations

import numpy as np
import pytest

from benchmarks.cut.sounds import FS, as_recording, lines_cut, render_cuts, shop_sound
from taptune.errors import InputError
from taptune.signal.cut import analyse_cut


def slot_batch(seconds=1.6, chatter_m=0.0, seed=0):
    """A 4-tooth full slot at 9000 rpm as the milling simulation gives it: the force barely varies
    (48 N ± 1 mN), the tool sits deflected by 3.2 µm, and the arithmetic leaves a 1e-21 m tone
    at 2520 Hz; ``chatter_m`` adds a real chatter [m] at 2611 Hz."""
    rng = np.random.default_rng(seed)
    t = np.arange(int(seconds * FS)) / FS
    f_tp = 600.0
    ripple = sum(10 ** (-h / 2) * np.cos(2 * np.pi * h * f_tp * t + rng.uniform(0, 6)) for h in range(1, 6))
    vib = 3.2e-6 + 1e-23 * ripple + 1e-21 * np.sin(2 * np.pi * 2520.0 * t)
    # A chatter is modulated by the tooth passing: its family f_c ± k f_tp.
    def chatter(phase):
        return sum(a * np.sin(2 * np.pi * (2611.0 + k * f_tp) * t + k + phase) for k, a in ((0, 1.0), (1, 0.2), (-1, 0.15)))

    vib = vib + chatter_m * chatter(0.0)
    force = 48.0 + 1e-14 * ripple + 1.5e7 * chatter_m * chatter(1.0)  # the force leads near the mode
    return {"rpm": 9000.0, "teeth": 4, "depths": [1e-3], "vibration": vib[None, :], "force": force[None, :],
            "growth": np.array([1.2 if chatter_m else 0.6])}


def test_arithmetic_noise_of_a_quiet_slot_is_not_amplified_into_a_chatter():
    (rec, truth, _), = render_cuts(slot_batch(), seed=1, noise_db=-28.0, hum_hz=50.0, fans=2)
    assert truth.kind == "stable"
    try:
        a = analyse_cut(rec, 9000, 4)
    except InputError as err:  # a cut no louder than the idle: told, not guessed
        assert "no cut" in str(err)
    else:
        assert a.verdict != "chatter"


def test_a_real_chatter_of_a_slot_is_still_heard():
    (rec, truth, _), = render_cuts(slot_batch(chatter_m=2e-6), seed=1, noise_db=-28.0, hum_hz=50.0, fans=2)
    a = analyse_cut(rec, 9000, 4)
    assert a.verdict == "chatter" and abs(a.chatter_hz / 2611.0 - 1) < 0.01


def test_a_ring_that_dies_out_over_the_cut_is_not_chatter():
    """Weak forced lines and a tool mode ringing down over the cut (a stable cut near its limit,
    started at full depth; at the start as loud as the forced lines): the line decays, so it is no regenerative chatter."""
    rng = np.random.default_rng(4)
    t = np.arange(int(2.5 * FS)) / FS
    f_tp = 600.0
    x = sum(0.5 * 10 ** (-h / 4) * np.cos(2 * np.pi * h * f_tp * t + rng.uniform(0, 6)) for h in range(1, 6))
    x = x + np.exp(-t / 0.5) * np.cos(2 * np.pi * 2487.0 * t)
    rec = as_recording(shop_sound(x, 9000, 4, rng=rng, noise_db=-30, fans=0, normalise=False))
    a = analyse_cut(rec, 9000, 4)
    assert a.verdict != "chatter"


@pytest.mark.parametrize("rpm, teeth, given, hint", [(8000, 3, dict(rpm=16000, teeth=3), "8000 rpm"),
                                                     (8000, 2, dict(rpm=8000, teeth=4), "2 teeth"),
                                                     (10000, 4, dict(rpm=10000, teeth=8), "4 teeth")])
def test_a_speed_or_tooth_count_twice_too_high_is_refused_naming_the_likely_one(rpm, teeth, given, hint):
    rec, _ = lines_cut(rpm, teeth, seed=2)
    with pytest.raises(InputError, match=hint):
        analyse_cut(rec, given["rpm"], given["teeth"])


@pytest.mark.parametrize("chatter_hz", [600.0 * 2.5 + 3.0, 300.0])
def test_a_flip_chatter_is_not_taken_for_a_comb_twice_too_high(chatter_hz):
    # Period doubling: the chatter at an odd multiple of f_tp/2, with its family spaced by f_tp.
    f = 600.0 * (round(2 * chatter_hz / 600.0) / 2)
    rec, _ = lines_cut(9000, 4, seed=3, chatter_hz=f, chatter_db=15.0)
    a = analyse_cut(rec, 9000, 4)
    assert a.verdict == "chatter" and abs(a.chatter_hz / f - 1) < 0.01
