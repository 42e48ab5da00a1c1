"""Honest prediction bands (identify.bands): composition, tolerances, model-form term, advice."""

import json
from dataclasses import replace

import numpy as np
import pytest

from taptune.errors import InputError
from taptune.identify import predict
from taptune.identify.bands import (DELTA_REF_MM, GROUPS, MODEL_FORM, PINNED_SPREAD, WIDE_BAND, coefficients_for,
                                    compose, conformal_quantile, evidence_groups, identified_spread, model_form_term,
                                    second_tap_advice)
from taptune.io.assembly import Tolerances, assembly_from_toml, assembly_to_toml
from taptune.model.params import NOMINAL
from tests.conftest import REFERENCE_TOML

EXACT = Tolerances(stickout=0.0, diameter=0.0, flute_ratio=0.0)
SETS = [NOMINAL, replace(NOMINAL, k_tt=NOMINAL.k_tt * 1.3, alpha=-5.0)]


def test_tolerance_keys_default_validate_and_round_trip():
    asm = assembly_from_toml(REFERENCE_TOML)
    assert asm.tolerances == Tolerances()
    text = REFERENCE_TOML.replace("stickout = 53.5", "stickout = 53.5\nstickout_tolerance = 0.5")
    text = text.replace("clamp_length = 40.0", "clamp_length = 40.0\ndiameter_tolerance = 0.2")
    text = text.replace("flute_diameter = 16.0", "flute_diameter = 16.0\nflute_ratio_tolerance = 0.02")
    asm = assembly_from_toml(text)
    assert asm.tolerances == Tolerances(stickout=0.5e-3, diameter=0.002, flute_ratio=0.02)
    again = assembly_from_toml(assembly_to_toml(asm))
    assert again.tolerances == asm.tolerances and again == asm
    assert asm.with_stickout(0.06).tolerances == asm.tolerances


@pytest.mark.parametrize("key,value,fragment", [("stickout_tolerance", -0.1, r"\[setup\] stickout_tolerance must lie in \[0, 20\] mm"),
                                                 ("stickout_tolerance", "'x'", "must be a number")])
def test_bad_tolerance_names_the_key(key, value, fragment):
    text = REFERENCE_TOML.replace("stickout = 53.5", f"stickout = 53.5\n{key} = {value}")
    with pytest.raises(InputError, match=fragment):
        assembly_from_toml(text, "a.toml")


def test_exact_description_without_model_form_is_the_set_spread(reference_assembly):
    target = reference_assembly.with_stickout(0.0635)
    p = predict(SETS, target, tolerances=EXACT, model_form=(0.0, 0.0, 0.0))
    alt = predict(SETS[1:], target, tolerances=EXACT, model_form=(0.0, 0.0, 0.0))
    spread = np.abs(np.array(alt.bending_hz) - p.bending_hz)
    assert np.allclose(p.bending_hz_spread, np.maximum(spread, 5e-4 * np.array(p.bending_hz)))
    assert p.band.geometry_hz == (0.0, 0.0, 0.0) and p.band.half_width_hz == p.bending_hz_spread


def test_stickout_part_is_the_frequency_change_over_the_ruler_tolerance(reference_assembly):
    # Independent route: the predicted frequencies themselves at ± the tolerance.
    target = reference_assembly.with_stickout(0.0635)
    tol = Tolerances(stickout=0.4e-3, diameter=0.0, flute_ratio=0.0)
    p = predict(SETS[:1], target, tolerances=tol, model_form=(0.0, 0.0, 0.0))
    up, down = (predict(SETS[:1], target.with_stickout(0.0635 + s), tolerances=EXACT, model_form=(0, 0, 0))
                for s in (0.4e-3, -0.4e-3))
    expected = np.abs(np.array(up.bending_hz) - down.bending_hz) / 2
    assert np.allclose(p.band.geometry_parts_hz["stickout"], expected, rtol=1e-6)
    assert np.all(expected > 0) and np.all(np.diff(up.bending_hz) > 0)
    # Longer tool, lower frequencies: f1 falls by ~2·f1·δ/L-ish, a few Hz per 0.4 mm here.
    assert np.all(np.array(up.bending_hz) < down.bending_hz)


def test_holder_and_flute_errors_count_only_where_the_transfer_changes_their_effect(reference_assembly):
    # Predicting the identified assembly itself: the parameters absorbed a wrong diameter
    # or flute ratio completely, only the stick-outs' ruler errors remain.
    tol = Tolerances(stickout=0.3e-3, diameter=0.01, flute_ratio=0.05)
    same = predict(SETS[:1], reference_assembly, identified=[reference_assembly], tolerances=tol, model_form=(0, 0, 0))
    assert np.allclose(same.band.geometry_parts_hz["diameter"], 0.0)
    assert np.allclose(same.band.geometry_parts_hz["flute_ratio"], 0.0)
    assert same.band.delta_stickout_mm == 0.0
    far = predict(SETS[:1], reference_assembly.with_stickout(0.0735), identified=[reference_assembly],
                  tolerances=tol, model_form=(0, 0, 0))
    assert np.all(np.array(far.band.geometry_parts_hz["flute_ratio"]) > 0)
    assert far.band.delta_stickout_mm == pytest.approx(20.0)


def test_model_form_grows_with_the_stickout_change_and_composes_in_quadrature():
    f = np.array([4000.0, 12000.0, 18000.0])
    c = (0.002, 0.003, 0.004)
    assert np.allclose(model_form_term(f, 0.0, c), np.array(c) * f)
    assert np.allclose(model_form_term(f, DELTA_REF_MM, c), 2 * np.array(c) * f)
    assert np.allclose(model_form_term(f, None, c), model_form_term(f, 20.0, c))  # unknown: assume 20 mm
    assert np.allclose(compose([3.0], [4.0], [12.0]), [13.0])


def test_band_json_text_and_second_tap_advice(reference_assembly):
    target = reference_assembly.with_stickout(0.0735)
    one = predict(SETS, target, identified=[reference_assembly], model_form=(0.008, 0.008, 0.008))
    d = json.loads(json.dumps(one.to_dict()))
    assert d["bending_hz_spread"] == d["band"]["half_width_hz"]
    assert set(d["band"]["components_hz"]) == {"set", "geometry", "model_form"}
    assert d["band"]["coverage_target"] == 0.9 and d["band"]["recordings"] == 1
    assert d["band"]["delta_stickout_mm"] == pytest.approx(20.0)
    assert len(d["band"]["model_form_groups"]) == 3 and set(d["band"]["model_form_groups"]) <= set(GROUPS)
    assert "90 of 100" in one.band_text()
    assert np.max(one.band.relative(one.bending_hz)) > WIDE_BAND
    assert "tap the same holder once more" in second_tap_advice([one])
    two = predict(SETS, target, identified=[reference_assembly, reference_assembly.with_stickout(0.0635)],
                  model_form=(0.008, 0.008, 0.008))
    assert two.band.delta_stickout_mm == pytest.approx(10.0)
    assert second_tap_advice([two]) is None


def test_conformal_quantile_is_the_ceil_level_n_plus_1_th_smallest():
    scores = np.arange(19.0, 0.0, -1.0)  # 1..19, shuffled order does not matter
    assert conformal_quantile(scores, 0.9) == 18.0  # ⌈0.9 × 20⌉ = 18
    assert conformal_quantile(scores, 0.5) == 10.0  # ⌈0.5 × 20⌉ = 10
    assert conformal_quantile([3.0, 1.0, 2.0], 0.9) == 3.0  # too few for 90 %: the largest
    assert conformal_quantile([], 0.9) == 0.0
    # The guarantee it gives: a fresh exchangeable score is ≤ it with probability ≥ 0.9.
    rng = np.random.default_rng(3)
    hits = [rng.exponential() <= conformal_quantile(rng.exponential(size=49), 0.9) for _ in range(2000)]
    assert 0.88 <= np.mean(hits) <= 0.95


def test_evidence_groups_pinned_free_and_unknown():
    f = np.array([[1000.0, 2000.0, 3000.0], [1001.0, 2010.0, 3000.0], [999.5, 1995.0, 3003.0]])
    assert np.allclose(identified_spread(f), [1e-3, 5e-3, 1e-3])
    assert evidence_groups(f) == ("pinned", "free", "pinned")
    assert evidence_groups(f, measured=[True, True, False]) == ("pinned", "free", "unknown")
    # A single set: nothing shows the tap pinned a mode, and there is no spread to stand in
    # for the model-form term: the widest group, whatever was measured.
    assert evidence_groups(f[:1]) == ("free",) * 3
    assert evidence_groups(f[:1], measured=[True, False, False]) == ("free",) * 3


def test_measured_modes_any_recording():
    from taptune.identify.bands import measured_modes

    assert measured_modes([[4000.0, None, 19000.0]]) == (True, False, True)
    assert measured_modes([[4000.0, None, None], [3000.0, 12000.0, None]]) == (True, True, False)
    assert measured_modes([[4000.0]]) == (True, False, False)
    edge = np.array([[1000.0], [1000.0 * (1 + PINNED_SPREAD)]])
    assert evidence_groups(edge) == ("pinned",)


def test_model_form_coefficients_per_group_per_mode_or_per_mode():
    groups = ("pinned", "free", "unknown")
    assert np.allclose(coefficients_for({"pinned": 0.001, "free": 0.002, "unknown": 0.003}, groups, 3),
                       [0.001, 0.002, 0.003])
    per_mode = {"pinned": (0.001, 0.004, 0.005), "free": (0.002, 0.006, 0.007), "unknown": 0.009}
    assert np.allclose(coefficients_for(per_mode, ("free", "pinned", "unknown"), 3), [0.002, 0.004, 0.009])
    assert np.allclose(coefficients_for((0.001, 0.002), groups, 3), [0.001, 0.002, 0.002])  # the old form
    assert set(MODEL_FORM) == set(GROUPS)
    f = np.array([4000.0, 12000.0, 18000.0])
    assert np.allclose(model_form_term(f, 0.0, per_mode, ("free", "pinned", "unknown")), [8.0, 48.0, 162.0])


def test_prediction_band_uses_the_group_of_each_mode(reference_assembly):
    target = reference_assembly.with_stickout(0.0635)
    c = {"pinned": 0.001, "free": 0.01, "unknown": 0.1}
    p = predict(SETS, target, identified=[reference_assembly], tolerances=EXACT, model_form=c,
                measured_modes=[True, True, False])
    groups = p.band.model_form_groups
    assert groups[2] == "unknown"
    expected = [c[g] * f * (1 + 10.0 / DELTA_REF_MM) for g, f in zip(groups, p.bending_hz)]
    assert np.allclose(p.band.model_form_hz, expected)
    assert "not measured in the tap" in p.band_text()


def test_a_jointly_identified_holder_takes_the_joint_coefficients_never_narrower(reference_assembly):
    from taptune.identify.bands import MODEL_FORM_JOINT, model_form_for

    assert model_form_for(1) is MODEL_FORM and model_form_for(2) is MODEL_FORM_JOINT
    assert all(MODEL_FORM_JOINT[g] >= MODEL_FORM[g] for g in GROUPS)  # a library history may mix both
    target = reference_assembly.with_stickout(0.0735)
    taps = [reference_assembly, reference_assembly.with_stickout(0.0635)]
    measured = (True, False, False)
    joint = predict(SETS, target, identified=taps, measured_modes=measured, tolerances=EXACT)
    by_hand = predict(SETS, target, identified=taps, measured_modes=measured, tolerances=EXACT, model_form=MODEL_FORM_JOINT)
    assert joint.bending_hz_spread == by_hand.bending_hz_spread
    one = predict(SETS, target, identified=taps[:1], measured_modes=measured, tolerances=EXACT)
    c = coefficients_for(MODEL_FORM_JOINT, joint.band.model_form_groups, 3)
    # Δ = 10 mm from the nearer tap: c × f × (1 + 10/Δref).
    assert np.allclose(joint.band.model_form_hz, c * np.array(joint.bending_hz) * (1 + 10.0 / DELTA_REF_MM))
    assert one.band.delta_stickout_mm == pytest.approx(20.0)


def test_each_identification_counts_the_stickout_tolerance_it_stated(reference_assembly):
    """Tapped with the stick-out read off a ruler, predicted with a gauge-measured file: the
    identification's reading error stays a ruler's (the band must not narrow with the
    new file), while the prediction's own stick-out part is the gauge's."""
    from taptune.library.schema import HolderEntry, ProvenanceRecord, tool_to_dict

    gauge, ruler = Tolerances(stickout=0.05e-3), Tolerances(stickout=0.3e-3)
    target = replace(reference_assembly.with_stickout(0.0735), tolerances=gauge)
    by_ruler = predict(SETS[:1], target, identified=[replace(reference_assembly, tolerances=ruler)])
    by_gauge = predict(SETS[:1], target, identified=[replace(reference_assembly, tolerances=gauge)])
    ruler_part = np.array(by_ruler.band.geometry_parts_hz["stickout_identified"])
    gauge_part = np.array(by_gauge.band.geometry_parts_hz["stickout_identified"])
    # Central differences over ±0.3 mm and ±0.05 mm: six times the change, to within curvature.
    np.testing.assert_allclose(ruler_part, 6 * gauge_part, rtol=0.02)
    assert by_ruler.band.geometry_parts_hz["stickout"] == by_gauge.band.geometry_parts_hz["stickout"]
    assert np.all(np.array(by_ruler.bending_hz_spread) > by_gauge.bending_hz_spread)
    # The library keeps the tolerance of each identification and its predictions use it.
    record = ProvenanceRecord(recording="tap.wav", sha256="0" * 64, tool=tool_to_dict(reference_assembly.tool),
                              stickout_mm=53.5, date="2026-11-25T20:00:00Z", objective=0.1, seed=0, evaluations=1,
                              bending_measured_hz=(4686.0, None, None), bending_model_hz=(4686.0, None, None),
                              taptune_version="0.1.0", stickout_tolerance_mm=0.3)
    entry = HolderEntry.create(reference_assembly.holder, SETS[0], identifications=[record])
    (identified,) = entry.identified_assemblies()
    assert identified.tolerances.stickout == pytest.approx(0.3e-3)
    assert entry.predict(target).band.geometry_parts_hz["stickout_identified"] == pytest.approx(
        by_ruler.band.geometry_parts_hz["stickout_identified"], rel=1e-9)
    unstated = HolderEntry.create(reference_assembly.holder, SETS[0],
                                  identifications=[replace(record, stickout_tolerance_mm=None)])
    assert unstated.identified_assemblies()[0].tolerances == Tolerances()  # a ruler's, by default


def test_band_text_names_the_tolerance_that_makes_most_of_the_geometry_part(reference_assembly):
    target = reference_assembly.with_stickout(0.0635)
    gauge = predict(SETS[:1], target, identified=[reference_assembly], model_form=(0, 0, 0),
                    tolerances=Tolerances(stickout=0.05e-3, diameter=0.01, flute_ratio=0.05))
    parts = gauge.band.geometry_parts_hz
    assert np.sum(np.square(parts["flute_ratio"])) > np.sum(np.square(parts["stickout"]))
    assert "Most of that is the flute ratio's ±0.05" in gauge.band_text()
    assert "[tool] flute_ratio_tolerance" in gauge.band_text()
    ruler = predict(SETS[:1], target, identified=[replace(reference_assembly, tolerances=Tolerances(stickout=0.8e-3))],
                    model_form=(0, 0, 0), tolerances=Tolerances(stickout=0.8e-3, diameter=0.01, flute_ratio=0.01))
    assert "the stick-out's ±0.8 mm" in ruler.band_text()
    # Not where the model-form term makes most of the band.
    wide = predict(SETS[:1], target, identified=[reference_assembly], model_form=(0.02, 0.02, 0.02))
    assert "Most of that" not in wide.band_text() and "what the model leaves out" in wide.band_text()


def test_taps_agree_needs_two_taps_five_heard_frequencies_and_a_joint_fit_within_0_1_percent():
    from taptune.identify.bands import AGREED_MISFIT, taps_agree

    six = [[5000.0, 14000.0, 22000.0], [6000.0, 15000.0, None]]
    assert taps_agree(six, 5e-4) and taps_agree(six, AGREED_MISFIT)
    assert not taps_agree(six, 1.5 * AGREED_MISFIT)  # the one set misses a frequency
    assert not taps_agree([[5000.0, 14000.0, None], [6000.0, 15000.0, None]], 5e-4)  # four heard
    assert not taps_agree([[5000.0, 14000.0, 22000.0]], 5e-4)  # one tap: five parameters meet three always
    assert taps_agree(six, 5e-4, [0.050, 0.060]) and taps_agree(six, 5e-4, [0.050, 0.055])
    assert not taps_agree(six, 5e-4, [0.050, 0.052])  # two taps at about one stick-out say nothing of transfer
    # Two taps at one stick-out repeat its three frequencies: 4 distinct, not 7 (five parameters meet 4 always).
    same = [[4686.0, 14935.0, 19894.0], [4686.3, 14934.0, 19895.0], [3742.0, None, None]]
    assert not taps_agree(same, 5e-4, [0.0535, 0.0535, 0.0635])
    assert taps_agree(same[:1] + [[3742.0, 12100.0, None]], 5e-4, [0.0535, 0.0635])
    # Calibrated with gauged stick-outs: a ruler's ±0.3 mm does not earn it.
    assert taps_agree(six, 5e-4, [0.050, 0.060], [0.05e-3, 0.05e-3])
    assert not taps_agree(six, 5e-4, [0.050, 0.060], [0.05e-3, 0.3e-3])


def test_agreeing_taps_take_the_agreed_coefficients_for_pinned_modes_only(reference_assembly):
    from taptune.identify.bands import MODEL_FORM_AGREED, MODEL_FORM_JOINT, model_form_for

    assert model_form_for(2, agreed=True) is MODEL_FORM_AGREED and model_form_for(2) is MODEL_FORM_JOINT
    assert model_form_for(1, agreed=True) is MODEL_FORM  # one tap cannot agree
    assert MODEL_FORM_AGREED["pinned"] < MODEL_FORM["pinned"]
    assert MODEL_FORM_AGREED["free"] == MODEL_FORM_JOINT["free"]
    assert MODEL_FORM_AGREED["unknown"] == MODEL_FORM_JOINT["unknown"]
    taps = [reference_assembly, reference_assembly.with_stickout(0.0635)]
    target = reference_assembly.with_stickout(0.0735)
    sets = [NOMINAL, replace(NOMINAL, k_tt=NOMINAL.k_tt * 1.0001)]  # agree on every mode: all pinned
    joint = predict(sets, target, identified=taps, measured_modes=(True, True, True))
    agreed = predict(sets, target, identified=taps, measured_modes=(True, True, True), agreed=True)
    assert joint.band.model_form_groups == agreed.band.model_form_groups == ("pinned",) * 3
    f = np.array(agreed.bending_hz)
    expected = MODEL_FORM_AGREED["pinned"] * f * (1 + agreed.band.delta_stickout_mm / DELTA_REF_MM)
    assert np.allclose(agreed.band.model_form_hz, expected)
    assert np.all(np.array(agreed.bending_hz_spread) < joint.bending_hz_spread)
    assert agreed.band.taps_agree and not joint.band.taps_agree and agreed.band.to_dict()["taps_agree"] is True
    assert "the taps agree" in agreed.band_text() and "the taps agree" not in joint.band_text()
