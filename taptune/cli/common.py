"""Small helpers the command modules share: JSON output, progress display, file lists."""

from __future__ import annotations

import json
import math
import os
import sys
from pathlib import Path

from taptune.errors import InputError
from taptune.io.atomic import atomic_write_bytes, check_writable


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


def _same_file(a: Path, b: Path) -> bool:
    """True when ``a`` and ``b`` name one file (after links; also two hard links of one file)."""
    if a.expanduser().resolve() == b.expanduser().resolve():
        return True
    try:
        return a.exists() and b.exists() and os.path.samefile(a, b)
    except OSError:
        return False


def refuse_library_output(path: str | os.PathLike | None, what: str, library=None, protect=()) -> None:
    """Refuse an output file that is a holder library file (or its lock or journal): one place for every command.

    Parameters
    ----------
    path : path or None
        The output file (None or ``-`` = stdout: nothing to check).
    what : str
        What would be written there ("JSON", "plot" …), for the message.
    library : path or None
        The command's ``--library`` value; None means ``$TAPTUNE_LIBRARY``, else the
        user data folder (:func:`~taptune.library.store.default_library_path`). The
        default library is protected even when another ``--library`` is given.
    protect : sequence of paths
        Further library files to protect (an open library's ``path``).

    Raises
    ------
    InputError
        ``path`` is one of those libraries or its ``.lock``, ``-wal``, ``-shm`` or ``-journal`` file.
    """
    if path is None or str(path) == "-":
        return
    from taptune.library.store import default_library_path, library_files

    libraries = [p for p in protect if p]
    for arg in dict.fromkeys((library or None, None)):  # the given library, then the default one
        try:
            libraries.append(default_library_path(arg))
        except (RuntimeError, KeyError):
            pass  # no home folder (a container's bare user): there is no default library to protect
    target = Path(path)
    for lib in libraries:
        files = library_files(lib)  # none for a server
        if files and _same_file(target, files[0]):
            raise InputError(f"{path}: is the holder library; writing the {what} there would destroy it")
        if any(_same_file(target, f) for f in files[1:]):
            raise InputError(f"{path}: is a file of the holder library ({files[0].name}'s lock or journal); "
                             f"choose another name for the {what}")


# Outputs whose writer has one format whatever the name (matplotlib PNG, PdfPages PDF).
_SUFFIXES = {"plot": (".png",), "report": (".pdf",)}

# Options and arguments that name files a command reads (never to be overwritten by its outputs).
_INPUT_ARGS = ("wav", "assembly", "params", "machine", "frf", "dummy", "aa", "ab", "bb", "bands",
               "interface_tap", "file", "spindle", "paths")


def command_inputs(args) -> list[str]:
    """The files a command reads (recordings, assembly, machine files and the spindle files a
    machine file names, the interface-band table of ``$TAPTUNE_INTERFACE_BANDS`` …)."""
    from taptune.io.files import BANDS_ENV

    out: list[str] = []
    for name in _INPUT_ARGS:
        value = getattr(args, name, None)
        values = value if isinstance(value, (list, tuple)) else [value]
        out += [str(v) for v in values if isinstance(v, (str, os.PathLike)) and str(v) not in ("", "-")]
    machine = getattr(args, "machine", None)
    if isinstance(machine, (str, os.PathLike)) and str(machine):
        from taptune.io.machine import machine_file_inputs  # only when there is one (a 25 ms import)

        out += machine_file_inputs(machine)
    if os.environ.get(BANDS_ENV):
        out.append(os.environ[BANDS_ENV])
    return out


def output_path(path: str | None, what: str, protect=(), library=None, create: bool = True,
                inputs=()) -> str | None:
    """Make sure an output file can be written before any long work.

    Not a folder, not the holder library (:func:`refuse_library_output`, with ``library``
    the command's ``--library`` value and ``protect`` further library files), not one of
    the command's ``inputs`` (:func:`command_inputs`: ``--json tap.wav`` replaced the
    recording), and its
    folder exists (created here) or, with ``create=False``, could be created (nothing
    is written: ``taptune record`` writes nothing before the first tap).
    """
    if path is None or path == "-":
        return path
    target = Path(path).expanduser().resolve()
    if target.is_dir():
        raise InputError(f"{path}: is a folder; give a file name for the {what}")
    refuse_library_output(path, what, library, protect)
    for source in inputs:
        if _same_file(Path(path), Path(source)):
            raise InputError(f"{path}: is also an input of this command; writing the {what} there would destroy it")
    wanted = _SUFFIXES.get(what)
    if wanted and target.suffix.lower() not in wanted:
        # The writers do not follow the name: a plot named x.pdf or x.txt held PNG data.
        raise InputError(f"{path}: the {what} is written as {' or '.join(wanted)}; name the file so")
    check_writable(path)  # a file or a read-only folder in the way: now, not after minutes of fitting
    if not create:
        return path
    try:
        target.parent.mkdir(parents=True, exist_ok=True)
    except OSError as err:
        raise InputError(f"{path}: cannot write the {what} ({target.parent}: {err.strerror})") from None
    return path


def check_seed_and_jobs(args) -> None:
    """``--seed`` must be >= 0 (numpy's seeds are) and ``--jobs`` >= 1 when given: bad input
    now, not a traceback from a worker (``--seed -1``) or a silent default (``--jobs 0``)."""
    seed = getattr(args, "seed", None)
    if seed is not None and seed < 0:
        raise InputError(f"--seed must be >= 0, got {seed}")
    jobs = getattr(args, "jobs", None)
    if jobs is not None and jobs < 1:
        raise InputError(f"--jobs must be at least 1, got {jobs}")


def format_table(rows: list[list[str]], header: list[str]) -> str:
    """An aligned plain-text table."""
    cols = [header] + rows
    widths = [max(len(str(r[i])) for r in cols) for i in range(len(header))]
    lines = ["  ".join(str(h).ljust(w) for h, w in zip(header, widths))]
    lines.append("  ".join("-" * w for w in widths))
    lines += ["  ".join(str(c).rjust(w) if i else str(c).ljust(w) for i, (c, w) in enumerate(zip(r, widths))) for r in rows]
    return "\n".join(lines)
