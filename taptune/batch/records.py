"""What the parts of a batch pass to each other: options, recordings, rows, outcomes.

A :class:`Row` is one line of ``summary.csv``; an :class:`Item` one discovered recording;
an :class:`Outcome` what a worker sends back; a :class:`BatchResult` the finished batch.
"""

from __future__ import annotations

import os
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Callable

from taptune.errors import TaptuneError
from taptune.identify import GAOptions, IdentifyOptions
# The one list of what read_audio reads (WAV, FLAC, MP3, Ogg, Opus, M4A/AAC …), so a
# folder of phone memos is batched like a folder of WAVs.
from taptune.io.audio import AUDIO_SUFFIXES

SUMMARY_NAME = "summary.csv"
ERROR_LOG_NAME = "errors.log"
SUMMARY_HEADER = (
    "file", "holder", "status",
    "f1_measured_hz", "f2_measured_hz", "f3_measured_hz",
    "f1_model_hz", "f2_model_hz", "f3_model_hz",
    "objective", "seconds",
    "a_crit_mm", "best_pocket_rpm", "best_pocket_a_lim_mm",  # with --machine; empty otherwise
    "message",
)
# Statuses that make the batch exit 1.
FAILED_STATUSES = ("failed", "error", "cancelled")
_MESSAGE_MAX = 400  # a summary cell and a terminal line stay readable

ProgressCallback = Callable[[float, str], object]


@dataclass(frozen=True)
class Row:
    """One line of ``summary.csv``: what happened to one recording.

    ``status`` is ``ok``, ``skipped`` (identified before with the same content),
    ``failed`` (bad input), ``error`` (unexpected failure) or ``cancelled``.
    Frequencies [Hz] are per bending mode 1–3 (None where not measured or not run).
    With ``--machine``: the critical depth of cut and the best pocket (speed [rpm], depth
    [mm]) of the lobes on the machine; None without it or when the machine part failed
    (``message`` says why).
    """

    file: str
    holder: str
    status: str
    measured_hz: tuple[float | None, ...] = (None, None, None)
    model_hz: tuple[float | None, ...] = (None, None, None)
    objective: float | None = None
    seconds: float | None = None
    message: str = ""
    a_crit_mm: float | None = None
    best_pocket_rpm: float | None = None
    best_pocket_a_lim_mm: float | None = None

    @property
    def failed(self) -> bool:
        """True if this recording makes the batch exit 1."""
        return self.status in FAILED_STATUSES

    def csv_cells(self) -> list[str]:
        """The row as ``summary.csv`` cells, in :data:`SUMMARY_HEADER` order."""
        return [
            self.file, self.holder, self.status,
            *(_cell(f, 2) for f in first_three(self.measured_hz)),
            *(_cell(f, 2) for f in first_three(self.model_hz)),
            _cell(self.objective, 6), _cell(self.seconds, 2),
            _cell(self.a_crit_mm, 4), _cell(self.best_pocket_rpm, 0), _cell(self.best_pocket_a_lim_mm, 4),
            self.message,
        ]


def first_three(values) -> tuple:
    """``values`` cut or padded with None to three (bending modes 1–3)."""
    values = tuple(values)[:3]
    return values + (None,) * (3 - len(values))


def _cell(value, digits: int) -> str:
    return "" if value is None else f"{value:.{digits}f}"


def one_line(err: BaseException | str) -> str:
    """A message on one line of bounded length (exception type named for unexpected errors)."""
    text = err if isinstance(err, str) else (
        str(err) if isinstance(err, TaptuneError) else f"{type(err).__name__}: {err}"
    )
    text = " ".join(text.split())
    return text if len(text) <= _MESSAGE_MAX else text[: _MESSAGE_MAX - 1] + "…"


@dataclass(frozen=True)
class Item:
    """One discovered recording, ready to run or already decided.

    ``assembly`` is the loaded :class:`~taptune.io.assembly.Assembly` (None when the
    file cannot run); ``sha256`` the hex hash of the recording's bytes; ``json_path``
    where its result JSON goes; ``assembly_sha256`` the hash of the assembly file (a
    changed assembly means a new identification).
    """

    path: Path
    json_path: Path
    assembly_path: Path | None = None
    assembly: object | None = None
    sha256: str = ""
    assembly_sha256: str = ""

    @property
    def holder(self) -> str:
        return self.assembly.holder.name if self.assembly is not None else ""


@dataclass(frozen=True)
class MachineSetup:
    """``--machine`` and the cut: what each job computes after its identification.

    ``machine`` is the loaded :class:`~taptune.io.machine.Machine`, ``freq_hz`` the
    tool-point FRF grid [Hz] inside its spindle files' band, ``cut`` a
    :class:`~taptune.cli.cut.CutOptions` (``diameter_mm`` None: each tool's own),
    ``contact`` the tool–holder joint of the model.
    """

    machine: object
    freq_hz: object
    cut: object
    contact: str = "distributed"
    path: str = ""


@dataclass(frozen=True)
class BatchOptions:
    """How to run a batch. ``jobs`` only changes the speed, never a result."""

    out_dir: Path = Path("taptune-batch")
    library: str | None = None  # None: $TAPTUNE_LIBRARY or the user data folder
    jobs: int | None = None  # worker processes; None = all cores
    seed: int = 0
    force: bool = False  # redo recordings identified before with the same content
    joint: bool = False  # one joint fit per holder instead of one fit per recording
    save: bool = True  # store the holders in the library
    population: int | None = None  # optimiser budget overrides (tests, quick looks)
    generations: int | None = None
    polish_evaluations: int | None = None
    keep_pages: bool = False  # return what a PDF report needs (BatchResult.pages)
    timeout_s: float | None = None  # a job running longer is stopped and marked "error"
    machine: MachineSetup | None = None  # tool-point FRF and lobes of each identified holder

    def identify_options(self):
        """IdentifyOptions for one worker: one process each (a pool worker may not fork a pool)."""
        ga = GAOptions()
        if self.population is not None:
            ga = replace(ga, population=self.population)
        if self.generations is not None:
            ga = replace(ga, generations=self.generations)
        options = IdentifyOptions(seed=self.seed, jobs=1, ga=ga)
        if self.polish_evaluations is not None:
            options = replace(options, polish_evaluations=self.polish_evaluations)
        return options

    def worker_count(self, n_jobs: int) -> int:
        """Processes to start for ``n_jobs`` jobs."""
        wanted = self.jobs or os.cpu_count() or 1
        return max(1, min(wanted, n_jobs))


@dataclass(frozen=True)
class Outcome:
    """What a worker sends back for one job: the rows and, if asked, report pages."""

    rows: tuple[Row, ...]
    pages: tuple = ()


@dataclass(frozen=True)
class BatchResult:
    """The rows of a finished batch (sorted by file), report pages and notes for the user."""

    rows: tuple[Row, ...]
    summary_path: Path
    pages: tuple = ()
    notes: tuple[str, ...] = ()
    cancelled: bool = False

    @property
    def failed(self) -> tuple[Row, ...]:
        """Rows that make the batch exit 1."""
        return tuple(r for r in self.rows if r.failed)

    def count(self, status: str) -> int:
        return sum(r.status == status for r in self.rows)

    @property
    def exit_status(self) -> int:
        """0 if every recording was identified or skipped, else 1 (130 when cancelled)."""
        if self.cancelled:
            return 130
        return 1 if self.failed else 0


def rows_for(items, status: str, message: str, seconds: float | None = None) -> list[Row]:
    """The same status and message for every item of a job."""
    return [Row(str(i.path), i.holder, status, seconds=seconds, message=message) for i in items]
