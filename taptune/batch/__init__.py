"""Identify every tap recording under some folders: the engine behind ``taptune batch``.

No argument parsing here (that is :mod:`taptune.cli.cmd_batch`). The parts, in the order
a batch runs them:

1. :mod:`~taptune.batch.planning` — :func:`discover` the audio (WAV, FLAC, MP3, Ogg, M4A …) files, :func:`find_assembly`
   for each, and :func:`plan` the work (hash, skip what was identified before with the
   same content, group into jobs);
2. :mod:`~taptune.batch.pool` — :func:`run_jobs` runs every job in its own worker process;
3. :mod:`~taptune.batch.job` — :func:`run_job`, in the worker: analyse, identify, store
   the holder in the library (locked, atomic), then write the recording's result JSON;
4. :mod:`~taptune.batch.outputs` — the result JSONs, ``summary.csv`` and ``errors.log``;
5. :mod:`~taptune.batch.run` — :func:`run_batch` strings them together and returns a
   :class:`BatchResult`. :mod:`~taptune.batch.records` holds the types they pass on.

A bad input (:class:`~taptune.errors.InputError`) marks that file ``failed`` with its
one-line message; any other exception marks it ``error`` with a one-line message, and
its traceback goes to ``errors.log`` in the output folder, never to the user.
"""

from taptune.batch.job import run_job
from taptune.batch.outputs import read_summary, write_summary
from taptune.batch.planning import Plan, discover, find_assembly, plan, result_names
from taptune.batch.pool import run_jobs
from taptune.batch.records import (
    AUDIO_SUFFIXES,
    ERROR_LOG_NAME,
    FAILED_STATUSES,
    SUMMARY_HEADER,
    SUMMARY_NAME,
    BatchOptions,
    BatchResult,
    Item,
    Outcome,
    ProgressCallback,
    Row,
    one_line,
)
from taptune.batch.run import run_batch

__all__ = [
    "AUDIO_SUFFIXES",
    "ERROR_LOG_NAME",
    "FAILED_STATUSES",
    "SUMMARY_HEADER",
    "SUMMARY_NAME",
    "BatchOptions",
    "BatchResult",
    "Item",
    "Outcome",
    "Plan",
    "ProgressCallback",
    "Row",
    "discover",
    "find_assembly",
    "one_line",
    "plan",
    "read_summary",
    "result_names",
    "run_batch",
    "run_job",
    "run_jobs",
    "write_summary",
]
