"""What a batch leaves on disk: one result JSON per recording, ``summary.csv``, ``errors.log``.

The result JSON is ``taptune identify --json``'s document plus the hashes the next batch
needs to skip the recording; ``summary.csv`` and the JSONs are written atomically;
``errors.log`` collects the tracebacks the user never sees on the terminal.
"""

from __future__ import annotations

import csv
import io
import os
import time
import traceback
from pathlib import Path
from typing import Sequence

from taptune.batch.records import ERROR_LOG_NAME, SUMMARY_HEADER, Item, Row
from taptune.errors import InputError
from taptune.identify.pipeline import identification_record
from taptune.io.atomic import atomic_write_bytes


def result_json(view, item: Item, recording, analysis, group_items, joint_objective: float) -> dict:
    """The identify --json document of one recording, plus what the next batch needs to skip it."""
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


def write_summary(path: Path, rows: Sequence[Row]) -> None:
    """Write ``summary.csv`` (header :data:`SUMMARY_HEADER`) atomically."""
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


def log_error(out_dir: Path, items, err: BaseException) -> None:
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
