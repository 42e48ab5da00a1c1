"""The near-optimal set: every parameter vector that explains the measurement as well as the best.

Three frequencies and one peak shape do not pin seven parameters (docs/physics.md §5): the
good fits form a long, curved valley. Its members are defined term by term against the
best fit (see :class:`~taptune.identify.core.IdentifyOptions`): the frequency term may
exceed the best's by what the measured peaks support, the shape term may reach a
multiple of the best's, because it is dominated by the systematic difference between
the sound and the tool-tip receptance. The valley can run to the edge of the search space
(a contact so stiff that the frequencies no longer feel it), far beyond what an optimiser's
archive visits, so its extent is measured directly: for every parameter, the smallest and
the largest value inside the set (:func:`set_extreme`, a constrained COBYLA run); an
adaptive random walk was tried and travelled too slowly along the valley.
Predictions over these members give honest uncertainty bands.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class SetLimits:
    """Upper limits of the frequency and the shape term (summed over recordings) for set members."""

    frequency: float
    shape: float

    def contains(self, terms: np.ndarray) -> bool:
        return bool(terms[0] <= self.frequency and terms[1] <= self.shape)


def summed_terms(objective, u_to_p, u) -> np.ndarray:
    """(frequency term, shape term) summed over the objective's recordings at unit point u
    (:meth:`Objective.summed_terms`: a failed model evaluation lies outside every set)."""
    return objective.summed_terms(u_to_p(u))


def set_extreme(terms_at, start: np.ndarray, quantity, sign: float, limits: SetLimits,
                max_evaluations: int, initial_step: float):
    """Push ``quantity(u)`` as low (sign −1) or high (+1) as the set allows.

    Constrained COBYLA (nlopt) on [0, 1]^d from a member ``start``: maximise
    sign·quantity(u) subject to both terms staying within ``limits``. ``quantity`` is a
    coordinate index or a callable (e.g. a predicted frequency at another stick-out,
    relative to its value at ``start``). COBYLA stops after ``max_evaluations``; its
    first step is ``initial_step`` in every unit coordinate (small: the set is a thin
    valley and the start lies on its edge).

    Returns
    -------
    members : ndarray, shape (k, d)
        The members of the set met on the way, in the order met (the start first).
    evaluations : int
    """
    import nlopt

    d = len(start)
    cache: dict = {}
    found = [np.asarray(start, dtype=float).copy()]

    def terms(u):
        key = u.tobytes()
        if key not in cache:
            cache[key] = terms_at(u)
            if limits.contains(cache[key]):
                found.append(u.copy())
        return cache[key]

    opt = nlopt.opt(nlopt.LN_COBYLA, d)
    opt.set_lower_bounds(np.zeros(d))
    opt.set_upper_bounds(np.ones(d))
    value = (lambda u: float(u[quantity])) if isinstance(quantity, (int, np.integer)) else quantity
    opt.set_min_objective(lambda u, grad: -sign * value(np.array(u)))
    opt.add_inequality_constraint(lambda u, grad: float(terms(np.array(u))[0] - limits.frequency), 0.0)
    opt.add_inequality_constraint(lambda u, grad: float(terms(np.array(u))[1] - limits.shape), 0.0)
    opt.set_maxeval(int(max_evaluations))
    opt.set_xtol_abs(1e-4)
    opt.set_initial_step(np.full(d, initial_step))
    try:
        opt.optimize(np.clip(start, 0.0, 1.0))
    except (nlopt.RoundoffLimited, ValueError, RuntimeError):
        pass  # keep the members found so far
    return np.array(found), len(cache)
