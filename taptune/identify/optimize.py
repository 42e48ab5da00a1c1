"""Optimisers on the unit cube [0, 1]^d: a real-coded genetic algorithm and a local polish.

The real-coded GA of docs/physics.md §4 (after Deb & Agrawal 1995): tournament selection,
simulated binary crossover (SBX), polynomial mutation, elitism, a seeded :class:`numpy.random.Generator`; then a bounded local
polish from the GA's best: :func:`polish_least_squares` (Gauss–Newton on the residual
vector of J; it beat nlopt's BOBYQA, which needed ≈ 250 evaluations for what it reaches
in ≈ 120). Every evaluated point is kept in an archive, because the near-optimal set is
the uncertainty of the identification.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable

import numpy as np


class Cancelled(Exception):
    """The caller asked the optimiser to stop (a progress callback returned False)."""


@dataclass(frozen=True)
class GAOptions:
    """Settings of the genetic algorithm (docs/physics.md §4)."""

    population: int = 48
    generations: int = 30
    crossover_probability: float = 0.9
    crossover_eta: float = 10.0  # SBX distribution index: larger = children nearer parents
    mutation_eta: float = 20.0  # polynomial mutation distribution index
    mutation_probability: float | None = None  # per gene; None = 1/d
    tournament: int = 2
    elite: int = 2
    patience: int = 10  # stop after this many generations without improvement …
    tolerance: float = 1e-3  # … by more than tolerance × best + tolerance_abs
    # J counts tolerances squared (docs/physics.md §4): gains below 0.005 change no prediction.
    tolerance_abs: float = 5e-3


@dataclass
class Archive:
    """Every point evaluated: unit-cube coordinates and objective values."""

    u: list = field(default_factory=list)
    f: list = field(default_factory=list)

    def add(self, u: np.ndarray, f: np.ndarray) -> None:
        self.u.append(np.atleast_2d(u).copy())
        self.f.append(np.atleast_1d(f).copy())

    def arrays(self) -> tuple[np.ndarray, np.ndarray]:
        if not self.u:
            return np.empty((0, 0)), np.empty(0)
        return np.vstack(self.u), np.concatenate(self.f)


@dataclass(frozen=True)
class OptimumResult:
    """Best point of one optimisation run and what it cost."""

    u: np.ndarray
    value: float
    evaluations: int
    generations: int
    archive_u: np.ndarray
    archive_f: np.ndarray


def latin_hypercube(n: int, d: int, rng: np.random.Generator) -> np.ndarray:
    """n points in [0, 1]^d, one per stratum in every coordinate."""
    u = (np.arange(n)[:, None] + rng.random((n, d))) / n
    for j in range(d):
        u[:, j] = u[rng.permutation(n), j]
    return u


def _sbx(a: np.ndarray, b: np.ndarray, eta: float, rng) -> tuple[np.ndarray, np.ndarray]:
    """Simulated binary crossover of parent rows a, b (Deb & Agrawal 1995), vectorised."""
    r = rng.random(a.shape)
    beta = np.where(r <= 0.5, (2 * r) ** (1 / (eta + 1)), (1 / (2 * (1 - r))) ** (1 / (eta + 1)))
    # Each gene crosses with probability 0.5, as in the standard operator.
    beta = np.where(rng.random(a.shape) < 0.5, beta, 1.0)
    c1 = 0.5 * ((1 + beta) * a + (1 - beta) * b)
    c2 = 0.5 * ((1 - beta) * a + (1 + beta) * b)
    return c1, c2


def _polynomial_mutation(x: np.ndarray, eta: float, prob: float, rng) -> np.ndarray:
    """Bounded polynomial mutation on [0, 1] (Deb & Goyal 1996), vectorised."""
    mask = rng.random(x.shape) < prob
    r = rng.random(x.shape)
    d1, d2 = x, 1 - x
    q = 1 / (eta + 1)
    lo = (2 * r + (1 - 2 * r) * (1 - d1) ** (eta + 1)) ** q - 1
    hi = 1 - (2 * (1 - r) + 2 * (r - 0.5) * (1 - d2) ** (eta + 1)) ** q
    delta = np.where(r < 0.5, lo, hi)
    return np.clip(np.where(mask, x + delta, x), 0.0, 1.0)


def genetic_algorithm(
    fun_batch: Callable[[np.ndarray], np.ndarray],
    dim: int,
    rng: np.random.Generator,
    options: GAOptions = GAOptions(),
    archive: Archive | None = None,
    on_generation: Callable[[int, float], bool] | None = None,
) -> OptimumResult:
    """Minimise ``fun_batch`` (rows of unit-cube points → values) with a real-coded GA.

    ``on_generation(generation, best_value)`` is called after every generation; returning
    False raises :class:`Cancelled`.
    """
    archive = archive if archive is not None else Archive()
    n = options.population + options.population % 2
    prob_mut = options.mutation_probability or 1.0 / dim
    pop = latin_hypercube(n, dim, rng)
    fit = fun_batch(pop)
    archive.add(pop, fit)
    evaluations = n
    best_hist = [float(fit.min())]
    generation = 0
    for generation in range(1, options.generations + 1):
        # Tournament selection of n parents.
        contenders = rng.integers(0, n, size=(n, options.tournament))
        winners = contenders[np.arange(n), np.argmin(fit[contenders], axis=1)]
        parents = pop[winners]
        a, b = parents[0::2], parents[1::2]
        c1, c2 = _sbx(a, b, options.crossover_eta, rng)
        cross = rng.random(len(a))[:, None] < options.crossover_probability
        children = np.vstack([np.where(cross, c1, a), np.where(cross, c2, b)])
        children = _polynomial_mutation(np.clip(children, 0, 1), options.mutation_eta, prob_mut, rng)
        child_fit = fun_batch(children)
        archive.add(children, child_fit)
        evaluations += len(children)
        # Elitism: the best of the old population survive in place of the worst children.
        elite = np.argsort(fit)[: options.elite]
        worst = np.argsort(child_fit)[::-1][: options.elite]
        children[worst], child_fit[worst] = pop[elite], fit[elite]
        pop, fit = children, child_fit
        best_hist.append(float(fit.min()))
        if on_generation is not None and on_generation(generation, best_hist[-1]) is False:
            raise Cancelled()
        if generation > options.patience:
            old = best_hist[-options.patience - 1]
            if old - best_hist[-1] <= options.tolerance * abs(best_hist[-1]) + options.tolerance_abs:
                break
    i = int(np.argmin(fit))
    au, af = archive.arrays()
    return OptimumResult(pop[i].copy(), float(fit[i]), evaluations, generation, au, af)


class _Budget(Exception):
    """The least-squares polish used its evaluations."""


def polish_least_squares(
    residuals: Callable[[np.ndarray], np.ndarray],
    u0: np.ndarray,
    max_evaluations: int = 120,
    diff_step: float = 1e-3,
    archive: Archive | None = None,
) -> tuple[np.ndarray, float, int]:
    """Bounded Gauss–Newton polish (trust-region reflective least squares) on the unit cube.

    J is a sum of squared residuals (docs/physics.md §4), so a Gauss–Newton step from a
    finite-difference Jacobian (d + 1 evaluations) goes about as far as a derivative-free
    method gets in a hundred. ``diff_step`` is the finite-difference step in unit-cube
    coordinates: far above the reduced model's solver noise (relative 1e-6 in λ).
    The reflective method nears a bound from inside (``dogbox``, which steps onto
    bounds, was measured to stall far above the optimum on identification problems).

    Parameters
    ----------
    residuals : callable
        Unit-cube point (d,) → residual vector whose squared norm is the objective.
    u0 : ndarray, shape (d,)
        Start point.
    max_evaluations : int
        Residual evaluations at most (Jacobian columns included).

    Returns
    -------
    (u, value, evaluations): the best point seen, its squared residual norm, evaluations used.
    """
    from scipy.optimize import least_squares

    u0 = np.clip(np.asarray(u0, dtype=float), 0.0, 1.0)
    best = [u0.copy(), np.inf]
    count = [0]

    def wrapped(u):
        if count[0] >= max_evaluations:
            raise _Budget()
        u = np.asarray(u, dtype=float)
        r = residuals(u)
        count[0] += 1
        value = float(np.dot(r, r))
        if archive is not None:
            archive.add(u, np.array([value]))
        if value < best[1]:
            best[0], best[1] = u.copy(), value
        return r

    try:
        least_squares(wrapped, u0, bounds=(0.0, 1.0), method="trf", diff_step=diff_step,
                      xtol=1e-8, ftol=1e-8, gtol=1e-10, x_scale=1.0)
    except _Budget:
        pass  # keep the best point seen
    return best[0], best[1], count[0]
