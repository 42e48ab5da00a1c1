"""Objective.batch (a GA generation) evaluates the new points together and gives what one
call per point gives."""

import numpy as np
import pytest

from taptune.identify.objective import Objective, ObjectiveOptions, make_target
from taptune.model.params import P_LOWER, P_UPPER
from taptune.model.reduced import FastEvaluator
from tests.identify.test_objective import FREQ, resonance
from tests.model.test_reduced import assembly


@pytest.fixture(scope="module")
def evaluator():
    return FastEvaluator(assembly("reference"))


def generation(seed: int, n: int = 30) -> np.ndarray:
    """Seeded points of the search space, with a repeated row and a clone of an earlier one."""
    P = P_LOWER + np.random.default_rng(seed).random((n, 7)) * (P_UPPER - P_LOWER)
    P[5] = P[2]
    return P


@pytest.mark.parametrize("options", [ObjectiveOptions(), ObjectiveOptions(compare="db", quantity="accelerance")])
def test_batch_equals_one_call_per_point(evaluator, options):
    """Two recordings (one with modes 1 and 3 only): same values, same evaluation count,
    same memo as the point-by-point objective."""
    targets = [
        make_target(FREQ, np.abs(resonance(FREQ, 4800.0)), {1: 4800.0, 2: 14500.0, 3: 19000.0}, options),
        make_target(FREQ, np.abs(resonance(FREQ, 4700.0, 0.01)), {1: 4700.0, 3: 18800.0}, options),
    ]
    batched = Objective(targets, [evaluator, evaluator], options)
    single = Objective(targets, [evaluator, evaluator], options)
    P = generation(3)
    batched(P[0])  # a remembered point is not evaluated again
    values = batched.batch(P)
    expected = np.array([single(p) for p in P])
    np.testing.assert_allclose(values, expected, rtol=1e-6)
    assert batched.evaluations == len(P) + 1 and single.evaluations == len(P)
    assert set(batched.memo) == set(single.memo)


def test_a_failing_candidate_is_bad_and_the_others_are_not(evaluator):
    """A candidate the model cannot solve makes the batch go point by point: that one is BAD."""

    class Failing:
        def __init__(self, bad):
            self.bad = bad

        def evaluate(self, p, window_hz):
            if np.array_equal(p, self.bad):
                raise np.linalg.LinAlgError("singular")
            return evaluator.evaluate(p, window_hz)

        def evaluate_many(self, P, window_hz):
            if any(np.array_equal(p, self.bad) for p in P):
                raise np.linalg.LinAlgError("singular")
            return evaluator.evaluate_many(P, window_hz)

    target = make_target(FREQ, np.abs(resonance(FREQ, 4800.0)), {1: 4800.0, 2: 14500.0, 3: 19000.0})
    P = generation(4, 6)
    values = Objective([target], [Failing(P[1])]).batch(P)
    assert values[1] == Objective.BAD and np.all(values[[0, 2, 3, 4]] < Objective.BAD)
    np.testing.assert_allclose(values[[0, 2, 3, 4]], Objective([target], [evaluator]).batch(P[[0, 2, 3, 4]]), rtol=1e-9)
