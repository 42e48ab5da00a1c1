"""The parallel search behind :func:`taptune.identify.identify`.

Three phases run as tasks on worker processes (or in-process with ``jobs=1``; the
result is the same, bit for bit):

1. genetic-algorithm islands, each seeded from the master seed;
2. least-squares (Gauss–Newton) polishes from each island's best and from diverse good archive points;
3. the near-optimal set's extent, each parameter pushed low and high inside it
   (:mod:`taptune.identify.uncertainty`).

Two kinds of workers. In a plain process (the CLI) a pool is forked per identification:
the objective, with its evaluators, is set in :data:`STATE` before the fork, so it is
built once and shared, never pickled. Forking is unsafe once other threads run (Qt's),
so an app starts a :class:`WarmPool` once (``spawn``: fresh interpreters) and installs
it with :func:`set_shared_pool`; each identification then writes its objective pickled
(≈ 3 MB, 3 ms; rebuilding the evaluator in a worker costs 0.45 s) once to a temporary
file in shared memory (``/dev/shm`` where there is one), every task carries only its
name, and each worker reads and unpickles it once.
"""

from __future__ import annotations

import multiprocessing as mp
import os
import pickle
import tempfile
import threading
import time
from dataclasses import dataclass

import numpy as np

from taptune.identify.objective import Objective
from taptune.identify.optimize import Archive, Cancelled, genetic_algorithm, polish_least_squares
from taptune.identify.uncertainty import SetLimits, set_extreme, summed_terms
from taptune.model.params import NAMES, unit_to_p
from taptune.workers import ignore_interrupt

STATE: dict = {}


@dataclass(frozen=True)
class RunResult:
    """One task's outcome: its best point and the archive points near it (with their
    summed terms, ``archive_terms`` (k, 2), so the near-optimal set need not re-evaluate them)."""

    u: np.ndarray
    value: float
    evaluations: int
    archive_u: np.ndarray
    archive_f: np.ndarray
    cancelled: bool = False
    archive_terms: np.ndarray | None = None


def _with_terms(objective: Objective, au: np.ndarray) -> np.ndarray:
    """The remembered summed terms of archive points (all were evaluated by this task's objective)."""
    return np.array([objective.summed_terms(unit_to_p(u)) for u in au]).reshape(len(au), 2)


def remember(objective: Objective, results: list[RunResult]) -> None:
    """Put the terms that tasks computed (maybe in other processes) into the objective's memo."""
    for r in results:
        if r.archive_terms is not None:
            for u, t in zip(r.archive_u, r.archive_terms):
                objective.memo.setdefault(unit_to_p(u).tobytes(), t)


def n_modes(objective: Objective) -> int:
    """Measured bending frequencies over all recordings."""
    return sum(len(t.modes) for t in objective.targets)


def near_band(value: float, options, modes: int) -> float:
    """How far above J_min a member of the near-optimal set can lie (bounds both terms)."""
    return modes * options.near_frequency + (options.near_shape_factor - 1) * abs(value) + options.near_shape_abs


def select_diverse(u: np.ndarray, f: np.ndarray, count: int) -> np.ndarray:
    """Indices of up to ``count`` mutually distant rows of u, the best first (farthest-point sampling)."""
    if len(u) == 0:
        return np.zeros(0, dtype=int)
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


def _cancelled(start: np.ndarray) -> RunResult | None:
    """The result of a task that was asked to stop before it began, or None."""
    if STATE["cancel"].is_set():
        return RunResult(start, Objective.BAD, 0, np.empty((0, len(start))), np.empty(0), True)
    return None


def _limits():
    from threadpoolctl import threadpool_limits

    return threadpool_limits(1)


def ga_task(index: int) -> RunResult:
    """One GA island; returns its best point and the archive near it."""
    objective: Objective = STATE["objective"]
    options = STATE["options"]
    counts, cancel = STATE["counts"], STATE["cancel"]
    seed = np.random.SeedSequence(options.seed).spawn(options.islands)[index]
    archive = Archive()
    start = objective.evaluations

    def on_generation(generation, best):
        counts[index % len(counts)] = generation
        return not cancel.is_set()

    with _limits():
        try:
            ga = genetic_algorithm(
                lambda U: objective.batch(unit_to_p(U)), len(NAMES), np.random.default_rng(seed), options.ga,
                archive, on_generation,
            )
        except Cancelled:
            au, af = archive.arrays()
            return RunResult(au[0], float(af[0]), objective.evaluations - start, au[:0], af[:0], True)
    counts[index % len(counts)] = options.ga.generations
    au, af = archive.arrays()
    # Polish starts and the near-optimal set come from the neighbourhood of the optimum only.
    keep = af <= ga.value + options.polish_band + near_band(ga.value, options, n_modes(objective))
    return RunResult(ga.u, ga.value, objective.evaluations - start, au[keep], af[keep],
                     archive_terms=_with_terms(objective, au[keep]))


def polish_task(u0: np.ndarray) -> RunResult:
    """Least-squares (Gauss–Newton) polish from one start; returns the polished point and its near-optimal trail."""
    objective: Objective = STATE["objective"]
    options = STATE["options"]
    if (stopped := _cancelled(u0)) is not None:
        return stopped
    archive = Archive()
    start = objective.evaluations
    with _limits():
        u, value, _ = polish_least_squares(lambda x: objective.residuals(unit_to_p(x)), u0, options.polish_evaluations,
                                           archive=archive)
    au, af = archive.arrays()
    keep = af <= value + near_band(value, options, n_modes(objective))
    return RunResult(u, value, objective.evaluations - start, au[keep], af[keep],
                     archive_terms=_with_terms(objective, au[keep]))


def extreme_task(args) -> RunResult:
    """The smallest or largest value of one parameter inside the near-optimal set."""
    axis, sign, start, limits, start_terms = args
    objective: Objective = STATE["objective"]
    options = STATE["options"]
    # The start's terms as the caller has them: recomputed in a worker by another path
    # (batched or single solver) they could differ in the last digits, and COBYLA's path
    # with them, so that jobs would change the result.
    objective.memo.setdefault(unit_to_p(start).tobytes(), start_terms)
    if (stopped := _cancelled(start)) is not None:
        return stopped
    with _limits():
        found, evaluations = set_extreme(lambda u: summed_terms(objective, unit_to_p, u), start, axis, sign,
                                         limits, options.extreme_evaluations, options.extreme_step)
    ends = found[np.argsort(sign * found[:, axis])]
    # The extreme member, and one half way there so the band is filled in.
    keep = ends[[len(ends) // 2, -1]] if len(ends) > 1 else ends
    return RunResult(ends[-1], Objective.BAD, evaluations, keep, np.full(len(keep), np.inf))


def _pooled(results: list[RunResult], bests: list[RunResult]):
    """All archive points of ``results`` followed by the points of ``bests``: (u, J, J_min)."""
    au = np.vstack([r.archive_u for r in results] + [r.u[None, :] for r in bests])
    af = np.concatenate([r.archive_f for r in results] + [[r.value] for r in bests])
    return au, af, float(af.min())


def polish_starts(results: list[RunResult], options, modes: int) -> np.ndarray:
    """Each island's best, then diverse good points of the archives (different places on the
    valley of equally good fits, docs/physics.md §5), up to ``options.polish_starts``."""
    au, af, j_min = _pooled(results, results)
    good = af <= j_min + options.polish_band + near_band(j_min, options, modes)
    starts = [r.u for r in sorted(results, key=lambda r: r.value)]
    for i in select_diverse(au[good], af[good], options.polish_starts):
        u = au[good][i]
        if min(np.linalg.norm(u - s) for s in starts) > 0.05:
            starts.append(u)
    return np.array(starts[: max(options.polish_starts, len(results))])


class _LocalFlag:
    """A stand-in for multiprocessing.Event in the single-process path."""

    def __init__(self):
        self._set = False

    def set(self):
        self._set = True

    def is_set(self):
        return self._set


class _ProgressFlag:
    """Reports progress whenever an in-process task asks whether it was cancelled."""

    def __init__(self, report, flag):
        self.report, self.flag = report, flag

    def set(self):
        self.flag.set()

    def is_set(self):
        self.report()
        return self.flag.is_set()


#: Seconds a cancelled phase's tasks get to return before their workers are stopped anyway.
TASKS_STOP_S = 10.0

#: Progress slots of a warm pool (one per island; more islands share slots).
_SLOTS = 64


def _join_warm_pool(counts, cancel) -> None:
    """Initializer of a :class:`WarmPool` worker: the shared progress slots and cancel flag."""
    ignore_interrupt()
    STATE.update(counts=counts, cancel=cancel, key=None)


def _warm_up(_):
    """Import what the tasks need, so the first identification does not wait for it."""
    import nlopt  # noqa: F401
    import threadpoolctl  # noqa: F401

    import taptune.model.reduced  # noqa: F401

    return os.getpid()


def _remote(args):
    """Run one task in a warm worker: read this identification's objective once per worker."""
    fn, key, path, item = args
    if STATE.get("key") != key:
        with open(path, "rb") as f:
            objective, options = pickle.load(f)
        STATE.update(objective=objective, options=options, key=key)
    return fn(item)


def _shared_file(blob: bytes) -> str:
    """Write ``blob`` to a new temporary file, in shared memory where there is room, else
    in the temporary folder; its path. A file that could not be written is removed."""
    shm = ("/dev/shm",) if os.path.isdir("/dev/shm") and os.access("/dev/shm", os.W_OK) else ()
    for folder in shm:
        try:
            return _write_temp(blob, folder)
        except OSError:
            pass  # full, or out of inodes: the temporary folder instead
    return _write_temp(blob, None)


def _write_temp(blob: bytes, folder) -> str:
    """Write ``blob`` to a new temporary file in ``folder`` (None: the temporary folder);
    its path. A file that could not be written is removed; the error is raised."""
    fd, path = tempfile.mkstemp(prefix="taptune-objective-", suffix=".pkl", dir=folder)
    try:
        with os.fdopen(fd, "wb") as f:
            f.write(blob)
    except OSError:
        os.unlink(path)
        raise
    return path


class WarmPool:
    """Worker processes started once with ``spawn`` and kept for every identification.

    Safe in a process whose other threads are running (a Qt app): ``spawn`` starts fresh
    interpreters instead of forking. Workers import the model code as soon as they start,
    in the background. One identification uses the pool at a time (others wait).

    Parameters
    ----------
    processes : int, optional
        Worker processes; default the CPU count.
    """

    def __init__(self, processes: int | None = None):
        ctx = mp.get_context("spawn")
        self.processes = max(1, processes or os.cpu_count() or 1)
        self.counts = ctx.Array("i", _SLOTS, lock=False)
        self.cancel = ctx.Event()
        self.lock = threading.Lock()
        self.pool = ctx.Pool(self.processes, initializer=_join_warm_pool, initargs=(self.counts, self.cancel))
        self.warming = self.pool.map_async(_warm_up, range(self.processes), chunksize=1)

    def close(self, timeout: float = TASKS_STOP_S + 5.0) -> None:
        """Stop the workers (a running identification is cancelled).

        The warm-up and a cancelled identification's tasks get up to ``timeout`` s to
        return first: Pool.terminate() on a worker that is writing its result can wait
        forever on the lock that worker held (CPython issue 96995).
        """
        self.cancel.set()
        deadline = time.monotonic() + timeout
        self.warming.wait(timeout)
        if self.lock.acquire(timeout=max(0.0, deadline - time.monotonic())):
            self.lock.release()
        self.pool.terminate()
        self.pool.join()


_SHARED: dict = {}


def set_shared_pool(pool: WarmPool | None) -> None:
    """Make ``pool`` the workers of every identification in this process (None: fork per identification)."""
    _SHARED["pool"] = pool


def shared_pool() -> WarmPool | None:
    """The pool installed with :func:`set_shared_pool`, if any."""
    return _SHARED.get("pool")


class _Slots:
    """Island progress counters in a warm pool's shared slots."""

    def __init__(self, shared, n: int):
        self.shared, self.n = shared, n
        for i in range(min(n, len(shared))):
            shared[i] = 0

    def __iter__(self):
        return (self.shared[i % len(self.shared)] for i in range(self.n))


class Workers:
    """Runs the search phases on worker processes (or in-process) and reports progress.

    With a shared :class:`WarmPool` installed the phases run on it; otherwise a pool is
    forked per identification, but only from the main thread (forking while other
    threads run is unsafe); ``jobs=1`` runs in-process. Use as a context manager;
    ``map(fn, items)`` runs one phase, raising :class:`Cancelled` when the progress
    callback asked to stop.
    """

    def __init__(self, objective: Objective, options, progress=None):
        warm = shared_pool()
        jobs = max(1, options.jobs or min(options.islands, warm.processes if warm else os.cpu_count() or 1))
        self.warm = warm if jobs > 1 else None
        main_thread = threading.current_thread() is threading.main_thread()
        use_fork = jobs > 1 and not self.warm and main_thread and "fork" in mp.get_all_start_methods()
        self.ctx = mp.get_context("fork") if use_fork else None
        self.jobs = jobs
        self.total = options.islands * options.ga.generations
        self.progress = progress
        self.phase = (0.05, 0.75, "fitting the model")
        self.pool = None
        self.pending = None  # the phase running on workers
        if self.warm:
            self.warm.lock.acquire()
            self.warm.cancel.clear()
            self.counts = _Slots(self.warm.counts, options.islands)
            self.cancel = self.warm.cancel
            self.key = os.urandom(8).hex()
            self.path = None
            try:
                self.path = _shared_file(pickle.dumps((objective, options), protocol=pickle.HIGHEST_PROTOCOL))
            except BaseException:
                self.warm.lock.release()
                raise
            return
        self.counts = self.ctx.Array("i", options.islands, lock=False) if self.ctx else [0] * options.islands
        self.cancel = self.ctx.Event() if self.ctx else _LocalFlag()
        STATE.update(objective=objective, options=options, counts=self.counts,
                     cancel=self.cancel if self.ctx else _ProgressFlag(self.report, self.cancel))
        self.pool = self.ctx.Pool(jobs, initializer=ignore_interrupt) if self.ctx else None

    def report(self) -> None:
        base, span, message = self.phase
        fraction = base + span * min(1.0, sum(self.counts) / self.total)
        if self.progress is not None and self.progress(fraction, message) is False:
            self.cancel.set()

    def map(self, fn, items, phase=None) -> list[RunResult]:
        if phase is not None:
            self.phase = phase
            self.report()
        items = list(items)
        if self.pool is None and self.warm is None:
            out = []
            for item in items:
                out.append(fn(item))
                if self.cancel.is_set():
                    break
        else:
            if self.warm is not None:
                pending = self.warm.pool.map_async(_remote, [(fn, self.key, self.path, i) for i in items], chunksize=1)
            else:
                pending = self.pool.map_async(fn, items, chunksize=1)
            self.pending = pending
            while not pending.ready():
                pending.wait(0.05)
                self.report()
            out = pending.get()
        if self.cancel.is_set() or any(r.cancelled for r in out):
            raise Cancelled()
        return out

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        settled = self.pending is None or self.pending.ready()
        try:
            if not settled:
                # Left mid-phase (Ctrl-C, an error): the tasks stop at their next generation and
                # return before the workers are stopped or handed on; terminate() on a worker
                # writing its result can hang (CPython issue 96995).
                self.cancel.set()
                self.pending.wait(TASKS_STOP_S)
                settled = self.pending.ready()
        finally:
            if self.warm is not None:
                try:
                    os.unlink(self.path)
                except OSError:
                    pass
                self.warm.lock.release()
            else:
                if self.pool is not None:
                    if settled:  # every worker idle: stopped without a signal
                        self.pool.close()
                        self.pool.join()
                    else:
                        self.pool.terminate()
                STATE.clear()
        return False


def near_optimal_set(objective: Objective, workers: Workers, results: list[RunResult], best: RunResult, options):
    """The best fit first, then up to ``near_count − 1`` diverse members of the near-optimal set,
    from the archives and from its extremes. Returns (unit points, evaluations)."""
    modes = n_modes(objective)
    au, af, j_min = _pooled(results, [best])
    pool = af <= j_min + near_band(j_min, options, modes)
    pick = select_diverse(au[pool], af[pool], options.near_candidates)
    cand_u, cand_f = au[pool][pick], af[pool][pick]
    remember(objective, results)
    evaluations = sum(not objective.known(unit_to_p(u)) for u in np.vstack([best.u, cand_u]))
    f_best, s_best = summed_terms(objective, unit_to_p, best.u)
    limits = SetLimits(f_best + modes * options.near_frequency, options.near_shape_factor * s_best + options.near_shape_abs)
    terms = np.array([summed_terms(objective, unit_to_p, u) for u in cand_u])
    ok = (terms[:, 0] <= limits.frequency) & (terms[:, 1] <= limits.shape)
    members, values = np.vstack([best.u, cand_u[ok]]), np.concatenate([[-np.inf], cand_f[ok]])
    if options.extreme_axes:
        # Each push starts from the member already farthest that way: the archives have
        # walked part of the valley, so COBYLA needs far fewer steps to reach its end.
        starts = [(axis, sign, members[np.argmax(sign * members[:, axis])])
                  for axis in options.extreme_axes for sign in (-1.0, 1.0)]
        tasks = [(axis, sign, u, limits, summed_terms(objective, unit_to_p, u)) for axis, sign, u in starts]
        ends = workers.map(extreme_task, tasks, phase=(0.85, 0.0, "measuring the uncertainty"))
        evaluations += sum(e.evaluations for e in ends)
        found = np.vstack([e.archive_u for e in ends])
        members = np.vstack([members, found])
        values = np.concatenate([values, np.full(len(found), np.inf)])
    keep = select_diverse(members, values, options.near_count)  # the best first (value −inf)
    return members[keep], evaluations
