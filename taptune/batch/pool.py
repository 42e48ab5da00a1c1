"""The worker pool: each job in its own process, at most ``jobs`` at a time.

A crash, a hang or a memory blow-up in one recording cannot take the batch down: a worker
that dies or runs past the timeout becomes "error" rows, and ``Ctrl-C`` terminates the
running workers. Workers are forked where the platform allows (they start in
milliseconds with everything imported) and report progress and their
:class:`~taptune.batch.records.Outcome` through a pipe.
"""

from __future__ import annotations

import multiprocessing as mp
import time
from collections import deque
from dataclasses import dataclass
from multiprocessing.connection import wait as wait_any
from pathlib import Path
from typing import Callable

from taptune.batch.job import run_job
from taptune.batch.outputs import log_error
from taptune.batch.records import BatchOptions, Outcome, one_line, rows_for
from taptune.workers import ignore_interrupt


def _worker_main(items, options: BatchOptions, conn) -> None:
    """Body of a worker process: run one job and send ("progress", f)… then ("done", Outcome)."""
    ignore_interrupt()  # the parent decides and terminates workers
    last = [-1.0]

    def progress(fraction, message=""):
        if fraction - last[0] >= 0.02:
            last[0] = fraction
            conn.send(("progress", float(fraction)))

    try:
        outcome = run_job(items, options, progress)
    except BaseException as err:  # noqa: BLE001 - even a bug in run_job becomes a row
        log_error(Path(options.out_dir), items, err)
        outcome = Outcome(tuple(rows_for(items, "error", one_line(err))))
    try:
        conn.send(("done", outcome))
    except Exception:  # noqa: BLE001 - e.g. report pages that do not pickle: keep the rows
        conn.send(("done", Outcome(outcome.rows)))
    conn.close()


def _context():
    # fork: workers start in milliseconds with everything imported; elsewhere spawn works too.
    return mp.get_context("fork" if "fork" in mp.get_all_start_methods() else "spawn")


@dataclass
class _Running:
    process: object
    items: tuple
    started: float
    fraction: float = 0.0


def _died(run: _Running) -> Outcome:
    code = run.process.exitcode
    how = f"killed by signal {-code}" if code is not None and code < 0 else f"exit code {code}"
    return Outcome(tuple(rows_for(run.items, "error", f"the worker process ended without a result ({how})")))


def _timed_out(run: _Running, timeout_s: float) -> Outcome:
    message = f"stopped after {timeout_s:g} s (--timeout); the identification did not finish"
    return Outcome(tuple(rows_for(run.items, "error", message, time.monotonic() - run.started)))


def run_jobs(jobs, options: BatchOptions, on_outcome: Callable[[Outcome], None],
             progress: Callable[[float], None] | None = None) -> bool:
    """Run each job in its own process, at most ``options.worker_count`` at once.

    ``on_outcome`` gets each job's :class:`Outcome` as it finishes (a worker that dies,
    or runs longer than ``options.timeout_s``, gives "error" rows). Returns False if interrupted by ``KeyboardInterrupt`` (running
    workers are terminated; jobs not finished get no outcome).
    """
    ctx = _context()
    pending = deque(jobs)
    running: dict = {}  # receiving connection -> _Running
    n_workers = options.worker_count(len(pending))
    finished = 0
    try:
        while pending or running:
            while pending and len(running) < n_workers:
                items = pending.popleft()
                receive, send = ctx.Pipe(duplex=False)
                process = ctx.Process(target=_worker_main, args=(items, options, send), daemon=True)
                process.start()
                send.close()  # our copy: EOF on `receive` then means the worker is gone
                running[receive] = _Running(process, items, time.monotonic())
            for conn in wait_any(list(running), timeout=0.5):
                run = running[conn]
                try:
                    kind, payload = conn.recv()
                except (EOFError, OSError):
                    kind, payload = "done", None
                if kind == "progress":
                    run.fraction = payload
                    continue
                del running[conn]
                conn.close()
                run.process.join()
                finished += 1
                on_outcome(payload if payload is not None else _died(run))
            if options.timeout_s is not None:
                for conn, run in list(running.items()):
                    if time.monotonic() - run.started > options.timeout_s:
                        run.process.terminate()
                        run.process.join()
                        del running[conn]
                        conn.close()
                        finished += 1
                        on_outcome(_timed_out(run, options.timeout_s))
            if progress is not None:
                total = finished + len(running) + len(pending)
                progress((finished + sum(r.fraction for r in running.values())) / max(total, 1))
    except KeyboardInterrupt:
        for run in running.values():
            run.process.terminate()
        for run in running.values():
            run.process.join()
        return False
    return True
