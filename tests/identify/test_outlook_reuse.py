"""A prediction and its band do their model work once, with bit-identical numbers.

The band's geometry part divides central differences by the frequencies of the
predicted assembly; the prediction has just solved those (its best set), so the
sensitivities take them instead of building and solving that model again.
"""

from dataclasses import replace

import numpy as np

import taptune.model
from taptune.identify import predict
from taptune.identify.bands import relative_sensitivities
from taptune.io.assembly import Tolerances
from taptune.model import ModelOptions, build_model, solve_modes
from taptune.model.params import NOMINAL

SETS = [NOMINAL, replace(NOMINAL, k_tt=NOMINAL.k_tt * 1.3, alpha=-5.0)]
TOL = Tolerances(stickout=0.3e-3, diameter=0.01, flute_ratio=0.05)


def test_sensitivities_with_the_predictions_base_equal_the_solved_base_bit_for_bit(reference_assembly):
    target = reference_assembly.with_stickout(0.0735)
    # The old path: the sensitivities build and solve the base model themselves (uncached call).
    old = relative_sensitivities.__wrapped__(target, SETS[0], TOL, ModelOptions(), 3)
    p = predict(SETS, target, identified=[reference_assembly], tolerances=TOL)
    new = relative_sensitivities.__wrapped__(target, SETS[0], TOL, ModelOptions(), 3, p.bending_hz)
    assert set(old) == set(new) == {"stickout", "diameter", "flute_ratio"}
    for name in old:
        assert np.array_equal(old[name], new[name]), name
    # Mode by mode, the band's stick-out part is exactly |Δf/f| × f from the old sensitivities.
    assert p.band.geometry_parts_hz["stickout"] == tuple(map(float, np.abs(old["stickout"]) * np.array(p.bending_hz)))


def test_prediction_builds_the_predicted_assembly_once(reference_assembly, monkeypatch):
    target = reference_assembly.with_stickout(0.0745)  # a stick-out no other test caches
    built = []
    original = taptune.model.build_model

    def counting(assembly, *args, **kwargs):
        built.append(assembly)
        return original(assembly, *args, **kwargs)

    monkeypatch.setattr(taptune.model, "build_model", counting)
    predict(SETS, target, identified=[reference_assembly.with_stickout(0.0545)], tolerances=TOL)
    # The target once (its sets and its sensitivities' base), each ± tolerance move once;
    # the identified assembly's base once more (its frequencies are not known here).
    assert built.count(target) == 1
    assert len(built) == 1 + 6 + 7


def test_identified_frequencies_spare_their_solves_bit_for_bit(reference_assembly):
    # What identify's full-model check stores as bending_model_hz: the identified assembly
    # solved with the best set on the default model.
    identified = [reference_assembly, reference_assembly.with_stickout(0.0595)]
    known = [tuple(map(float, solve_modes(build_model(a), SETS[0], n_modes=3).frequency_hz[:3])) for a in identified]
    target = reference_assembly.with_stickout(0.0695)
    old = predict(SETS, target, identified=identified, tolerances=TOL)
    new = predict(SETS, target, identified=identified, tolerances=TOL, identified_hz=known)
    assert new.to_dict() == old.to_dict()
    assert new.band.geometry_parts_hz == old.band.geometry_parts_hz and new.band.half_width_hz == old.band.half_width_hz
    # Frequencies of other modes than predicted, or a mode not known, are not used.
    two = predict(SETS[:1], target, n_modes=2, identified=identified[:1], tolerances=TOL, identified_hz=known[:1])
    assert two.band.geometry_parts_hz == predict(SETS[:1], target, n_modes=2, identified=identified[:1],
                                                  tolerances=TOL).band.geometry_parts_hz


def test_outlook_builds_no_identified_base(reference_assembly, monkeypatch):
    identified = reference_assembly.with_stickout(0.0505)  # stick-outs no other test caches
    known = [tuple(map(float, solve_modes(build_model(identified), SETS[0], n_modes=3).frequency_hz[:3]))]
    target = reference_assembly.with_stickout(0.0705)
    built = []
    original = taptune.model.build_model

    def counting(assembly, *args, **kwargs):
        built.append(assembly)
        return original(assembly, *args, **kwargs)

    monkeypatch.setattr(taptune.model, "build_model", counting)
    predict(SETS, target, identified=[identified], tolerances=TOL, identified_hz=known)
    # The target once, six ± tolerance moves of each assembly; neither base again.
    assert built.count(target) == 1 and identified not in built
    assert len(built) == 1 + 6 + 6
