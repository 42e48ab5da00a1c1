"""The fast reduced evaluator reproduces the full converged model over the whole search space.

Accuracy required of the optimiser's evaluator (docs/physics.md §4), measured on
seeded Latin-hypercube points and corners of the bounds of p:
  * f1–f3 within 0.01 % of the full model;
  * ζ1 within 0.5 %;
  * |H_tt| on the 201-point, 1 Hz objective window centred on f1 within 0.5 % of the
    window's largest |H_tt| (the objective normalises by that peak).
The reference is the full model: ARPACK modes and the direct (one LU per frequency)
tip receptance.
"""

import copy
import itertools
import tomllib
from pathlib import Path

import numpy as np
import pytest

from taptune.io.assembly import load_assembly, parse_assembly
from taptune.model import build_model, solve_modes, tip_receptance
from taptune.model.params import NOMINAL, P_LOWER, P_UPPER, HolderParams, from_p, to_p
from taptune.model.reduced import BatchEvaluation, Evaluation, FastEvaluator, ReductionOptions, _Solver
from tests.conftest import REFERENCE_TOML

ASSETS = Path(__file__).resolve().parents[2] / "assets"
F_TOL, ZETA_TOL, H_TOL = 1e-4, 5e-3, 5e-3
WINDOW = np.arange(-100.0, 101.0)  # the objective's shape window around f1 [Hz]
HOLDER_A = HolderParams(1.90e9, 9.37e3, 1.98e-3, 8.20e-3, -10.0, 7478 / 7800, 1.0)


def assembly(name: str):
    """The reference assembly (the example of docs/assembly-format.md) or an assembly file of assets/."""
    if name == "reference":
        return parse_assembly(tomllib.loads(REFERENCE_TOML), "reference.toml")
    return load_assembly(ASSETS / f"{name}.toml")


@pytest.fixture(scope="module")
def reference():
    """(full model, evaluator) of the reference assembly, built once for this module."""
    fe = build_model(assembly("reference"))
    return fe, FastEvaluator.from_model(fe)


def sample(n_lhs: int, n_corners: int, seed: int) -> np.ndarray:
    """Seeded points of p: a Latin hypercube and randomly chosen corners of the bounds, (n, 7)."""
    rng = np.random.default_rng(seed)
    strata = np.stack([rng.permutation(n_lhs) for _ in range(7)], axis=1)
    lhs = (strata + rng.random((n_lhs, 7))) / n_lhs
    corners = np.array(list(itertools.product((0.0, 1.0), repeat=7)))
    u = np.vstack([lhs, corners[rng.permutation(len(corners))[:n_corners]]])
    return P_LOWER + u * (P_UPPER - P_LOWER)


def worst_errors(fe, evaluator, points) -> np.ndarray:
    """Largest relative errors (f1–f3, ζ1, |H| in the window) of the evaluator over the points."""
    worst = np.zeros(3)
    for p in points:
        params = from_p(p)
        modes = solve_modes(fe, params, n_modes=3)
        window = modes.frequency_hz[0] + WINDOW
        h_full = tip_receptance(fe, params, window, method="direct")
        e = evaluator.evaluate(p, window)
        errors = [
            np.max(np.abs(e.bending_hz / modes.frequency_hz[:3] - 1)),
            abs(e.damping_ratio[0] / modes.damping_ratio[0] - 1),
            np.max(np.abs(np.abs(e.tip_receptance) - np.abs(h_full))) / np.max(np.abs(h_full)),
        ]
        worst = np.maximum(worst, errors)
    return worst


def test_reduced_model_matches_the_full_model_on_the_reference_assembly(reference):
    """f1–f3 to 0.01 %, ζ1 to 0.5 %, |H| in the 200 Hz window to 0.5 % of its peak, on 8
    Latin-hypercube points and 4 corners of the search space (stiff, soft, lossy, loss-free)."""
    fe, ev = reference
    worst = worst_errors(fe, ev, sample(8, 4, 1))
    assert worst[0] < F_TOL and worst[1] < ZETA_TOL and worst[2] < H_TOL, worst


@pytest.mark.parametrize("name, seed", [("er32_hsk63_d6", 2), ("shrinkfit_hsk63_d12", 3)])
def test_reduced_model_matches_the_full_model_on_other_assemblies(name, seed):
    """The same tolerances for a Ø6 tool in an ER32 × 80 chuck and a Ø12 tool in a slim
    shrink-fit chuck (different contact lengths, holder profiles and mode spacings)."""
    fe = build_model(assembly(name))
    worst = worst_errors(fe, FastEvaluator.from_model(fe), sample(8, 4, seed))
    assert worst[0] < F_TOL and worst[1] < ZETA_TOL and worst[2] < H_TOL, worst


@pytest.mark.slow
@pytest.mark.parametrize("name", ["reference", "er32_hsk63_d6", "shrinkfit_hsk63_d12", "hydraulic_hsk63_d20"])
def test_reduced_model_matches_the_full_model_on_a_large_sweep(name):
    """The same tolerances on 150 Latin-hypercube points and all 128 corners per assembly."""
    fe = build_model(assembly(name))
    worst = worst_errors(fe, FastEvaluator.from_model(fe), sample(150, 128, 100))
    assert worst[0] < F_TOL and worst[1] < ZETA_TOL and worst[2] < H_TOL, worst


def test_holder_A_matches_the_converged_table(reference):
    """Holder A at 53.5 mm (converged values of two independent implementations), 4685.8 / 14934.8 / 19891.9 Hz, ζ1 = 0.391 %,
    H_tt(1000 Hz) ≈ −9.178e-8 − 2.25e-10 i m/N (rigid-body terms included)."""
    _, ev = reference
    e = ev.evaluate(to_p(HOLDER_A), [1000.0])
    assert np.allclose(e.bending_hz, [4685.8, 14934.8, 19891.9], rtol=5e-4)
    assert e.damping_ratio[0] == pytest.approx(0.00391, rel=0.02)
    assert e.tip_receptance[0].real == pytest.approx(-9.178e-8, rel=1e-3)
    assert e.tip_receptance[0].imag == pytest.approx(-2.25e-10, rel=0.02)


def test_the_assembly_constructor_builds_the_same_evaluator(reference):
    """FastEvaluator(assembly) and FastEvaluator.from_model(build_model(assembly)) agree exactly
    (the build is deterministic)."""
    _, ev = reference
    again = FastEvaluator(assembly("reference"))
    window = 4800.0 + WINDOW
    for p in sample(3, 1, 9):
        np.testing.assert_array_equal(again.evaluate(p, window).tip_receptance, ev.evaluate(p, window).tip_receptance)


def test_the_cached_evaluator_is_built_once_per_assembly(reference):
    """The app identifies the same assembly again and again: its evaluator is reused."""
    from taptune.model.reduced import cached_evaluator

    first = cached_evaluator(assembly("reference"))
    assert cached_evaluator(assembly("reference")) is first
    other = assembly("reference").with_stickout(0.0635)
    assert cached_evaluator(other) is not first
    window = 4800.0 + WINDOW
    p = sample(1, 1, 4)[0]
    np.testing.assert_array_equal(first.evaluate(p, window).tip_receptance, reference[1].evaluate(p, window).tip_receptance)


def test_a_fresh_process_finds_the_evaluator_in_the_disk_cache(reference, tmp_path, monkeypatch):
    """One ``taptune identify`` per tap: the next process loads the reduced model instead of
    training it again, and the loaded model gives the very same numbers."""
    from taptune.model import reduced

    monkeypatch.setenv("TAPTUNE_CACHE_DIR", str(tmp_path))
    reduced.cached_evaluator.cache_clear()
    built = reduced.cached_evaluator(assembly("reference"))
    assert len(list(tmp_path.glob("reduced-*.npz"))) == 1
    reduced.cached_evaluator.cache_clear()  # as a new process starts

    def no_training(*args, **kwargs):
        raise AssertionError("trained again although the disk cache has the model")

    monkeypatch.setattr(reduced.FastEvaluator, "from_model", no_training)
    loaded = reduced.cached_evaluator(assembly("reference"))
    window = 4800.0 + WINDOW
    P = sample(4, 2, 5)
    np.testing.assert_array_equal(loaded.evaluate_many(P, window).tip_receptance,
                                  built.evaluate_many(P, window).tip_receptance)
    np.testing.assert_array_equal(loaded.evaluate(P[0], window).tip_receptance, reference[1].evaluate(P[0], window).tip_receptance)
    # Another stick-out is another model: not served by this entry.
    reduced.cached_evaluator.cache_clear()
    with pytest.raises(AssertionError, match="trained again"):
        reduced.cached_evaluator(assembly("reference").with_stickout(0.0635))
    reduced.cached_evaluator.cache_clear()


def test_a_corrupt_disk_cache_entry_is_rebuilt(reference, tmp_path, monkeypatch):
    from taptune.model import reduced

    monkeypatch.setenv("TAPTUNE_CACHE_DIR", str(tmp_path))
    reduced.cached_evaluator.cache_clear()
    reduced.cached_evaluator(assembly("reference"))
    (entry,) = tmp_path.glob("reduced-*.npz")
    good = entry.read_bytes()
    window = 4800.0 + WINDOW
    p = sample(1, 1, 6)[0]
    for bad in (good[: len(good) // 2], b"", b"not a zip file"):
        entry.write_bytes(bad)
        reduced.cached_evaluator.cache_clear()
        again = reduced.cached_evaluator(assembly("reference"))
        np.testing.assert_array_equal(again.evaluate(p, window).tip_receptance, reference[1].evaluate(p, window).tip_receptance)
        assert entry.read_bytes() == good  # rebuilt and saved over
    # Arrays that load but do not fit together (another version's layout): rebuilt too.
    with np.load(entry) as z:
        arrays = dict(z)
    arrays["starts"] = arrays["starts"][:, :3]
    np.savez(entry, **arrays)
    reduced.cached_evaluator.cache_clear()
    again = reduced.cached_evaluator(assembly("reference"))
    np.testing.assert_array_equal(again.evaluate(p, window).tip_receptance, reference[1].evaluate(p, window).tip_receptance)
    reduced.cached_evaluator.cache_clear()


def test_the_disk_cache_can_be_turned_off(tmp_path, monkeypatch):
    from taptune.model import reduced

    monkeypatch.setenv("TAPTUNE_CACHE_DIR", "off")
    monkeypatch.setenv("HOME", str(tmp_path))
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "xdg"))
    reduced.cached_evaluator.cache_clear()
    reduced.cached_evaluator(assembly("reference"))
    reduced.cached_evaluator.cache_clear()
    assert not any(tmp_path.rglob("*.npz"))


def test_evaluate_many_equals_evaluate(reference):
    """The batch form gives the single results, stacked."""
    _, ev = reference
    P = sample(4, 2, 9)
    window = 4800.0 + WINDOW
    batch = ev.evaluate_many(P, window)
    assert isinstance(batch, BatchEvaluation) and len(batch) == len(P)
    assert batch.bending_hz.shape == (len(P), 3) and batch.tip_receptance.shape == (len(P), len(window))
    for i, p in enumerate(P):
        single = ev.evaluate(p, window)
        assert isinstance(single, Evaluation)
        assert single.bending_hz.shape == (3,) and single.damping_ratio.shape == (3,)
        np.testing.assert_allclose(batch[i].bending_hz, single.bending_hz, rtol=1e-9)
        np.testing.assert_allclose(batch[i].damping_ratio, single.damping_ratio, rtol=1e-6)
        np.testing.assert_allclose(batch[i].tip_receptance, single.tip_receptance, rtol=1e-6)


def assert_batch_equals_single(ev, P, window):
    """evaluate_many equals evaluate row by row within the solver's tolerances, with the
    same inverse iterations per candidate (the same convergence test)."""
    batch = ev.evaluate_many(P, window)
    single = [ev.evaluate(p, window) for p in P]
    np.testing.assert_array_equal(batch.iterations, [e.iterations for e in single])
    for b, s in zip(batch.tip_receptance, single):
        assert np.max(np.abs(b - s.tip_receptance)) < 1e-7 * np.max(np.abs(s.tip_receptance))
    np.testing.assert_allclose(batch.bending_hz, [e.bending_hz for e in single], rtol=1e-9)
    np.testing.assert_allclose(batch.damping_ratio, [e.damping_ratio for e in single], rtol=1e-6)
    return batch


def test_the_batched_solver_equals_the_single_one_across_the_bounds(reference):
    """40 Latin-hypercube points and 24 corners in one batch: the stacked iteration (one
    solve per iteration serving as next step and error estimate) takes the same number of
    iterations as the single one (2 to 5 here) and gives the same modes and receptance."""
    _, ev = reference
    batch = assert_batch_equals_single(ev, sample(40, 24, 11), 4800.0 + WINDOW)
    assert batch.iterations.min() == 2 and batch.iterations.max() > 2


def test_unconverged_candidates_of_a_batch_fall_back_to_the_single_solver(reference):
    """With at most 2 iterations the candidates that need more leave the batch unconverged
    and are solved one at a time (dense solution: iterations = 0), the others stay batched."""
    _, ev = reference
    short = copy.copy(ev)
    short._solver = _Solver(ev.model, ReductionOptions(max_iterations=2))
    batch = assert_batch_equals_single(short, sample(24, 8, 12), 4800.0 + WINDOW)
    assert 0 < np.count_nonzero(batch.iterations == 0) < len(batch)


def test_dense_fallback_gives_the_same_answer(reference):
    """A candidate whose inverse iteration does not converge is solved densely on the reduced
    model (iterations = 0); forced here by a solver with an unreachable tolerance."""
    _, ev = reference
    dense = copy.copy(ev)
    dense._solver = _Solver(ev.model, ReductionOptions(tol=0.0, tol_damping=0.0, max_iterations=2))
    window = 4800.0 + WINDOW
    for p in sample(2, 1, 4):
        e, d = ev.evaluate(p, window), dense.evaluate(p, window)
        assert d.iterations == 0
        np.testing.assert_allclose(d.bending_hz, e.bending_hz, rtol=1e-5)
        assert d.damping_ratio[0] == pytest.approx(e.damping_ratio[0], rel=1e-3)
        assert np.max(np.abs(d.tip_receptance - e.tip_receptance)) < 1e-3 * np.max(np.abs(e.tip_receptance))


def test_low_frequency_receptance_is_the_rigid_body_mass_line(reference):
    """Far below mode 1 the free-free tip receptance tends to −(1/m + d²/J)/ω² (rigid-body mass and inertia):
    the reduced model keeps the exact rigid-body terms."""
    fe, ev = reference
    h_full = tip_receptance(fe, NOMINAL, [5.0, 50.0], method="direct")
    h = ev.evaluate(to_p(NOMINAL), [5.0, 50.0]).tip_receptance
    np.testing.assert_allclose(h, h_full, rtol=1e-6)


def test_the_fast_contact_coefficients_equal_the_parameters_own():
    """stiffness_coefficients repeats HolderParams.c_t/c_r in plain Python for speed; they must agree."""
    from taptune.model.params import P_LOWER, P_UPPER, from_p
    from taptune.model.reduced import stiffness_coefficients

    for u in np.random.default_rng(0).random((20, 7)):
        p = P_LOWER + u * (P_UPPER - P_LOWER)
        params = from_p(p)
        c = stiffness_coefficients(p)
        a = params.alpha / 100
        expected = [1.0, params.modulus_factor, params.c_t, params.c_t * a, params.c_r, params.c_r * a]
        np.testing.assert_allclose(c, expected, rtol=1e-12)
