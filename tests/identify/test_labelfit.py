"""Labels the model decides (identify.labelfit): plausible labelings fitted on the fast model."""

from dataclasses import replace

import numpy as np
import pytest

from taptune.identify.labelfit import quick_fit
from taptune.identify.pipeline import analyse_for_assembly, model_expectation
from taptune.model import ModelOptions, analyse
from taptune.model.params import NOMINAL
from taptune.signal.synth import Nuisances
from taptune.synthetic import simulate_tap_recording


def test_quick_fit_reaches_model_frequencies_and_prefers_nominal(reference_assembly):
    from taptune.model.reduced import FastEvaluator

    ev = FastEvaluator(reference_assembly)
    truth = replace(NOMINAL, k_rr=NOMINAL.k_rr * 3)
    f = np.asarray(analyse(reference_assembly, truth, ModelOptions()).bending_hz[:3])
    cost, model_hz, _ = quick_fit(ev, {1: f[0], 2: f[1], 3: f[2]}, sigma=0.005)
    assert np.max(np.abs(model_hz / f - 1)) < 0.002  # the fit reaches them
    assert cost < 1.0  # half a decade in k_rr is well inside the prior
    # Mode 2 10 % off with modes 1 and 3 unchanged: no plausible holder explains it.
    far, _, _ = quick_fit(ev, {1: f[0], 2: 0.9 * f[1], 3: f[2]}, sigma=0.005)
    assert far > 20 * max(cost, 0.1)


def test_quick_fit_batched_differences_reach_the_same_fit(reference_assembly):
    """The finite-difference candidates are solved in one batch; the fit is the one
    least_squares' own forward differences reach."""
    from taptune.model.reduced import FastEvaluator

    class OneAtATime:
        def __init__(self, ev):
            self.evaluate = ev.evaluate

    ev = FastEvaluator(reference_assembly)
    truth = replace(NOMINAL, k_tt=NOMINAL.k_tt * 0.4, density_factor=1.02)
    f = np.asarray(analyse(reference_assembly, truth, ModelOptions()).bending_hz[:3])
    for measured in ({1: f[0], 2: f[1], 3: f[2]}, {1: f[0] * 1.01, 3: f[2]}):
        batched = quick_fit(ev, measured, sigma=0.005)
        single = quick_fit(OneAtATime(ev), measured, sigma=0.005)
        assert batched[0] == pytest.approx(single[0], rel=1e-9, abs=1e-12)
        np.testing.assert_allclose(batched[1], single[1], rtol=1e-9)
        np.testing.assert_allclose(batched[2], single[2], rtol=1e-6)  # alpha: a flat direction


@pytest.mark.slow
def test_weak_mode_2_on_the_skirt_of_the_interface_mode_is_labelled_by_the_fit():
    # Shrink-fit holder at 52 mm, a stiff contact (k_rr at the top of the published
    # range, alpha at its bottom): mode 2 at 9.60 kHz sits on the skirt of the loud
    # interface mode at 9.70 kHz, both inside the HSK band. The guidance takes the
    # louder interface mode; the fitted model explains the weak peak.
    from taptune.io.assembly import load_assembly
    from tests.conftest import REPO

    base = load_assembly(REPO / "recordings" / "shrinkfit_d12.toml")
    asm = base.with_stickout(base.stickout * 1.3)
    params = replace(NOMINAL, k_tt=1.8e9, k_rr=4.83e4, alpha=-23.0)
    truth = np.asarray(analyse(asm, params, ModelOptions()).bending_hz[:3])
    rec = simulate_tap_recording(asm, params, Nuisances(sample_rate=48000, snr_db=50.0), np.random.default_rng(1))
    guidance = model_expectation(asm)
    guided = analyse_for_assembly(rec, asm, guidance=guidance, decide_labels=False).bending_by_mode()
    assert abs(guided[2] - 9700.0) < 5.0  # what the guidance alone chose
    decided = analyse_for_assembly(rec, asm, guidance=guidance)
    found = decided.bending_by_mode()
    assert sorted(found) == [1, 2, 3]
    assert all(abs(found[m] / truth[m - 1] - 1) < 1e-3 for m in found)
    assert any("labels were ambiguous" in w and "9602 Hz" in w for w in decided.warnings)
    assert decided.peaks[[p.mode for p in decided.peaks].index(2)].note == "bending (fit), inside the interface band"


def test_relabelled_replaces_only_the_missing_mode_warning():
    """The old labels' missing-mode warning gives way to the new one's; other warnings stay."""
    from dataclasses import dataclass

    from taptune.identify.labelfit import relabelled
    from taptune.signal.peaks import Peak

    @dataclass(frozen=True)
    class Analysis:
        peaks: list
        warnings: list
        file: str = "tap.wav"

    peaks = [Peak(4500.0, -3.0, kind="bending", mode=1, prominence_db=30.0),
             Peak(9000.0, -20.0, kind="other", prominence_db=25.0),
             Peak(15000.0, -6.0, kind="bending", mode=3, prominence_db=28.0)]
    other = "only the first tap is clean (a made-up warning that is not about the modes)"
    before = Analysis(peaks, ["only 2 of 3 bending modes found (missing mode 2)", other])
    after = relabelled(before, [0, 1, 2], ["chose mode 2 = 9000 Hz"])
    assert [p.mode for p in after.peaks] == [1, 2, 3]
    assert after.peaks[1].note == "bending (fit)"
    assert after.warnings == [other, "chose mode 2 = 9000 Hz"]
    fewer = relabelled(before, [0, None, None], [])
    assert fewer.warnings == [other, "only 1 of 3 bending modes found (missing mode 2, 3)"]


def test_a_faint_peak_pulls_the_quick_fit_less(reference_assembly):
    # Mode 2 measured 3 % off the others' explanation: as a faint peak (twice the
    # tolerance) it moves the fitted model less and costs less than as a clear one.
    from taptune.model.reduced import FastEvaluator

    ev = FastEvaluator(reference_assembly)
    f = np.asarray(analyse(reference_assembly, NOMINAL, ModelOptions()).bending_hz[:3])
    measured = {1: f[0], 2: 1.03 * f[1], 3: f[2]}
    clear_cost, clear_hz, _ = quick_fit(ev, measured, 0.01)
    faint_cost, faint_hz, _ = quick_fit(ev, measured, {1: 0.01, 2: 0.02, 3: 0.01})
    assert faint_cost < clear_cost
    assert abs(faint_hz[1] / measured[2] - 1) > abs(clear_hz[1] / measured[2] - 1)
    assert abs(faint_hz[0] / f[0] - 1) <= abs(clear_hz[0] / f[0] - 1) + 1e-6
