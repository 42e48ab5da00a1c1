"""Identify every tap recording under some folders: the engine behind ``taptune batch``.

No argument parsing here (that is :mod:`taptune.cli.cmd_batch`). The steps:

1. :func:`discover` the WAV/FLAC files (recursively, sorted, so every run sees the same
   order) and :func:`find_assembly` for each (``--assembly``, else the ``.toml`` of the
   same stem beside it, see there);
2. :func:`plan` the work: load each assembly, hash each recording, skip what was already
   identified with the same content (result JSON or library provenance, unless
   ``force``), and group the rest into jobs (one recording each, or one holder each
   for a joint fit);
3. :func:`run_batch` runs every job in its own worker process (at most ``jobs`` at a
   time), so a crash, a hang on ``Ctrl-C`` or a memory blow-up in one recording cannot
   take the batch down; each worker writes the library itself through
   :func:`~taptune.library.record.save_identification` (locked, atomic) and then the
   recording's result JSON;
4. it writes ``summary.csv`` and returns a :class:`BatchResult`.

A bad input (:class:`~taptune.errors.InputError`) marks that file ``failed`` with its
one-line message; any other exception marks it ``error`` with a one-line message, and
its traceback goes to ``errors.log`` in the output folder, never to the user.
"""

from __future__ import annotations

import csv
import io
import json
import multiprocessing as mp
from multiprocessing.connection import wait as wait_any
import os
import signal
import time
import traceback
from collections import deque
from dataclasses import dataclass, replace
from pathlib import Path
from types import SimpleNamespace
from typing import Callable, Sequence

from taptune.errors import InputError

AUDIO_SUFFIXES = (".wav", ".flac")
SUMMARY_NAME = "summary.csv"
ERROR_LOG_NAME = "errors.log"
SUMMARY_HEADER = (
    "file", "holder", "status",
    "f1_measured_hz", "f2_measured_hz", "f3_measured_hz",
    "f1_model_hz", "f2_model_hz", "f3_model_hz",
    "objective", "seconds", "message",
)
# Statuses that make the batch exit 1.
FAILED_STATUSES = ("failed", "error", "cancelled")
_MESSAGE_MAX = 400  # a summary cell and a terminal line stay readable

ProgressCallback = Callable[[float, str], object]


# ----------------------------------------------------------------------------- records


@dataclass(frozen=True)
class Row:
    """One line of ``summary.csv``: what happened to one recording.

    ``status`` is ``ok``, ``skipped`` (identified before with the same content),
    ``failed`` (bad input), ``error`` (unexpected failure) or ``cancelled``.
    Frequencies [Hz] are per bending mode 1–3 (None where not measured or not run).
    """

    file: str
    holder: str
    status: str
    measured_hz: tuple[float | None, ...] = (None, None, None)
    model_hz: tuple[float | None, ...] = (None, None, None)
    objective: float | None = None
    seconds: float | None = None
    message: str = ""

    @property
    def failed(self) -> bool:
        """True if this recording makes the batch exit 1."""
        return self.status in FAILED_STATUSES

    def csv_cells(self) -> list[str]:
        """The row as ``summary.csv`` cells, in :data:`SUMMARY_HEADER` order."""
        return [
            self.file, self.holder, self.status,
            *(_cell(f, 2) for f in _three(self.measured_hz)),
            *(_cell(f, 2) for f in _three(self.model_hz)),
            _cell(self.objective, 6), _cell(self.seconds, 2), self.message,
        ]


def _three(values) -> tuple:
    values = tuple(values)[:3]
    return values + (None,) * (3 - len(values))


def _cell(value, digits: int) -> str:
    return "" if value is None else f"{value:.{digits}f}"


def one_line(err: BaseException | str) -> str:
    """A message on one line of bounded length (exception type named for unexpected errors)."""
    from taptune.errors import TaptuneError

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

    def identify_options(self):
        """IdentifyOptions for one worker: one process each (a pool worker may not fork a pool)."""
        from taptune.identify import GAOptions, IdentifyOptions

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


# ----------------------------------------------------------------------------- discovery


def _is_audio(path: Path) -> bool:
    return path.suffix.lower() in AUDIO_SUFFIXES


def discover(paths: Sequence[str | os.PathLike]) -> tuple[list[Path], list[Row]]:
    """The recordings under ``paths``, and a failed row for each path that does not exist.

    Folders are searched recursively for ``.wav``/``.flac`` (any case); a file named
    explicitly is taken whatever its extension (the reader will say if it is not
    audio). The list is sorted and without duplicates, so runs are reproducible.
    """
    found: dict[Path, Path] = {}
    missing: list[Row] = []
    for arg in paths:
        p = Path(arg)
        if p.is_dir():
            for f in p.rglob("*"):
                if f.is_file() and _is_audio(f):
                    found.setdefault(f.resolve(), f)
        elif p.exists():
            found.setdefault(p.resolve(), p)
        else:
            missing.append(Row(str(p), "", "failed", message=f"{p}: no such file or folder"))
    files = sorted(found.values(), key=lambda f: str(f))
    return files, missing


def find_assembly(recording: Path, assembly: str | os.PathLike | None = None) -> Path | None:
    """The assembly file of ``recording``; None if there is none.

    ``assembly`` if given; else, beside the recording, ``<stem>.toml``, then the stem
    without a ``_tap``/``-tap`` ending (``er32_d16_tap.wav`` → ``er32_d16.toml``, as in
    ``recordings/``), then ``assembly.toml``.
    """
    if assembly is not None:
        return Path(assembly)
    stem = recording.stem
    bare = stem[:-4] if stem.lower().endswith(("_tap", "-tap")) and len(stem) > 4 else stem
    for candidate in (recording.with_suffix(".toml"), recording.with_name(bare + ".toml"),
                      recording.parent / "assembly.toml"):
        if candidate.is_file():
            return candidate
    return None


def result_names(files: Sequence[Path]) -> dict[Path, Path]:
    """Relative result-JSON path of each recording, unique within the batch.

    Recordings keep their folder layout below the common folder of all of them
    (``d01/tap.wav`` → ``d01/tap.json``), so equal names in different folders do not
    collide; two recordings that differ only by extension keep it (``tap.wav.json``).
    """
    if not files:
        return {}
    resolved = [f.resolve() for f in files]
    root = Path(os.path.commonpath([r.parent for r in resolved]))
    rel = [r.relative_to(root) for r in resolved]
    stems = [r.with_suffix("") for r in rel]
    clashes = {s for s in stems if stems.count(s) > 1}
    return {
        f: (r.with_name(r.name + ".json") if s in clashes else s.with_name(s.name + ".json"))
        for f, r, s in zip(files, rel, stems)
    }


# ----------------------------------------------------------------------------- skip by hash


def _read_json(path: Path) -> dict | None:
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None  # missing or half-written: not a previous result
    return data if isinstance(data, dict) else None


def _skip_from_json(item: Item, group_hashes: frozenset[str]) -> Row | None:
    """A skipped row if ``item``'s result JSON holds a result for the same content."""
    data = _read_json(item.json_path)
    if data is None or data.get("sha256") != item.sha256 or data.get("assembly_sha256") != item.assembly_sha256:
        return None
    joint = data.get("joint")
    previous_group = frozenset(joint.get("sha256", ())) if isinstance(joint, dict) else frozenset({item.sha256})
    if previous_group != group_hashes:
        return None
    try:
        measured = _three(data.get("bending_measured_hz") or ())
        model = _three(data.get("bending_model_hz") or ())
        objective = data.get("objective")
    except TypeError:
        return None
    return Row(str(item.path), item.holder, "skipped", measured, model, objective, None,
               f"identified before (same sha256 {item.sha256[:12]}; {item.json_path.name})")


def _skip_from_library(item: Item, entries: dict, group_hashes: frozenset[str]) -> Row | None:
    """A skipped row if the library's provenance holds this recording with this tool and stick-out.

    The recording must have been fitted in the same company: alone for a single fit, with
    exactly the group's recordings for a joint one (the records of one fit share its
    objective value).
    """
    entry = entries.get(item.holder)
    if entry is None:
        return None
    asm = item.assembly
    mine = [
        r for r in entry.identifications
        if r.sha256 == item.sha256 and r.tool_name == asm.tool.name and abs(r.stickout_mm - asm.stickout * 1e3) < 1e-6
    ]
    for record in reversed(mine):
        together = {r.sha256 for r in entry.identifications if r.objective == record.objective}
        if together == group_hashes:
            return Row(str(item.path), item.holder, "skipped", _three(record.bending_measured_hz),
                       _three(record.bending_model_hz),
                       record.objective, None,
                       f"identified before (same sha256 {item.sha256[:12]} in the library, {record.date})")
    return None


# ----------------------------------------------------------------------------- planning


@dataclass(frozen=True)
class Plan:
    """The jobs to run (each a tuple of items: one recording, or one holder's group) and the rows already decided."""

    jobs: tuple[tuple[Item, ...], ...]
    decided: tuple[Row, ...]
    notes: tuple[str, ...] = ()


def _prepare(files: Sequence[Path], assembly: str | None, out_dir: Path) -> tuple[list[Item], list[Row]]:
    """Load each recording's assembly and hash both files; rows for those that cannot run."""
    from taptune.io.assembly import load_assembly
    from taptune.library.schema import sha256_file

    names = result_names(files)
    loaded: dict[Path, tuple] = {}  # one load per assembly file, one message per problem
    items: list[Item] = []
    rows: list[Row] = []
    for f in files:
        asm_path = find_assembly(f, assembly)
        if asm_path is None:
            rows.append(Row(str(f), "", "failed", message=(
                f"{f}: no assembly (give --assembly, or put {f.with_suffix('.toml').name} beside it)")))
            continue
        key = asm_path.resolve()
        if key not in loaded:
            try:
                loaded[key] = (load_assembly(asm_path), sha256_file(asm_path), "")
            except InputError as err:
                loaded[key] = (None, "", one_line(err))
            except OSError as err:
                loaded[key] = (None, "", one_line(f"{asm_path}: cannot read ({err.strerror})"))
        asm, asm_sha, problem = loaded[key]
        if asm is None:
            rows.append(Row(str(f), "", "failed", message=problem))
            continue
        try:
            sha = sha256_file(f)
        except OSError as err:
            rows.append(Row(str(f), asm.holder.name, "failed", message=f"{f}: cannot read ({err.strerror})"))
            continue
        items.append(Item(f, out_dir / names[f], asm_path, asm, sha, asm_sha))
    return items, rows


def _group(items: Sequence[Item], joint: bool) -> list[tuple[Item, ...]]:
    """One job per recording, or (joint) one per holder name in order of first appearance."""
    if not joint:
        return [(i,) for i in items]
    groups: dict[str, list[Item]] = {}
    for item in items:
        groups.setdefault(item.holder, []).append(item)
    return [tuple(g) for g in groups.values()]


def _library_entries(options: BatchOptions) -> dict:
    """The library's holders (empty if there is none yet); a broken library stops the batch up front."""
    from taptune.library.store import HolderLibrary, default_library_path

    return HolderLibrary(default_library_path(options.library)).entries()


def plan(paths: Sequence[str | os.PathLike], options: BatchOptions, assembly: str | None = None) -> Plan:
    """Discover, pair, hash and group the recordings; decide what is skipped or cannot run.

    Raises
    ------
    InputError
        No recording found at all, an ``assembly`` file that cannot be used, or a
        library file that does not validate.
    """
    if assembly is not None:
        from taptune.io.assembly import load_assembly

        load_assembly(assembly)  # a bad --assembly concerns every file: bad input up front, exit 2
    files, rows = discover(paths)
    if not files and not rows:
        raise InputError(f"no .wav or .flac recording under {', '.join(map(str, paths))}")
    items, bad = _prepare(files, assembly, Path(options.out_dir))
    rows += bad
    entries = _library_entries(options) if options.save and not options.force else {}
    jobs = []
    for group in _group(items, options.joint):
        hashes = frozenset(i.sha256 for i in group)
        skipped = [] if options.force else [
            _skip_from_json(i, hashes) or (_skip_from_library(i, entries, hashes) if entries else None) for i in group
        ]
        if skipped and all(skipped):
            rows += skipped
        else:
            jobs.append(group)
    return Plan(tuple(jobs), tuple(rows), _notes(jobs, options))


def _notes(jobs, options: BatchOptions) -> tuple[str, ...]:
    """Warn where separate fits of one holder overwrite each other in the library."""
    if options.joint or not options.save:
        return ()
    counts: dict[str, int] = {}
    for group in jobs:
        counts[group[0].holder] = counts.get(group[0].holder, 0) + 1
    return tuple(
        f"{n} recordings of holder '{name}' are identified separately; the library keeps the one that "
        "finishes last (use --joint to fit them together)"
        for name, n in counts.items() if n > 1
    )


# ----------------------------------------------------------------------------- one job (in a worker)


def _rows_for(items, status: str, message: str, seconds: float | None = None) -> list[Row]:
    return [Row(str(i.path), i.holder, status, seconds=seconds, message=message) for i in items]


def _log_error(out_dir: Path, items, err: BaseException) -> None:
    """Append the traceback to errors.log (one write, so parallel workers do not interleave)."""
    text = (
        f"--- {time.strftime('%Y-%m-%dT%H:%M:%S')} {', '.join(str(i.path) for i in items)}\n"
        + "".join(traceback.format_exception(err))
    )
    try:
        out_dir.mkdir(parents=True, exist_ok=True)
        fd = os.open(out_dir / ERROR_LOG_NAME, os.O_WRONLY | os.O_CREAT | os.O_APPEND, 0o666)
        try:
            os.write(fd, text.encode("utf-8", "replace"))
        finally:
            os.close(fd)
    except OSError:
        pass  # the row already carries the message; the log is a debugging aid only


def _analyse(items, id_options, out_dir: Path):
    """Read and analyse each recording on its own, so one bad file does not sink its group."""
    from taptune.identify.pipeline import analyse_for_assembly
    from taptune.io.audio import read_audio

    good, rows = [], []
    for item in items:
        try:
            recording = read_audio(item.path)
            good.append((item, recording, analyse_for_assembly(recording, item.assembly, None, id_options.model)))
        except InputError as err:
            rows.append(Row(str(item.path), item.holder, "failed", message=one_line(err)))
        except Exception as err:  # noqa: BLE001 - one recording's surprise must not stop the batch
            _log_error(out_dir, [item], err)
            rows.append(Row(str(item.path), item.holder, "error", message=one_line(err)))
    return good, rows


def _result_json(view, item: Item, recording, analysis, group_items, joint_objective: float) -> dict:
    """The identify --json document of one recording, plus what the next batch needs to skip it."""
    from taptune.identify.pipeline import identification_record

    data = identification_record([recording], [item.assembly], [analysis], view)
    data["sha256"] = item.sha256
    data["assembly"] = str(item.assembly_path)
    data["assembly_sha256"] = item.assembly_sha256
    if len(group_items) > 1:
        data["joint"] = {
            "files": [str(i.path) for i in group_items],
            "sha256": [i.sha256 for i in group_items],
            "objective": round(joint_objective, 6),
        }
    return data


def run_job(items: Sequence[Item], options: BatchOptions, progress: ProgressCallback | None = None) -> Outcome:
    """Identify one recording, or one holder's recordings jointly; store and write the results.

    Never raises for a bad recording: every item gets a row. The library is written
    before the result JSON, so a JSON on disk always means the library has the holder.
    """
    from taptune.cli.common import write_json
    from taptune.identify import identify
    from taptune.report.pdf import recording_view

    t0 = time.perf_counter()
    out_dir = Path(options.out_dir)
    id_options = options.identify_options()
    good, rows = _analyse(items, id_options, out_dir)
    if not good:
        return Outcome(tuple(rows))
    group = [g[0] for g in good]
    recordings = [g[1] for g in good]
    analyses = [g[2] for g in good]
    assemblies = [i.assembly for i in group]
    try:
        result = identify(analyses, assemblies, id_options, progress=progress)
        if options.save:
            from taptune.library.record import save_identification

            save_identification(options.library, result, recordings, assemblies)
        seconds = time.perf_counter() - t0
        done = []  # rows join the outcome only when every file of the job is written
        for k, item in enumerate(group):
            view = recording_view(result, k)
            data = _result_json(view, item, recordings[k], analyses[k], group, result.objective)
            write_json(data, str(item.json_path))
            done.append(Row(str(item.path), item.holder, "ok", _three(view.bending_measured_hz[0]),
                            _three(view.bending_model_hz[0]), view.objective, seconds, _warning_note(data)))
    except InputError as err:
        return Outcome(tuple(rows + _rows_for(group, "failed", one_line(err), time.perf_counter() - t0)))
    except Exception as err:  # noqa: BLE001 - reported as status "error", traceback to errors.log
        _log_error(out_dir, group, err)
        return Outcome(tuple(rows + _rows_for(group, "error", one_line(err), time.perf_counter() - t0)))
    pages = _pages(result, analyses, recordings, assemblies, id_options.model, out_dir) if options.keep_pages else ()
    return Outcome(tuple(rows + done), pages)


def _pages(result, analyses, recordings, assemblies, model_options, out_dir: Path) -> tuple:
    """Report pages of a finished identification; none (and a log entry) if they cannot be made.

    The identification itself is stored and written by then: a report problem must not
    turn it into a failure.
    """
    from taptune.report.pdf import report_pages

    try:
        return tuple(report_pages(result, [_slim(a) for a in analyses], recordings, assemblies, model_options))
    except Exception as err:  # noqa: BLE001 - logged; the summary page still lists the recording
        _log_error(out_dir, [SimpleNamespace(path=r.path) for r in recordings], err)
        return ()


def _warning_note(data: dict) -> str:
    n = len(data.get("warnings", ()))
    return "" if n == 0 else f"{n} warning{'s' if n > 1 else ''}: {one_line(data['warnings'][0])}"


def _slim(analysis):
    """The analysis without per-tap spectra (the report does not draw them; the pickle shrinks)."""
    from dataclasses import is_dataclass

    if is_dataclass(analysis) and hasattr(analysis, "tap_magnitudes"):
        return replace(analysis, tap_magnitudes=analysis.tap_magnitudes[:0], noise_magnitude=None)
    return analysis


# ----------------------------------------------------------------------------- worker processes


def _worker_main(items, options: BatchOptions, conn) -> None:
    """Body of a worker process: run one job and send ("progress", f)… then ("done", Outcome)."""
    # Ctrl-C reaches the whole process group; the parent decides and terminates workers.
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    last = [-1.0]

    def progress(fraction, message=""):
        if fraction - last[0] >= 0.02:
            last[0] = fraction
            conn.send(("progress", float(fraction)))

    try:
        outcome = run_job(items, options, progress)
    except BaseException as err:  # noqa: BLE001 - even a bug in run_job becomes a row
        _log_error(Path(options.out_dir), items, err)
        outcome = Outcome(tuple(_rows_for(items, "error", one_line(err))))
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
    return Outcome(tuple(_rows_for(run.items, "error", f"the worker process ended without a result ({how})")))


def _timed_out(run: _Running, timeout_s: float) -> Outcome:
    message = f"stopped after {timeout_s:g} s (--timeout); the identification did not finish"
    return Outcome(tuple(_rows_for(run.items, "error", message, time.monotonic() - run.started)))


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


# ----------------------------------------------------------------------------- the batch


def write_summary(path: Path, rows: Sequence[Row]) -> None:
    """Write ``summary.csv`` (header :data:`SUMMARY_HEADER`) atomically."""
    from taptune.io.atomic import atomic_write_bytes

    buffer = io.StringIO()
    writer = csv.writer(buffer, lineterminator="\n")
    writer.writerow(SUMMARY_HEADER)
    writer.writerows(r.csv_cells() for r in rows)
    try:
        atomic_write_bytes(path, buffer.getvalue().encode("utf-8"))
    except OSError as err:
        raise InputError(f"{path}: cannot write the summary ({err.strerror})") from None


def read_summary(path: str | os.PathLike) -> list[dict[str, str]]:
    """The rows of a ``summary.csv`` as dicts keyed by :data:`SUMMARY_HEADER`."""
    with open(path, newline="", encoding="utf-8") as f:
        return list(csv.DictReader(f))


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
        Files and folders (searched recursively for WAV/FLAC).
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
