"""The analysis before the fit does its work once: the plausible labelings' quick fits share
their model solves."""

import numpy as np

from taptune.identify.labelfit import RememberedEvaluator


class _Counting:
    def __init__(self):
        self.calls = 0

    def evaluate(self, p, window_hz):
        self.calls += 1
        return float(np.sum(p)) + float(np.sum(window_hz))


def test_remembered_evaluator_solves_each_candidate_once():
    ev = RememberedEvaluator(_Counting())
    p = np.array([1.0, 2.0, 3.0])
    first = ev.evaluate(p, [1000.0])
    assert ev.evaluate(p.copy(), np.array([1000.0])) == first
    assert ev.evaluator.calls == 1
    ev.evaluate(p, [2000.0])
    ev.evaluate(p + 1e-12, [1000.0])
    assert ev.evaluator.calls == 3
