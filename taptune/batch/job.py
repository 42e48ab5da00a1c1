"""One job, in a worker process: analyse, identify, store in the library, (with ``--machine``)
the holder on the spindle, write the result JSONs.

A bad recording never raises out of :func:`run_job`: every item gets a row, and an
unexpected exception's traceback goes to ``errors.log``.
"""

from __future__ import annotations

import time
from dataclasses import is_dataclass, replace
from pathlib import Path
from types import SimpleNamespace
from typing import Sequence

from taptune.batch.on_machine import MACHINE_FAILED, MachinePart, failed_part, machine_part
from taptune.batch.outputs import log_error, result_json
from taptune.batch.records import BatchOptions, Item, Outcome, ProgressCallback, Row, first_three, one_line, rows_for
from taptune.cli.common import write_json
from taptune.errors import InputError
from taptune.identify import identify
from taptune.identify.pipeline import analyse_for_assembly, check_distinct
from taptune.io.audio import read_audio
from taptune.library.record import poor_fit, save_identification
from taptune.report.pdf import recording_view, report_pages


def _analyse(items, id_options, out_dir: Path):
    """Read and analyse each recording on its own, so one bad file does not sink its group."""
    good, rows = [], []
    for item in items:
        try:
            recording = read_audio(item.path)
            good.append((item, recording, analyse_for_assembly(recording, item.assembly, None, id_options.model)))
        except InputError as err:
            rows.append(Row(str(item.path), item.holder, "failed", message=one_line(err)))
        except Exception as err:  # noqa: BLE001 - one recording's surprise must not stop the batch
            log_error(out_dir, [item], err)
            rows.append(Row(str(item.path), item.holder, "error", message=one_line(err)))
    return good, rows


def run_job(items: Sequence[Item], options: BatchOptions, progress: ProgressCallback | None = None) -> Outcome:
    """Identify one recording, or one holder's recordings jointly; store and write the results.

    Never raises for a bad recording: every item gets a row. The library is written
    before the result JSON, so a JSON on disk always means the library has the holder.
    """
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
        check_distinct(recordings)
        result = identify(analyses, assemblies, id_options, progress=progress)
        if options.save and (reason := poor_fit(result, recordings, assemblies)):
            # Not stored, and no result JSON (a JSON on disk means the library has it, and
            # the next batch would skip the file): the row keeps what the fit found.
            seconds = time.perf_counter() - t0
            return Outcome(tuple(rows + [
                Row(str(item.path), item.holder, "failed", first_three(view.bending_measured_hz[0]),
                    first_three(view.bending_model_hz[0]), view.objective, seconds, one_line(reason))
                for item, view in ((item, recording_view(result, k)) for k, item in enumerate(group))]))
        if options.save:
            save_identification(options.library, result, recordings, assemblies)
        seconds = time.perf_counter() - t0
        done = []  # rows join the outcome only when every file of the job is written
        parts = []
        for k, item in enumerate(group):
            view = recording_view(result, k)
            data = result_json(view, item, recordings[k], analyses[k], group, result.objective)
            part = _machine(result.params, id_options.model, item, options)
            if part is not None:
                data["machine"] = part.record
            write_json(data, str(item.json_path))
            done.append(_ok_row(item, view, seconds, data, part))
            parts.append(part)
    except InputError as err:
        return Outcome(tuple(rows + rows_for(group, "failed", one_line(err), time.perf_counter() - t0)))
    except Exception as err:  # noqa: BLE001 - reported as status "error", traceback to errors.log
        log_error(out_dir, group, err)
        return Outcome(tuple(rows + rows_for(group, "error", one_line(err), time.perf_counter() - t0)))
    pages = _pages(result, analyses, recordings, group, id_options.model, out_dir) if options.keep_pages else ()
    if pages and options.machine is not None:
        pages = tuple(replace(page, machine=part.view) for page, part in zip(pages, parts))
    return Outcome(tuple(rows + done), pages)


def _machine(params, model_options, item: Item, options: BatchOptions) -> MachinePart | None:
    """The recording's machine part (None without --machine); a surprise fails only this part."""
    setup = options.machine
    if setup is None:
        return None
    try:
        return machine_part(params, model_options, item.assembly, setup, item.json_path)
    except Exception as err:  # noqa: BLE001 - the identification is done: keep it, log the traceback
        log_error(Path(options.out_dir), [item], err)
        return failed_part({"machine": setup.machine.name, "file": setup.path, "contact": setup.contact},
                           f"On {setup.machine.name}", one_line(err))


def _ok_row(item: Item, view, seconds: float, data: dict, part: MachinePart | None) -> Row:
    """The summary row of an identified recording, with the machine part's numbers or why they are missing."""
    note = _warning_note(data, item.json_path)
    if part is not None and part.error:
        note = "; ".join(filter(None, [f"{MACHINE_FAILED} {part.error}", note]))
    best = part.best_pocket if part is not None and part.best_pocket else (None, None)
    return Row(str(item.path), item.holder, "ok", first_three(view.bending_measured_hz[0]),
               first_three(view.bending_model_hz[0]), view.objective, seconds, note,
               a_crit_mm=part.a_crit_mm if part is not None else None,
               best_pocket_rpm=best[0], best_pocket_a_lim_mm=best[1])


def _pages(result, analyses, recordings, items: Sequence[Item], model_options, out_dir: Path) -> tuple:
    """Report pages of a finished identification; none (and a log entry) if they cannot be made.

    The recordings' hashes come from planning (each file is hashed once per batch).

    The identification itself is stored and written by then: a report problem must not
    turn it into a failure.
    """
    try:
        return tuple(report_pages(result, [_slim(a) for a in analyses], recordings, [i.assembly for i in items],
                                  model_options, sha256s=[i.sha256 for i in items]))
    except Exception as err:  # noqa: BLE001 - logged; the summary page still lists the recording
        log_error(out_dir, [SimpleNamespace(path=r.path) for r in recordings], err)
        return ()


def _warning_note(data: dict, json_path) -> str:
    """The first warning, and how many more the result JSON holds (a line, not a report)."""
    warnings = data.get("warnings", ())
    if not warnings:
        return ""
    more = f" (and {len(warnings) - 1} more in {Path(json_path).name})" if len(warnings) > 1 else ""
    return f"{len(warnings)} warning{'s' if len(warnings) > 1 else ''}: {one_line(warnings[0])}{more}"


def _slim(analysis):
    """The analysis without per-tap spectra (the report does not draw them; the pickle shrinks)."""
    if is_dataclass(analysis) and hasattr(analysis, "tap_magnitudes"):
        return replace(analysis, tap_magnitudes=analysis.tap_magnitudes[:0], noise_magnitude=None)
    return analysis
