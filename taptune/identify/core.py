"""Identify a holder from tap recordings, and predict it with other tools and stick-outs.

The scikit-learn-like contract of taptune::

    result = identify(analyses, assemblies, IdentifyOptions(seed=0))   # fit
    predictions = predict(result.param_sets, assembly.with_stickout(0.0635))

``identify`` runs several independent genetic-algorithm "islands" (seeded from one
master seed, in parallel processes when allowed), polishes each best with BOBYQA, and
keeps every candidate whose objective is close to the best: the parameters of this
model are not all identifiable from three frequencies and one peak shape (MODEL.md §8.6),
but the predictions are, and their spread over the near-optimal set is the honest
uncertainty that ``predict`` reports.
"""

from __future__ import annotations

import multiprocessing as mp
import os
import time
from dataclasses import dataclass, field
from typing import Callable, Sequence

import numpy as np

from taptune.errors import InputError
from taptune.identify.objective import Objective, ObjectiveOptions, Target, make_target, model_shape
from taptune.identify.optimize import Archive, Cancelled, GAOptions, genetic_algorithm, polish
from taptune.model.params import NAMES, HolderParams, from_p, p_to_unit, to_p, unit_to_p

ProgressCallback = Callable[[float, str], "bool | None"]


@dataclass(frozen=True)
class IdentifyOptions:
    """How to identify. ``seed`` fixes the result; ``jobs`` only changes the speed."""

    seed: int = 0
    islands: int = 2  # independent GA runs, each polished; their union is the archive
    jobs: int | None = None  # processes; None = min(islands, CPU count)
    ga: GAOptions = GAOptions()
    polish_evaluations: int = 300
    polish_starts: int = 6  # polishes from diverse good points (island bests first)
    polish_band: float = 2.0  # archive points this far above J_min may start a polish
    objective: ObjectiveOptions = ObjectiveOptions()
    model: object | None = None  # taptune.model.ModelOptions; None = defaults
    # Near-optimal set: candidates with J <= J_min + near_abs + near_rel * J_min.
    near_abs: float = 0.05
    near_rel: float = 0.10
    near_count: int = 12  # how many diverse members the set keeps (best included)


@dataclass(frozen=True)
class Identification:
    """Result of :func:`identify` (SI inside, library units for the parameters)."""

    params: HolderParams
    param_sets: tuple[HolderParams, ...]  # near-optimal set, best first
    bending_measured_hz: tuple[tuple[float | None, ...], ...]  # per recording, modes 1–3
    bending_model_hz: tuple[tuple[float, ...], ...]  # full model at the best params
    damping_model: tuple[tuple[float, ...], ...]
    objective: float
    objective_terms: tuple[tuple[float, float], ...]  # (frequency, shape) per recording
    evaluations: int
    seconds: float
    seed: int
    warnings: tuple[str, ...]
    window_hz: tuple[np.ndarray, ...] = field(repr=False, compare=False)
    measured_shape: tuple[np.ndarray, ...] = field(repr=False, compare=False)
    model_shape: tuple[np.ndarray, ...] = field(repr=False, compare=False)

    @property
    def param_spread(self) -> dict[str, float]:
        """± half-range of each parameter over the near-optimal set."""
        values = np.array([[getattr(p, n) for n in NAMES] for p in self.param_sets])
        return {n: float((values[:, i].max() - values[:, i].min()) / 2) for i, n in enumerate(NAMES)}

    def to_dict(self) -> dict:
        """JSON-ready dictionary (CLI-CONTRACT.md keys for one recording; lists per recording for joint fits)."""
        single = len(self.bending_measured_hz) == 1

        def pick(x):
            return list(x[0]) if single else [list(v) for v in x]

        return {
            "bending_measured_hz": pick(self.bending_measured_hz),
            "bending_model_hz": pick([[round(f, 2) for f in v] for v in self.bending_model_hz]),
            "damping_ratio_model": pick([[round(z, 6) for z in v] for v in self.damping_model]),
            "params": self.params.to_dict(),
            "params_spread": self.param_spread,
            "near_optimal_sets": len(self.param_sets),
            "objective": round(self.objective, 6),
            "objective_terms": [{"frequency": round(f, 6), "shape": round(s, 6)} for f, s in self.objective_terms],
            "evaluations": self.evaluations,
            "seconds": round(self.seconds, 3),
            "seed": self.seed,
            "warnings": list(self.warnings),
        }


@dataclass(frozen=True)
class Prediction:
    """Predicted free-free bending modes of a holder with one tool at one stick-out."""

    stickout_mm: float
    bending_hz: tuple[float, ...]
    bending_hz_spread: tuple[float, ...]
    damping_ratio: tuple[float, ...]
    damping_ratio_spread: tuple[float, ...]

    def to_dict(self) -> dict:
        return {
            "stickout": round(self.stickout_mm, 4),
            "bending_hz": [round(f, 2) for f in self.bending_hz],
            "bending_hz_spread": [round(f, 2) for f in self.bending_hz_spread],
            "damping_ratio": [round(z, 6) for z in self.damping_ratio],
            "damping_ratio_spread": [round(z, 6) for z in self.damping_ratio_spread],
        }


# ----------------------------------------------------------------------------- helpers


def _model_options(options: IdentifyOptions):
    from taptune.model import ModelOptions

    return options.model if options.model is not None else ModelOptions()


def bending_peaks(analysis) -> dict[int, float]:
    """Bending frequencies by mode number from a :class:`SpectrumAnalysis`."""
    out: dict[int, float] = {}
    for peak in analysis.peaks:
        if peak.kind == "bending" and peak.mode is not None:
            out[int(peak.mode)] = float(peak.hz)
    return out


def _select_diverse(u: np.ndarray, f: np.ndarray, count: int) -> np.ndarray:
    """Indices of up to ``count`` mutually distant rows of u, starting with the best (farthest-point sampling)."""
    order = np.argsort(f, kind="stable")
    u = u[order]
    chosen = [0]
    dist = np.linalg.norm(u - u[0], axis=1)
    while len(chosen) < min(count, len(u)):
        i = int(np.argmax(dist))
        if dist[i] < 1e-6:
            break
        chosen.append(i)
        dist = np.minimum(dist, np.linalg.norm(u - u[i], axis=1))
    return order[np.array(chosen)]


# The objective and the progress counters a worker sees. Set in the parent before the
# worker processes fork, so the evaluators are built once and shared, never pickled.
_STATE: dict = {}


@dataclass(frozen=True)
class _RunResult:
    u: np.ndarray
    value: float
    evaluations: int
    archive_u: np.ndarray
    archive_f: np.ndarray
    cancelled: bool = False


def _near_band(value: float, options: IdentifyOptions) -> float:
    return options.near_abs + options.near_rel * abs(value)


def _ga_task(index: int) -> _RunResult:
    """One GA island; returns its best point and the archive near it."""
    objective: Objective = _STATE["objective"]
    options: IdentifyOptions = _STATE["options"]
    counts, cancel = _STATE["counts"], _STATE["cancel"]
    seed = np.random.SeedSequence(options.seed).spawn(options.islands)[index]
    archive = Archive()
    start = objective.evaluations

    def on_generation(generation, best):
        counts[index] = generation
        return not cancel.is_set()

    from threadpoolctl import threadpool_limits

    with threadpool_limits(1):
        try:
            ga = genetic_algorithm(
                lambda U: objective.batch(unit_to_p(U)), len(NAMES), np.random.default_rng(seed), options.ga,
                archive, on_generation,
            )
        except Cancelled:
            au, af = archive.arrays()
            return _RunResult(au[0], float(af[0]), objective.evaluations - start, au[:0], af[:0], True)
    counts[index] = options.ga.generations
    au, af = archive.arrays()
    # The polish starts and the near-optimal set come from the neighbourhood of the optimum only.
    keep = af <= ga.value + options.polish_band + _near_band(ga.value, options)
    return _RunResult(ga.u, ga.value, objective.evaluations - start, au[keep], af[keep])


def _polish_task(u0: np.ndarray) -> _RunResult:
    """BOBYQA from one start; returns the polished point and its near-optimal trail."""
    objective: Objective = _STATE["objective"]
    options: IdentifyOptions = _STATE["options"]
    if _STATE["cancel"].is_set():
        return _RunResult(u0, Objective.BAD, 0, np.empty((0, len(u0))), np.empty(0), True)
    archive = Archive()
    start = objective.evaluations
    from threadpoolctl import threadpool_limits

    with threadpool_limits(1):
        u, value, _ = polish(lambda x: objective(unit_to_p(x)), u0, options.polish_evaluations, archive=archive)
    au, af = archive.arrays()
    keep = af <= value + _near_band(value, options)
    return _RunResult(u, value, objective.evaluations - start, au[keep], af[keep])


def _polish_starts(results: list[_RunResult], options: IdentifyOptions) -> np.ndarray:
    """Each island's best, then diverse good points of the archives (different places on the
    valley of equally good fits, MODEL.md §8.6), up to ``options.polish_starts``."""
    au = np.vstack([r.archive_u for r in results] + [r.u[None, :] for r in results])
    af = np.concatenate([r.archive_f for r in results] + [[r.value] for r in results])
    j_min = float(af.min())
    good = af <= j_min + options.polish_band + _near_band(j_min, options)
    starts = [r.u for r in sorted(results, key=lambda r: r.value)]
    for i in _select_diverse(au[good], af[good], options.polish_starts):
        u = au[good][i]
        if min(np.linalg.norm(u - s) for s in starts) > 0.05:
            starts.append(u)
    return np.array(starts[: max(options.polish_starts, len(results))])


def _run_pool(objective: Objective, options: IdentifyOptions, progress: ProgressCallback | None):
    """GA islands, then polishes from diverse starts; in forked processes where allowed."""
    jobs = options.jobs or min(options.islands, os.cpu_count() or 1)
    jobs = max(1, jobs)
    use_processes = jobs > 1 and "fork" in mp.get_all_start_methods()
    ctx = mp.get_context("fork") if use_processes else None
    counts = ctx.Array("i", options.islands, lock=False) if ctx else [0] * options.islands
    cancel = ctx.Event() if ctx else _LocalFlag()
    total = options.islands * options.ga.generations
    phase = {"base": 0.05, "span": 0.75}

    def report() -> None:
        fraction = phase["base"] + phase["span"] * min(1.0, sum(counts) / total)
        message = "fitting the model" if phase["base"] < 0.5 else "polishing near-optimal fits"
        if progress is not None and progress(fraction, message) is False:
            cancel.set()

    def run_tasks(pool, fn, items):
        if pool is None:
            out = []
            for item in items:
                out.append(fn(item))
                if cancel.is_set():
                    break
            return out
        pending = pool.map_async(fn, items, chunksize=1)
        while not pending.ready():
            pending.wait(0.1)
            report()
        return pending.get()

    _STATE.update(objective=objective, options=options, counts=counts,
                  cancel=_ProgressFlag(report, cancel) if ctx is None else cancel)
    try:
        pool = ctx.Pool(min(jobs, max(options.islands, options.polish_starts))) if ctx else None
        try:
            islands = run_tasks(pool, _ga_task, range(options.islands))
            if cancel.is_set() or any(r.cancelled for r in islands):
                raise Cancelled()
            phase.update(base=0.8, span=0.0)
            report()
            polished = run_tasks(pool, _polish_task, list(_polish_starts(islands, options)))
        finally:
            if pool is not None:
                pool.terminate()
    finally:
        _STATE.clear()
    if cancel.is_set() or any(r.cancelled for r in polished):
        raise Cancelled()
    return islands, polished


class _LocalFlag:
    """A stand-in for multiprocessing.Event in the single-process path."""

    def __init__(self):
        self._set = False

    def set(self):
        self._set = True

    def is_set(self):
        return self._set


class _ProgressFlag:
    """Calls the progress report whenever the island asks whether it was cancelled."""

    def __init__(self, report, flag):
        self.report, self.flag = report, flag

    def set(self):
        self.flag.set()

    def is_set(self):
        self.report()
        return self.flag.is_set()


# ----------------------------------------------------------------------------- identify


def identify(
    analyses: Sequence,
    assemblies: Sequence,
    options: IdentifyOptions = IdentifyOptions(),
    progress: ProgressCallback | None = None,
    evaluator_factory: Callable | None = None,
) -> Identification:
    """Fit the seven holder parameters to one or several tap recordings of one holder.

    Parameters
    ----------
    analyses : sequence of SpectrumAnalysis
        One per recording (``taptune.signal.analyse_recording``), with labelled bending peaks.
    assemblies : sequence of Assembly
        The assembly of each recording (same holder, any tool and stick-out).
    options : IdentifyOptions
        Seed, optimiser budget, objective and model options.
    progress : callable, optional
        ``progress(fraction, message)``; returning False cancels (raises ``Cancelled``).
    evaluator_factory : callable, optional
        ``factory(assembly, model_options)`` returning an evaluator; default the fast
        reduced model (:class:`taptune.model.reduced.FastEvaluator`).

    Returns
    -------
    Identification
    """
    from taptune.model import build_model, solve_modes, tip_receptance

    t0 = time.perf_counter()
    if len(analyses) != len(assemblies) or not analyses:
        raise InputError("identify: give one assembly per recording")
    names = {a.holder.name for a in assemblies}
    if len(names) > 1:
        raise InputError(f"identify: a joint fit needs one holder, got {sorted(names)}")
    model_options = _model_options(options)

    def say(fraction, message):
        if progress is not None and progress(fraction, message) is False:
            raise Cancelled()

    targets: list[Target] = []
    warnings: list[str] = []
    for analysis, asm in zip(analyses, assemblies):
        label = getattr(analysis, "path", "") or asm.source
        target = make_target(analysis.freq_hz, analysis.magnitude, bending_peaks(analysis), options.objective, label)
        targets.append(target)
        warnings.extend(target.warnings)

    say(0.0, "building the model")
    if evaluator_factory is None:
        from taptune.model.reduced import FastEvaluator

        evaluator_factory = FastEvaluator
    evaluators = [evaluator_factory(asm, model_options) for asm in assemblies]
    objective = Objective(targets, evaluators, options.objective)

    say(0.05, "fitting the model")
    islands, polished = _run_pool(objective, options, progress)
    results = islands + polished
    evaluations = sum(r.evaluations for r in results)
    best = min(polished, key=lambda r: r.value)

    # Near-optimal set over the union of the islands' archives.
    au = np.vstack([r.archive_u for r in results])
    af = np.concatenate([r.archive_f for r in results])
    j_min = float(min(af.min(), best.value))
    near = af <= j_min + options.near_abs + options.near_rel * j_min
    chosen = _select_diverse(au[near], af[near], options.near_count)
    sets_u = au[near][chosen]
    # The polished optimum heads the set even where the archive holds an equal value.
    sets_u = np.vstack([best.u, sets_u[np.linalg.norm(sets_u - best.u, axis=1) > 1e-9]])[: options.near_count]
    param_sets = tuple(from_p(unit_to_p(u)) for u in sets_u)
    params = param_sets[0]

    say(0.97, "checking on the full model")
    measured, model_hz, model_zeta, window, meas_shape, mod_shape, terms = [], [], [], [], [], [], []
    for target, asm in zip(targets, assemblies):
        fe = build_model(asm, model_options)
        modes = solve_modes(fe, params, n_modes=3)
        h = tip_receptance(fe, params, target.window_hz)
        fm = np.asarray(modes.frequency_hz[:3], dtype=float)
        meas = {m: f for m, f in zip(target.modes, target.measured_hz)}
        measured.append(tuple(float(meas[m]) if m in meas else None for m in (1, 2, 3)))
        model_hz.append(tuple(float(f) for f in fm))
        model_zeta.append(tuple(float(z) for z in modes.damping_ratio[:3]))
        window.append(target.window_hz)
        meas_shape.append(target.shape)
        mod_shape.append(model_shape(target.window_hz, h, options.objective))
        from taptune.identify.objective import objective_terms

        terms.append(objective_terms(target, fm, h, options.objective))
        misfit = np.abs(fm[np.asarray(target.modes) - 1] / target.measured_hz - 1)
        if misfit.max() > 0.001:
            warnings.append(
                f"{target.label}: the fitted model misses a measured bending frequency by {100 * misfit.max():.2f} % "
                "(check the peak labels and the assembly dimensions)"
            )
    at_bound = [n for n, u in zip(NAMES, p_to_unit(to_p(params))) if (u < 1e-3 or u > 1 - 1e-3) and n not in ("eta_tt", "eta_rr")]
    if at_bound:
        warnings.append(f"identified {', '.join(at_bound)} at the edge of the search space: the assembly description may be off")
    say(1.0, "done")
    return Identification(
        params=params,
        param_sets=param_sets,
        bending_measured_hz=tuple(measured),
        bending_model_hz=tuple(model_hz),
        damping_model=tuple(model_zeta),
        objective=float(sum(f + s for f, s in terms)),
        objective_terms=tuple(terms),
        evaluations=int(evaluations),
        seconds=time.perf_counter() - t0,
        seed=options.seed,
        warnings=tuple(dict.fromkeys(warnings)),
        window_hz=tuple(window),
        measured_shape=tuple(meas_shape),
        model_shape=tuple(mod_shape),
    )


# ----------------------------------------------------------------------------- predict


def predict(param_sets: Sequence[HolderParams], assembly, model_options=None, n_modes: int = 3,
            relative_floor: float = 5e-4) -> Prediction:
    """Predict the bending modes of ``assembly`` with the holder's near-optimal parameter sets.

    Every set fits the measurement equally well (MODEL.md §8.6), so the prediction is the
    centre of the band their predictions span and the spread its half-width — but never
    less than ``relative_floor`` × f: the measured frequencies themselves are only known
    to about 0.05 % (or to the fit's residual misfit, if larger; see
    :func:`fit_misfit`), and no parameter set can predict better than it was measured.
    """
    from taptune.model import ModelOptions, build_model, solve_modes

    if not param_sets:
        raise InputError("predict: the holder has no identified parameters")
    fe = build_model(assembly, model_options or ModelOptions())
    f, z = [], []
    for params in param_sets:
        modes = solve_modes(fe, params, n_modes=n_modes)
        f.append(np.asarray(modes.frequency_hz[:n_modes], dtype=float))
        z.append(np.asarray(modes.damping_ratio[:n_modes], dtype=float))
    f, z = np.array(f), np.array(z)
    f_mid, z_mid = (f.max(0) + f.min(0)) / 2, (z.max(0) + z.min(0)) / 2
    f_half = np.maximum((f.max(0) - f.min(0)) / 2, relative_floor * f_mid)
    return Prediction(
        stickout_mm=assembly.stickout * 1e3,
        bending_hz=tuple(map(float, f_mid)),
        bending_hz_spread=tuple(map(float, f_half)),
        damping_ratio=tuple(map(float, z_mid)),
        damping_ratio_spread=tuple(map(float, (z.max(0) - z.min(0)) / 2)),
    )


def fit_misfit(measured_hz, model_hz, floor: float = 5e-4) -> float:
    """Largest relative miss of the fitted model on the measured frequencies, at least ``floor``.

    Works on the pairs stored in an identification or a library provenance record (None
    entries, modes not measured, are skipped).
    """
    pairs = [(m, f) for m, f in zip(measured_hz, model_hz) if m is not None and f is not None]
    return max([floor] + [abs(f / m - 1) for m, f in pairs])
