"""The genetic algorithm and the least-squares polish find known optima, deterministically."""

import numpy as np
import pytest

from taptune.identify.optimize import (Archive, Cancelled, GAOptions, genetic_algorithm, latin_hypercube,
                                      polish_least_squares)

OPTIMUM = np.array([0.13, 0.87, 0.42, 0.05, 0.61, 0.33, 0.77])


def shifted_sphere(U):
    """Convex bowl with its minimum 0 at OPTIMUM."""
    return np.sum((np.atleast_2d(U) - OPTIMUM) ** 2, axis=1)


def rastrigin(U):
    """Multimodal: many local minima, the global one (0) at OPTIMUM."""
    X = 4 * (np.atleast_2d(U) - OPTIMUM)
    return np.sum(X**2 - np.cos(2 * np.pi * X) + 1, axis=1)


def rastrigin_residuals(u):
    """Residuals whose squares sum to :func:`rastrigin` (1 − cos 2πx = 2 sin² πx)."""
    X = 4 * (np.asarray(u) - OPTIMUM)
    return np.concatenate([X, np.sqrt(2) * np.sin(np.pi * X)])


def test_latin_hypercube_has_one_point_per_stratum():
    u = latin_hypercube(10, 7, np.random.default_rng(1))
    assert u.shape == (10, 7)
    for j in range(7):
        assert sorted(np.floor(u[:, j] * 10).astype(int)) == list(range(10))


def test_ga_then_polish_finds_the_minimum_of_a_bowl():
    rng = np.random.default_rng(0)
    ga = genetic_algorithm(shifted_sphere, 7, rng, GAOptions(population=40, generations=60))
    assert ga.value < 1e-2
    u, value, n = polish_least_squares(lambda x: np.asarray(x) - OPTIMUM, ga.u, 120)
    assert value < 1e-10
    np.testing.assert_allclose(u, OPTIMUM, atol=1e-5)
    assert n <= 120


def test_ga_escapes_local_minima_of_rastrigin():
    rng = np.random.default_rng(3)
    ga = genetic_algorithm(rastrigin, 7, rng, GAOptions(population=80, generations=150, patience=40))
    u, value, _ = polish_least_squares(rastrigin_residuals, ga.u, 400)
    assert value < 1e-6, "the GA should land in the global basin"


def test_same_seed_gives_identical_run_and_archive():
    runs = []
    for _ in range(2):
        archive = Archive()
        r = genetic_algorithm(rastrigin, 7, np.random.default_rng(42), GAOptions(generations=20), archive)
        runs.append((r, archive.arrays()))
    (a, (au, af)), (b, (bu, bf)) = runs
    assert a.value == b.value and np.array_equal(a.u, b.u)
    assert np.array_equal(au, bu) and np.array_equal(af, bf)
    assert len(af) == a.evaluations


def test_different_seeds_explore_differently():
    a = genetic_algorithm(rastrigin, 7, np.random.default_rng(1), GAOptions(generations=5))
    b = genetic_algorithm(rastrigin, 7, np.random.default_rng(2), GAOptions(generations=5))
    assert not np.array_equal(a.archive_u, b.archive_u)


def test_ga_stops_early_once_converged():
    r = genetic_algorithm(shifted_sphere, 7, np.random.default_rng(0), GAOptions(generations=500, patience=10))
    assert r.generations < 500


def test_progress_callback_can_cancel():
    with pytest.raises(Cancelled):
        genetic_algorithm(shifted_sphere, 7, np.random.default_rng(0), on_generation=lambda g, best: g < 3)


def bowl_residuals(u):
    """A nonlinear least-squares problem with its zero at OPTIMUM (J = Σ r²)."""
    d = np.asarray(u) - OPTIMUM
    return np.concatenate([d, 0.5 * d**2, [np.sum(d) ** 2]])


def test_least_squares_polish_reaches_the_minimum_in_few_evaluations():
    archive = Archive()
    u, value, n = polish_least_squares(bowl_residuals, np.full(7, 0.5), 120, archive=archive)
    assert value < 1e-8
    np.testing.assert_allclose(u, OPTIMUM, atol=1e-4)
    au, af = archive.arrays()
    assert n == len(af) <= 120
    assert value == af.min()


def test_least_squares_polish_keeps_to_its_budget_and_the_cube():
    target = np.full(7, 1.3)  # outside the box: the polish nears the bound from inside
    u, value, n = polish_least_squares(lambda x: np.asarray(x) - target, np.full(7, 0.5), 30)
    assert n <= 30
    assert np.all(u <= 1.0) and np.all(u >= 0.0)
    np.testing.assert_allclose(u, 1.0, atol=1e-2)
