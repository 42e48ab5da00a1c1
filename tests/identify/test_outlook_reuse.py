"""A prediction and its band do their model work once, with bit-identical numbers.

The band's geometry part divides central differences by the frequencies of the
predicted assembly; the prediction has just solved those (its best set), so the
sensitivities take them instead of building and solving that model again. The ± moves
and the base of an assembly are cached apart, so the next prediction from the same
identified assembly (the report's rows after the outlook) builds none of them again.
"""

from dataclasses import replace

import numpy as np

import taptune.model
from taptune.identify import predict
from taptune.identify.bands import clear_caches, relative_sensitivities
from taptune.io.assembly import Tolerances
from taptune.model import ModelOptions, build_model, solve_modes
from taptune.model.params import NOMINAL

SETS = [NOMINAL, replace(NOMINAL, k_tt=NOMINAL.k_tt * 1.3, alpha=-5.0)]
TOL = Tolerances(stickout=0.3e-3, diameter=0.01, flute_ratio=0.05)


def _counting_builds(monkeypatch) -> list:
    built = []
    original = taptune.model.build_model

    def counting(assembly, *args, **kwargs):
        built.append(assembly)
        return original(assembly, *args, **kwargs)

    monkeypatch.setattr(taptune.model, "build_model", counting)
    return built


def test_sensitivities_with_the_predictions_base_equal_the_solved_base_bit_for_bit(reference_assembly):
    target = reference_assembly.with_stickout(0.0735)
    # The old path, written out: each ± move and the base built and solved on their own.
    up, down = (target.with_stickout(target.stickout + d) for d in (TOL.stickout, -TOL.stickout))
    f_up, f_down, f = (np.asarray(solve_modes(build_model(a), SETS[0], n_modes=3).frequency_hz[:3])
                       for a in (up, down, target))
    by_hand = (f_up - f_down) / 2 / f
    clear_caches()
    old = relative_sensitivities(target, SETS[0], TOL, ModelOptions(), 3)  # the base solved here
    p = predict(SETS, target, identified=[reference_assembly], tolerances=TOL)
    new = relative_sensitivities(target, SETS[0], TOL, ModelOptions(), 3, p.bending_hz)
    assert set(old) == set(new) == {"stickout", "diameter", "flute_ratio"}
    for name in old:
        assert np.array_equal(old[name], new[name]), name
    assert np.array_equal(old["stickout"], by_hand)
    # Mode by mode, the band's stick-out part is exactly |Δf/f| × f from the old sensitivities.
    assert p.band.geometry_parts_hz["stickout"] == tuple(map(float, np.abs(old["stickout"]) * np.array(p.bending_hz)))


def test_prediction_builds_the_predicted_assembly_once(reference_assembly, monkeypatch):
    target = reference_assembly.with_stickout(0.0745)
    clear_caches()
    built = _counting_builds(monkeypatch)
    predict(SETS, target, identified=[reference_assembly.with_stickout(0.0545)], tolerances=TOL)
    # The target once (its sets and its sensitivities' base), each ± tolerance move once;
    # the identified assembly's base once more (its frequencies are not known here).
    assert built.count(target) == 1
    assert len(built) == 1 + 6 + 7


def test_next_predictions_from_the_same_identification_build_only_their_target(reference_assembly, monkeypatch):
    identified = [reference_assembly.with_stickout(0.0505)]
    clear_caches()
    first = predict(SETS, reference_assembly.with_stickout(0.0705), identified=identified, tolerances=TOL)
    built = _counting_builds(monkeypatch)
    # As the report's rows follow the outlook: the identified assembly's moves and base are known.
    target = reference_assembly.with_stickout(0.0605)
    predict(SETS, target, identified=identified, tolerances=TOL)
    assert built.count(target) == 1 and not any(a.stickout < 0.0600 for a in built)
    assert len(built) == 1 + 6
    # The cache changes no number: the first prediction again, from cold, is equal.
    clear_caches()
    assert predict(SETS, reference_assembly.with_stickout(0.0705), identified=identified,
                   tolerances=TOL).to_dict() == first.to_dict()


def test_tolerance_moves_meshed_alike_agree_with_moves_meshed_on_their_own(reference_assembly):
    """The ± moves are meshed for their base's frequency (no first pass each): the
    sensitivities agree with fully re-meshed moves to well under a percent of themselves."""
    clear_caches()
    rel = relative_sensitivities(reference_assembly, SETS[1], TOL, ModelOptions(), 3)
    moves = {"stickout": lambda a, s: a.with_stickout(a.stickout + s * TOL.stickout),
             "diameter": lambda a, s: a.with_holder(replace(a.holder, segments=tuple(
                 replace(g, od=g.od * (1 + s * TOL.diameter)) for g in a.holder.segments)))}
    f = np.asarray(solve_modes(build_model(reference_assembly), SETS[1], n_modes=3).frequency_hz[:3])
    for name, move in moves.items():
        up, down = (np.asarray(solve_modes(build_model(move(reference_assembly, s)), SETS[1], n_modes=3).frequency_hz[:3])
                    for s in (1, -1))
        np.testing.assert_allclose(rel[name], (up - down) / 2 / f, rtol=2e-3, err_msg=name)
