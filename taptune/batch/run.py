"""The batch from start to end: plan, run the jobs in the pool, write ``summary.csv``."""

from __future__ import annotations

import os
from pathlib import Path
from typing import Callable, Sequence

from taptune.batch.outputs import write_summary
from taptune.batch.planning import plan
from taptune.batch.pool import run_jobs
from taptune.batch.records import SUMMARY_NAME, BatchOptions, BatchResult, Outcome, ProgressCallback, Row
from taptune.errors import InputError


def run_batch(
    paths: Sequence[str | os.PathLike],
    options: BatchOptions,
    assembly: str | None = None,
    progress: ProgressCallback | None = None,
    on_row: Callable[[Row], None] | None = None,
) -> BatchResult:
    """Identify every recording under ``paths``; write result JSONs and ``summary.csv``.

    Parameters
    ----------
    paths : sequence of path-like
        Files and folders (searched recursively for audio (WAV, FLAC, MP3, Ogg, M4A …)).
    options : BatchOptions
    assembly : path-like, optional
        One assembly file for every recording (else each finds its own, see :func:`find_assembly`).
    progress : callable, optional
        ``progress(fraction, message)`` while the batch runs.
    on_row : callable, optional
        Called with each :class:`Row` as soon as it is known (skipped and failed first).

    Returns
    -------
    BatchResult
        Rows sorted by file. ``summary.csv`` is in ``options.out_dir``.

    Raises
    ------
    InputError
        Nothing to do (no recording at all), an output folder that cannot be created,
        or a library file that does not validate.
    """
    out_dir = Path(options.out_dir)
    if out_dir.exists() and not out_dir.is_dir():
        raise InputError(f"{out_dir}: is a file, not a folder; --out needs a folder for the results")
    try:
        out_dir.mkdir(parents=True, exist_ok=True)
    except OSError as err:
        raise InputError(f"{out_dir}: cannot create the output folder ({err.strerror})") from None
    the_plan = plan(paths, options, assembly)
    rows: list[Row] = list(the_plan.decided)
    pages: list = []
    total = len(rows) + sum(len(j) for j in the_plan.jobs)
    for row in rows:
        if on_row is not None:
            on_row(row)

    def collect(outcome: Outcome) -> None:
        rows.extend(outcome.rows)
        pages.extend(outcome.pages)
        if on_row is not None:
            for row in outcome.rows:
                on_row(row)

    def show(fraction: float) -> None:
        if progress is not None:
            bad = sum(r.failed for r in rows)
            progress(fraction, f"{len(rows)}/{total} files" + (f", {bad} failed" if bad else ""))

    completed = run_jobs(the_plan.jobs, options, collect, show) if the_plan.jobs else True
    if not completed:
        done = {r.file for r in rows}
        rows += [Row(str(i.path), i.holder, "cancelled", message="interrupted before it finished")
                 for job in the_plan.jobs for i in job if str(i.path) not in done]
    rows.sort(key=lambda r: r.file)
    pages.sort(key=lambda p: p.file)
    summary = out_dir / SUMMARY_NAME
    write_summary(summary, rows)
    return BatchResult(tuple(rows), summary, tuple(pages), the_plan.notes, cancelled=not completed)
