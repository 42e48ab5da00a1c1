"""Small helpers the command modules share: JSON output, progress display, file lists."""

from __future__ import annotations

import json
import math
import sys
from pathlib import Path

from taptune.errors import InputError
from taptune.io.atomic import atomic_write_bytes


def write_json(data: dict, out: str | None) -> None:
    """Write JSON to ``out`` (``-`` = stdout). Unwritable path → InputError."""
    if out is None:
        return
    text = json.dumps(data, indent=2, ensure_ascii=False, allow_nan=False, default=_jsonable) + "\n"
    if out == "-":
        sys.stdout.write(text)
        return
    try:
        atomic_write_bytes(out, text.encode("utf-8"))
    except OSError as err:
        raise InputError(f"{out}: cannot write ({err.strerror})") from None


def _jsonable(value):
    if hasattr(value, "tolist"):
        return value.tolist()
    if isinstance(value, float) and not math.isfinite(value):
        return None
    raise TypeError(f"not JSON serialisable: {type(value).__name__}")


class ProgressBar:
    """A one-line progress display on stderr when it is a terminal; silent otherwise."""

    def __init__(self, label: str, stream=None, width: int = 30):
        self.stream = stream or sys.stderr
        self.label = label
        self.width = width
        self.enabled = hasattr(self.stream, "isatty") and self.stream.isatty()
        self._last = ""

    def __call__(self, fraction: float, message: str = "") -> bool:
        if self.enabled:
            n = int(round(self.width * max(0.0, min(1.0, fraction))))
            line = f"\r{self.label} [{'#' * n}{' ' * (self.width - n)}] {100 * fraction:3.0f}% {message:<28}"
            if line != self._last:
                self.stream.write(line)
                self.stream.flush()
                self._last = line
        return True

    def close(self) -> None:
        if self.enabled and self._last:
            self.stream.write("\r" + " " * len(self._last) + "\r")
            self.stream.flush()


def output_path(path: str | None, what: str, protect=()) -> str | None:
    """Make sure an output file can be written before any long work: not a folder, not one of
    the ``protect`` files (e.g. the holder library), and its folder exists (created here)."""
    if path is None or path == "-":
        return path
    target = Path(path).expanduser().resolve()
    if target.is_dir():
        raise InputError(f"{path}: is a folder; give a file name for the {what}")
    if any(target == Path(p).expanduser().resolve() for p in protect if p):
        raise InputError(f"{path}: is the holder library; writing the {what} there would destroy it")
    try:
        target.parent.mkdir(parents=True, exist_ok=True)
    except OSError as err:
        raise InputError(f"{path}: cannot write the {what} ({target.parent}: {err.strerror})") from None
    return path


def format_table(rows: list[list[str]], header: list[str]) -> str:
    """An aligned plain-text table."""
    cols = [header] + rows
    widths = [max(len(str(r[i])) for r in cols) for i in range(len(header))]
    lines = ["  ".join(str(h).ljust(w) for h, w in zip(header, widths))]
    lines.append("  ".join("-" * w for w in widths))
    lines += ["  ".join(str(c).rjust(w) if i else str(c).ljust(w) for i, (c, w) in enumerate(zip(r, widths))) for r in rows]
    return "\n".join(lines)
