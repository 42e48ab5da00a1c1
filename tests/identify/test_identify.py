"""Identification end to end: fit one recording, predict other stick-outs, reproducibly."""

import numpy as np
import pytest

from taptune.identify import Cancelled, IdentifyOptions, identify, predict
from taptune.model.params import HolderParams

from .helpers import model_analysis

# Published holder A (CIRP JMST 2022) on the reference assembly (the example of docs/assembly-format.md).
HOLDER_A = HolderParams(1.90e9, 9.37e3, 1.98e-3, 8.20e-3, -10.0, 7478 / 7800, 1.0)
# Converged f1-f3 [Hz] of holder A at the two transfer stick-outs (two independent implementations).
TRANSFER = {63.5: (3748.4, 13124.7, 17765.9), 73.5: (3077.1, 11118.7, 16898.9)}


@pytest.fixture(scope="module")
def reference_fit(tmp_path_factory):
    """Holder A identified from a noise-free 'recording' (the model's own tip receptance) at 53.5 mm."""
    from taptune.io.assembly import load_assembly
    from tests.conftest import REFERENCE_TOML

    path = tmp_path_factory.mktemp("ref") / "reference.toml"
    path.write_text(REFERENCE_TOML)
    asm = load_assembly(path)
    analysis = model_analysis(asm, HOLDER_A)
    result = identify([analysis], [asm], IdentifyOptions(seed=3))
    return asm, analysis, result


def test_fit_matches_the_measured_frequencies_to_0_1_percent(reference_fit):
    asm, analysis, result = reference_fit
    measured = np.array(result.bending_measured_hz[0], dtype=float)
    model = np.array(result.bending_model_hz[0])
    assert np.max(np.abs(model / measured - 1)) < 1e-3
    assert result.objective < 0.05, "noise-free data: the fit should be essentially exact"
    assert result.evaluations > 1000
    assert len(result.param_sets) >= 2, "the near-optimal set is the uncertainty"


@pytest.mark.parametrize("stickout_mm", sorted(TRANSFER))
def test_predictions_at_other_stickouts_match_the_published_model_values(reference_fit, stickout_mm):
    """docs/physics.md §5: parameters are not identifiable, predictions are (within 1 %, the issue's bound;
    the planning experiments saw up to 0.6 % on this very case)."""
    asm, _, result = reference_fit
    p = predict(result.param_sets, asm.with_stickout(stickout_mm * 1e-3), identified=[asm])
    truth = np.array(TRANSFER[stickout_mm])
    error = np.abs(np.array(p.bending_hz) / truth - 1)
    assert error.max() < 0.01
    assert p.stickout_mm == pytest.approx(stickout_mm)
    spread = np.array(p.bending_hz_spread)
    assert np.all(np.abs(np.array(p.bending_hz) - truth) <= spread), "in the model family the band holds the truth"
    set_part = np.array(p.band.set_hz)
    assert np.all(set_part >= 5e-4 * truth * 0.99), "the band is never narrower than the measurement (0.05 %)"
    assert np.all(set_part < 0.02 * truth), "the near-optimal sets alone agree within 2 %"
    assert p.band.delta_stickout_mm == pytest.approx(abs(stickout_mm - asm.stickout * 1e3))


def test_same_seed_gives_identical_results_whatever_the_number_of_processes(reference_fit):
    asm, analysis, result = reference_fit
    again = identify([analysis], [asm], IdentifyOptions(seed=3, jobs=1))
    a, b = result.to_dict(), again.to_dict()
    a.pop("seconds"), b.pop("seconds")
    assert a == b


def test_transfer_outlook_is_the_prediction_it_states(reference_fit):
    """The outlook's numbers are predict's at 20 mm more stick-out, whatever the caches hold."""
    from taptune.identify.bands import clear_caches, measured_modes
    from taptune.identify.pipeline import transfer_outlook

    asm, _, result = reference_fit
    clear_caches()
    outlook = transfer_outlook(result, [asm]).to_dict()
    clear_caches()
    target = asm.with_stickout(asm.stickout + 20e-3)
    cold = predict(result.param_sets, target, relative_floor=result.relative_floor, identified=[asm],
                   measured_modes=measured_modes(result.bending_measured_hz)).to_dict()
    assert outlook == cold
    assert transfer_outlook(result, [asm]).to_dict() == cold  # from the caches this time


def test_progress_is_reported_and_can_cancel(reference_fit):
    asm, analysis, _ = reference_fit
    seen = []

    def progress(fraction, message):
        seen.append(fraction)
        return len(seen) < 5

    with pytest.raises(Cancelled):
        identify([analysis], [asm], IdentifyOptions(seed=1, jobs=1), progress=progress)
    assert seen and all(0.0 <= f <= 1.0 for f in seen)


def test_joint_identification_of_two_stickouts_fits_both(reference_fit):
    """Two recordings of one holder at different stick-outs share one parameter set."""
    asm, analysis, _ = reference_fit
    other = asm.with_stickout(0.0635)
    joint = identify([analysis, model_analysis(other, HOLDER_A)], [asm, other], IdentifyOptions(seed=0))
    for measured, model in zip(joint.bending_measured_hz, joint.bending_model_hz):
        assert np.max(np.abs(np.array(model) / np.array(measured, dtype=float) - 1)) < 2e-3
    p = predict(joint.param_sets, asm.with_stickout(0.0735))
    assert np.max(np.abs(np.array(p.bending_hz) / np.array(TRANSFER[73.5]) - 1)) < 0.005


def test_a_noisy_synthetic_recording_is_identified(tmp_path, reference_fit):
    """Model + workshop nuisances (noise, hum, interface modes) → the fit still matches f1-f3 to 0.1 %."""
    from taptune.identify.pipeline import identify_recordings
    from taptune.io.audio import read_audio
    from taptune.model import analyse
    from taptune.synthetic import write_tap_recording

    asm = reference_fit[0]
    wav = write_tap_recording(tmp_path / "tap.wav", asm, HOLDER_A, seed=5, snr_db=35.0, contact_s=50e-6,
                              radiation_exponent=2.0, mic_lp_hz=20000.0)
    analyses, result = identify_recordings([read_audio(wav)], [asm], IdentifyOptions(seed=0))
    truth = np.array(analyse(asm, HOLDER_A).bending_hz[:3])
    model = np.array(result.bending_model_hz[0])
    assert np.max(np.abs(model / truth - 1)) < 1e-3
    kinds = {round(p.hz / 100): p.kind for p in analyses[0].peaks}
    assert kinds.get(97) == "local"  # the HSK-A63 interface mode at 9.7 kHz is excluded


def test_one_assembly_per_recording_and_one_holder_are_required(reference_fit):
    from dataclasses import replace

    from taptune.errors import InputError

    asm, analysis, _ = reference_fit
    with pytest.raises(InputError, match="one assembly per recording"):
        identify([analysis, analysis], [asm])
    other = replace(asm, holder=replace(asm.holder, name="another holder"))
    with pytest.raises(InputError, match="one holder"):
        identify([analysis, analysis], [asm, other])


def test_different_seeds_predict_within_each_others_bands(reference_fit):
    """Another seed lands elsewhere on the valley of equally good fits; its predictions must
    agree with the first within the reported spreads (the bands overlap)."""
    asm, analysis, first = reference_fit
    second = identify([analysis], [asm], IdentifyOptions(seed=11))
    for stickout_mm in sorted(TRANSFER):
        target = asm.with_stickout(stickout_mm * 1e-3)
        a, b = predict(first.param_sets, target), predict(second.param_sets, target)
        gap = np.abs(np.array(a.bending_hz) - np.array(b.bending_hz))
        assert np.all(gap <= np.array(a.bending_hz_spread) + np.array(b.bending_hz_spread)), (stickout_mm, a, b)
