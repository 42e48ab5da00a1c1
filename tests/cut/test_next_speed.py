"""The next speed from the lobes, the chatter matched to a tool mode, and observed cuts weighing the parameter sets."""

from __future__ import annotations

import numpy as np
import pytest

from taptune.machine.next_speed import lobe_advice, match_mode, observation_warnings
from taptune.machine.observed import set_weights, weighted_band
from taptune.machine.peaks import FRFMode
from taptune.library.observations import CutObservation

MM = 1e-3


def boundary():
    """A made-up boundary: 1 mm everywhere but two pockets, 9,000–9,800 rpm at 3 mm and 12,000–14,000 rpm at 6 mm."""
    rpm = np.arange(5000.0, 16001.0, 10.0)
    a = np.full(len(rpm), 1.0 * MM)
    a[(rpm >= 9000) & (rpm <= 9800)] = 3 * MM
    a[(rpm >= 12000) & (rpm <= 14000)] = 6 * MM
    return rpm, a


def test_the_middle_of_the_nearest_wide_window_comes_first():
    rpm, a = boundary()
    adv = lobe_advice(rpm, a, 2.0 * MM, 10000.0)
    assert adv.depth_to is None
    assert adv.suggested_rpm[0] == pytest.approx(9400, abs=10)  # 8.5 % wide, nearest
    assert adv.suggested_rpm[1] == pytest.approx(13000, abs=10)
    # 4 mm: only the high pocket allows it (with 15 % to spare).
    assert lobe_advice(rpm, a, 4.0 * MM, 10000.0).suggested_rpm == pytest.approx((13000,), abs=10)
    # Outside the machine's range there is no window: the depth to come down to.
    low = lobe_advice(rpm, a, 4.0 * MM, 10000.0, max_rpm=11000)
    assert low.depth_to == pytest.approx(3 * MM / 1.15) and low.suggested_rpm[0] == pytest.approx(9000, abs=10)


def test_a_chatter_matches_a_mode_within_its_band_or_5_percent():
    modes = (FRFMode(3400.0, 0.016, "x", 1e-6), FRFMode(4280.0, 0.011, "x", 1e-6))
    assert match_mode(4390.0, modes) == (modes[1], True)  # 2.6 % above
    assert match_mode(2210.0, modes) == (modes[0], False)
    assert match_mode(1000.0, ()) == (None, False)


def obs(rpm, depth, verdict):
    return CutObservation("2026-11-27T09:00:00Z", "c.wav", "0" * 64, rpm, depth, 8.0, "down", 3, None, 800.0, 200.0,
                          verdict, 900.0 if verdict == "chatter" else None, None, "0")


def test_cuts_that_contradict_the_lobes_warn():
    rpm, a = boundary()
    w = observation_warnings([obs(13000, 2.0, "chatter"), obs(6000, 0.5, "stable"), obs(6000, 3.0, "stable"),
                              obs(6000, 3.0, "chatter")], rpm, a)
    assert len(w) == 2 and "chatter observed at 13000 rpm" in w[0] and "clean cut at 6000 rpm" in w[1]


def test_observations_weigh_the_sets_that_explain_them():
    # Three sets with limits 1, 1.35 and 2.5 mm at the cut; a chatter at 1.5 mm and a clean cut at 1.2 mm:
    # the limit lies between, as set 2 has it. By hand (σ = 0.15): 1·Φ(−1.22) = 0.11, Φ(0.70)·Φ(0.785) = 0.59,
    # Φ(−3.4) = 3e-4.
    limits = np.array([[1.0, 1.0], [1.35, 1.35], [2.5, 2.5]]) * MM
    w = set_weights(limits, np.array([1.5, 1.2]) * MM, ["chatter", "stable"])
    assert w.sum() == pytest.approx(1.0)
    assert w == pytest.approx(np.array([0.111, 0.585, 3.4e-4]) / 0.696, rel=0.05)
    # Unclear cuts weigh nothing.
    assert set_weights(limits, [1.5 * MM], ["unclear"]) == pytest.approx(np.full(3, 1 / 3))
    band = weighted_band(np.array([[1.0], [1.35], [2.5]]), w)
    assert band[:, 0] == pytest.approx([1.0, 1.35, 1.35])
    assert weighted_band(np.array([[1.0], [2.0], [4.0]]), np.full(3, 1 / 3))[:, 0] == pytest.approx([1.0, 2.0, 4.0])


def test_one_misheard_verdict_does_not_rule_out_the_truth():
    # Two sets, limits 1 and 3 mm at the cuts; a clean cut at 2 mm and a chatter at 1.2 mm
    # contradict each other. As heard (lapse 0) the chatter rules the 3 mm set out, 3,600:1:
    # Φ(−4.62)·Φ(1.22) = 1.7e-6 against Φ(2.70)·Φ(−6.11) = 5e-10. Each verdict wrong with
    # probability 0.02 (by hand: (0.02 + 0.96·1.9e-6)(0.02 + 0.96·0.889) = 0.0175 against
    # (0.02 + 0.96·0.9965)(0.02 + 0.96·5e-10) = 0.0195) both stay in play, and two more
    # clean cuts at 2 mm settle it for the 3 mm set.
    from taptune.machine.observed import LAPSE

    limits = np.array([[1.0, 1.0], [3.0, 3.0]]) * MM
    depths, verdicts = np.array([2.0, 1.2]) * MM, ["stable", "chatter"]
    assert set_weights(limits, depths, verdicts)[1] < 1e-3
    w = set_weights(limits, depths, verdicts, lapse=LAPSE)
    assert LAPSE == 0.02 and w[1] == pytest.approx(0.0195 / (0.0175 + 0.0195), rel=0.02)
    more = set_weights(np.array([[1.0] * 4, [3.0] * 4]) * MM, np.array([2.0, 2.0, 2.0, 1.2]) * MM,
                       ["stable", "stable", "stable", "chatter"], lapse=LAPSE)
    assert more[1] > 0.99
