"""A loud non-bending peak beside a true bending mode of a holder the model describes exactly.

The in-family case ``inf098`` (the corpus's control: truth = the product model, the
assembly file exact) rings mode 3 at 15.15 kHz; an axial or fixture resonance 5.85 %
above it, 10 dB louder, was taken as mode 3 because "a prominent peak is not left
unexplained", although with it the fitted model misses modes 2 and 3 by percent
(issue 22: 15,119 vs 16,004 Hz, predictions 2-3 % off). The labelling the model explains
within the peaks' precision wins; the loud peak stays ``other`` and a warning names it.
"""

from dataclasses import replace

import numpy as np
import pytest

from benchmarks.realism.corpus import make_case
from taptune.identify.pipeline import analyse_for_assembly, model_expectation
from taptune.synthetic import simulate_tap_recording


@pytest.fixture(scope="module")
def loud_neighbour():
    case = make_case("infamily", 98)
    truth = np.asarray(case.truth.bending_hz)
    spurious = 1.0585 * truth[2]
    extra = case.recording.extra_modes + ((spurious, 0.004, 3.0),)
    rec = simulate_tap_recording(case.described, case.holder.params, case.recording.nuisances,
                                 np.random.default_rng(case.seed), extra_modes=extra)
    guidance = model_expectation(case.described)
    return case, truth, spurious, rec, guidance


def test_the_loud_peak_beside_mode_3_is_other_and_named(loud_neighbour):
    case, truth, spurious, rec, guidance = loud_neighbour
    analysis = analyse_for_assembly(rec, case.described, guidance=guidance)
    found = analysis.bending_by_mode()
    assert sorted(found) == [1, 2, 3]
    assert all(abs(found[m] / truth[m - 1] - 1) < 1e-3 for m in found)  # the true modes, not the loud peak
    loud = min(analysis.peaks, key=lambda p: abs(p.hz - spurious))
    assert abs(loud.hz / spurious - 1) < 1e-3 and loud.kind == "other"
    assert loud.level_db > max(p.level_db for p in analysis.peaks if p.kind == "bending" and p.mode == 3) + 6
    said = [w for w in analysis.warnings if f"peak at {loud.hz:.0f} Hz left as other" in w]
    assert len(said) == 1 and "would miss by" in said[0]


def test_without_the_fit_the_guidance_keeps_mode_3_too(loud_neighbour):
    # The guidance alone had it right; the fitted choice must not undo that.
    case, truth, _, rec, guidance = loud_neighbour
    guided = analyse_for_assembly(rec, case.described, guidance=guidance, decide_labels=False).bending_by_mode()
    assert abs(guided[3] / truth[2] - 1) < 1e-3


@pytest.mark.slow
def test_a_miss_beyond_the_storing_limit_leaves_the_labelling_to_the_poor_fit_refusal():
    # In-family inf009 clamped again 10 mm out (its second tap of a joint fit): modes 2 and
    # 3 (13.0, 16.5 kHz) do not ring; a table resonance at 8.94 kHz and the interface's
    # 10.37 kHz mode are loud. Taking them for modes 2 and 3 leaves the fit 22 % off; mode 1
    # alone would be explained within the peaks' precision. A miss that large is what a
    # wrong assembly file gives too (a hydraulic chuck's tap with an ER32 file: 10.5 %), so
    # the loud labelling stays and `taptune identify` refuses to store the fit, naming the
    # miss: dropping modes there would store a wrong holder without a word.
    from benchmarks.realism.audio import record
    from benchmarks.realism.corpus import elsewhere

    case = make_case("infamily", 9, stickout_error_mm=0.05)
    tap = elsewhere(case, case.queries[0].stickout_mm)
    analysis = analyse_for_assembly(record(tap), tap.described)
    found = analysis.bending_by_mode()
    assert len(found) == 3 and abs(found[1] / tap.truth.bending_hz[0] - 1) < 1e-3
    assert not [w for w in analysis.warnings if "left as other" in w]
