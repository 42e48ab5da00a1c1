"""Holder-library files in and out, and receptance files of a holder with a tool.

* :func:`read_library_file` reads and validates a file in the library format (the
  library's own file, an exported one, one to import).
* :func:`export_library` writes the library as JSON (exactly the library file format, so
  :func:`import_library` round-trips it) or as CSV (one row per holder, units in the
  header) for spreadsheets.
* :func:`import_library` validates a whole file first (plain JSON, never executed or
  unpickled), then merges it under the library lock and reports what it did.
* :func:`holder_receptance` predicts the tool-tip receptance of a library holder with
  another tool or stick-out (docs/physics.md §6); :func:`write_receptance_csv` and
  :func:`write_receptance_uff58` write it for other software (pyuff imported lazily).

Every file is written atomically (:func:`taptune.io.atomic.atomic_write`). The functions
work on entries and files; those given a library (``lib``) use only its ``target``,
``iter_entries()`` and ``_transaction()``, so this module never imports
:mod:`taptune.library.store` (the stores import it).
"""

from __future__ import annotations

import contextlib
import csv
import io
import itertools
import json
import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from taptune.errors import InputError, LibraryError
from taptune.io.atomic import atomic_write, atomic_write_bytes
from taptune.library import bulk
from taptune.library.bulk import _compact, library_document_head  # noqa: F401  (library_document_head: public here)
from taptune.library.schema import (PARAM_UNITS, SCHEMA, HolderEntry, LibraryFormatError, decode, encode, parse_library,
                                    refuse_implausible)
from taptune.model.params import NAMES

FORMATS = ("json", "csv")
RECEPTANCE_SUFFIXES = {".uff": "uff58", ".unv": "uff58", ".csv": "csv"}


# --------------------------------------------------------------------------- read


def read_library_file(path: str | os.PathLike, missing_ok: bool = False) -> dict[str, HolderEntry]:
    """Read and validate a holder-library JSON file; a missing file is empty if ``missing_ok``."""
    path = Path(path)
    try:
        raw = path.read_bytes()
    except FileNotFoundError:
        if missing_ok:
            return {}
        raise LibraryFormatError(f"{path}: no such file") from None
    except IsADirectoryError:
        raise LibraryFormatError(f"{path}: is a folder, not a holder library file") from None
    except OSError as err:
        raise LibraryFormatError(f"{path}: cannot read the holder library ({err.strerror})") from None
    return parse_library(decode(raw, str(path)), str(path))


#: Library files up to this size are read whole (with line and column in a message);
#: larger ones holder by holder, so importing a large export needs little memory.
WHOLE_FILE_BYTES = 64 << 20
_CHUNK = 1 << 20


def iter_library_file(path: str | os.PathLike, chunk: int = _CHUNK):
    """(name, entry) of every holder of a library file, validated one by one, in file order.

    The same checks as :func:`read_library_file` (schema, version before any holder when
    the file states it first, as exports do; strict JSON; no duplicate names), reading
    the file in pieces: memory does not grow with the file. A problem raises
    LibraryFormatError naming the file when it is reached, so a caller that writes while
    iterating must do it in a transaction it can roll back.
    """
    for name, entry, _ in _iter_holders(path, chunk):
        yield name, entry


def _iter_holders(path: str | os.PathLike, chunk: int = _CHUNK):
    """(name, entry, document) of :func:`iter_library_file`; ``document`` the holder's JSON
    text as in the file (indentation removed: :func:`_compact`), which decodes to what the
    entry was checked from, so a database can store it without encoding the entry again."""
    from taptune.library.schema import VERSION, _reject_constant, _unique_keys

    path = Path(path)
    src = str(path)
    decoder = json.JSONDecoder(object_pairs_hook=_unique_keys, parse_constant=_reject_constant)
    try:
        f = open(path, encoding="utf-8")
    except FileNotFoundError:
        raise LibraryFormatError(f"{path}: no such file") from None
    except IsADirectoryError:
        raise LibraryFormatError(f"{path}: is a folder, not a holder library file") from None
    except OSError as err:
        raise LibraryFormatError(f"{path}: cannot read the holder library ({err.strerror})") from None
    state = {"buf": "", "pos": 0, "eof": False, "offset": 0}

    def more() -> bool:
        if state["eof"]:
            return False
        try:
            piece = f.read(chunk)
        except UnicodeDecodeError:
            raise LibraryFormatError(f"{path}: is not UTF-8 text, so not a holder library (JSON)") from None
        if not piece:
            state["eof"] = True
            return False
        state["offset"] += state["pos"]
        state["buf"] = state["buf"][state["pos"]:] + piece
        state["pos"] = 0
        return True

    def bad(what: str):
        raise LibraryFormatError(f"{path}: is not valid JSON near character {state['offset'] + state['pos']} "
                                 f"({what}); truncated or not a holder library")

    def skip_ws() -> str:
        while True:
            buf, pos = state["buf"], state["pos"]
            while pos < len(buf) and buf[pos] in " \t\r\n":
                pos += 1
            state["pos"] = pos
            if pos < len(buf):
                return buf[pos]
            if not more():
                return ""

    def expect(chars: str) -> str:
        c = skip_ws()
        if not c or c not in chars:
            bad(f"expected {' or '.join(repr(x) for x in chars)}, found {c!r}" if c else "ends too early")
        state["pos"] += 1
        return c

    def value():
        """The JSON value that starts here; its text (from the buffer) in ``state["text"]``."""
        skip_ws()
        while True:
            try:
                obj, end = decoder.raw_decode(state["buf"], state["pos"])
            except json.JSONDecodeError as err:
                if more():
                    continue
                bad(err.msg)
            except (ValueError, RecursionError) as err:
                bad(str(err))
            if end == len(state["buf"]) and more():
                continue  # a number may go on in the next piece
            state["text"] = (state["buf"], state["pos"], end)
            state["pos"] = end
            return obj

    def members(what: str):
        """The keys of the object that starts here; the caller reads each value before the next key."""
        expect("{")
        first = True
        while True:
            c = expect('}"' if first else "},")
            if c == "}":
                return
            if c == '"':
                state["pos"] -= 1  # the key's opening quote: value() reads the key
            elif skip_ws() != '"':
                bad(f"expected {what}")
            first = False
            key = value()
            expect(":")
            yield key

    with f:
        if skip_ws() == "\ufeff":
            state["pos"] += 1
        if skip_ws() == "":
            raise LibraryFormatError(f"{path}: is empty (truncated?), not a holder library")
        head: dict = {}
        names: set[str] = set()
        for key in members("a key"):
            if key in head or (key == "holders" and names):
                raise LibraryFormatError(f"{path}: is not valid JSON (duplicate key {key!r})")
            if key != "holders":
                head[key] = value()
                if key == "schema" and head[key] != SCHEMA:
                    raise LibraryFormatError(f"{path}: is not a taptune holder library (schema {head[key]!r})")
                if key == "version":
                    parse_library({"schema": SCHEMA, "version": head[key], "holders": {}}, src)
                elif key not in ("schema", "version"):
                    raise LibraryFormatError(f"{path}: {key} is not a known key (allowed: schema, version, holders)")
                continue
            if "schema" not in head:
                raise LibraryFormatError(f"{path}: is not a taptune holder library (no \"schema\": \"{SCHEMA}\" "
                                         "key before its holders)")
            head[key] = None
            for name in members("a holder name"):
                if name in names:
                    raise LibraryFormatError(f"{path}: is not valid JSON (duplicate key {name!r})")
                names.add(name)
                where = f"{src}: holder {name!r}"
                entry = HolderEntry.from_dict(value(), where)
                if entry.name != name:
                    raise LibraryFormatError(f"{where}: name {entry.name!r} differs from its key in \"holders\"")
                buf, start, end = state["text"]
                yield name, entry, _compact(buf[start:end])
        if skip_ws() != "":
            bad("more after the end of the document")
        missing = [k for k in ("schema", "version", "holders") if k not in head]
        if missing:
            raise LibraryFormatError(f"{path}: {missing[0]} is missing")
        if not isinstance(head["version"], int) or head["version"] > VERSION:
            parse_library({"schema": SCHEMA, "version": head["version"], "holders": {}}, src)


# --------------------------------------------------------------------------- export


def _csv_header() -> list[str]:
    header = ["name", "interface"]
    for k in NAMES:
        header += [f"{k} [{PARAM_UNITS[k]}]", f"{k}_spread [{PARAM_UNITS[k]}]"]
    return header + ["param_sets", "holder_length [mm]", "clamp_length [mm]", "identifications", "last_identified"]


def _csv_line(row: list) -> str:
    out = io.StringIO()
    csv.writer(out, lineterminator="\n").writerow(row)
    return out.getvalue()


_CSV_HEADER_LINE = _csv_line(_csv_header())


def library_csv_row(e: HolderEntry) -> str:
    """The CSV line of one holder (see :func:`library_csv`)."""
    spread = e.spread()
    row = [e.name, e.interface]
    for k in NAMES:
        row += [repr(getattr(e.params, k)), repr(spread[k])]
    row += [
        len(e.param_sets),
        repr(sum(s["length"] for s in e.holder["segments"])),
        repr(e.holder["clamp_length"]),
        len(e.identifications),
        e.last_identified or "",
    ]
    return _csv_line(row)


def library_csv(entries: dict[str, HolderEntry]) -> str:
    """One CSV row per holder: parameters and their ± half-width spreads, geometry, history."""
    return _CSV_HEADER_LINE + "".join(library_csv_row(entries[name]) for name in sorted(entries))


def export_library(lib, out: str | os.PathLike, format: str = "json") -> int:
    """Write every holder of ``lib`` to ``out``; returns how many.

    Parameters
    ----------
    lib : HolderLibrary
        The library (never the file being written).
    out : path
        Output file (created with its folders; replaced atomically if it exists).
    format : {"json", "csv"}
        ``"json"``: the library file format (:func:`import_library` reads it back to the
        same entries). ``"csv"``: a table for spreadsheets; it cannot be imported.

    A JSON library is written from its entries at once; a database is streamed holder by
    holder (:meth:`iter_entries`), so the export of a large library needs little memory,
    and the bytes are those :func:`export_entries` would write.
    """
    _check_format(format)
    out = Path(out)
    if lib.target is not None and Path(os.path.realpath(out)) == lib.target:
        raise InputError(f"{out}: is the library being exported; choose another file")
    if not hasattr(lib, "export_version"):
        return export_entries(lib.entries(), out, format)
    count = 0

    def write(tmp: Path) -> None:
        nonlocal count
        with open(tmp, "w", encoding="utf-8", newline="\n") as f:
            if format == "csv":
                f.write(_CSV_HEADER_LINE)
                for _, entry in lib.iter_entries():
                    f.write(library_csv_row(entry))
                    count += 1
                return
            f.write(library_document_head(lib.export_version()))
            for name, entry in lib.iter_entries():
                f.write((",\n" if count else "\n") + holder_json(name, entry))
                count += 1
            f.write(("\n  }" if count else "}") + "\n}\n")

    _write_output(out, lambda: atomic_write(out, write))
    return count


def export_entries(entries: dict[str, HolderEntry], out: str | os.PathLike, format: str = "json") -> int:
    """Write ``entries`` to ``out`` as JSON (the library file format) or CSV; returns how many."""
    _check_format(format)
    out = Path(out)
    if format == "json":
        data = encode(entries, str(out))
    else:
        data = library_csv(entries).encode("utf-8")
    _write_output(out, lambda: atomic_write_bytes(out, data))
    return len(entries)


def holder_json(name: str, entry: HolderEntry) -> str:
    """One ``"name": {...}`` member of ``holders``, indented as :func:`encode` writes it."""
    body = json.dumps(entry.to_dict(), indent=2, ensure_ascii=False, allow_nan=False).replace("\n", "\n    ")
    return "    " + json.dumps(name, ensure_ascii=False) + ": " + body


def _check_format(format: str) -> None:
    if format not in FORMATS:
        raise InputError(f"export format must be one of {', '.join(FORMATS)}, got {format!r}")


def _write_output(out: Path, write) -> None:
    """Run ``write()``; a file the user named that cannot be written is bad input (exit 2)."""
    if out.is_dir():
        raise InputError(f"{out}: is a folder; give a file name to write")
    try:
        write()
    except OSError as err:
        raise InputError(f"{out}: cannot write ({err.strerror or err})") from None


# --------------------------------------------------------------------------- import


@dataclass(frozen=True)
class Conflict:
    """An imported holder whose name exists with different parameters or geometry."""

    name: str
    differences: tuple[str, ...]

    def to_dict(self) -> dict:
        return {"name": self.name, "differences": list(self.differences)}


@dataclass(frozen=True)
class ImportReport:
    """What :func:`import_library` did with each holder of the imported file.

    Attributes
    ----------
    source : str
        The imported file.
    added : tuple of str
        Holders that were new.
    merged : tuple of str
        Holders with the same parameters whose new identification records were appended.
    skipped : tuple of str
        Holders identical to the library's (nothing to do).
    conflicts : tuple of Conflict
        Same name, different parameters, sets, geometry or model options.
    replaced : bool
        Whether the conflicting holders were replaced by the imported ones (their
        identification history is kept either way); if False they were kept as they were.
    """

    source: str
    added: tuple[str, ...] = ()
    merged: tuple[str, ...] = ()
    skipped: tuple[str, ...] = ()
    conflicts: tuple[Conflict, ...] = ()
    replaced: bool = False

    def to_dict(self) -> dict:
        return {
            "source": self.source,
            "added": list(self.added),
            "merged": list(self.merged),
            "skipped": list(self.skipped),
            "conflicts": [c.to_dict() for c in self.conflicts],
            "replaced": self.replaced,
        }

    def lines(self) -> list[str]:
        """Human-readable summary, one line per outcome and per conflict."""
        out = [
            f"{self.source}: {len(self.added)} added, {len(self.merged)} merged (new identification records), "
            f"{len(self.skipped)} identical and skipped, {len(self.conflicts)} in conflict"
        ]
        action = "replaced by the imported holder (history kept)" if self.replaced else "kept; use --replace to take the imported holder"
        for c in self.conflicts:
            out.append(f"  conflict {c.name!r}: {'; '.join(c.differences)} — {action}")
        return out


def import_library(lib, file: str | os.PathLike, replace: bool = False) -> ImportReport:
    """Merge the holders of a library file into ``lib`` (a HolderLibrary) in one transaction.

    Every holder is validated; geometry that would enter the library (a new holder, or a
    replacing one with other geometry) must also be within the assembly file's plausible
    ranges (else refused, naming the holder). An invalid file changes nothing: a small
    file is validated whole before the transaction, a large one (over
    :data:`WHOLE_FILE_BYTES`, into a database) holder by holder inside it, and the
    transaction is rolled back at the first problem. See :func:`merge_entries` for what
    happens to each holder; only the holders it adds or changes are written.
    """
    try:
        size = os.path.getsize(file)
    except OSError:
        size = 0
    streamed = size > WHOLE_FILE_BYTES and hasattr(lib, "export_version")
    if streamed and bulk.workers() > 1:
        try:
            return _import_parallel(lib, file, replace, bulk.workers())
        except bulk.NotParallel:
            pass  # rolled back: the serial reader below reports the problem (or reads the other layout)
    holders = (_iter_holders(file) if streamed
               else ((name, entry, None) for name, entry in read_library_file(file).items()))
    parts: list[ImportReport] = []
    with lib._transaction() as tx:
        while True:
            batch = list(itertools.islice(holders, 1000))
            if not batch:
                break
            parts.append(_merge_batch(tx, {name: entry for name, entry, _ in batch}, replace, file,
                                      {name: document for name, _, document in batch if document is not None}))
    return _combined(file, parts, replace)


def _combined(file, parts: list[ImportReport], replace: bool) -> ImportReport:
    return ImportReport(str(file), *(tuple(sorted(n for p in parts for n in getattr(p, k)))
                                     for k in ("added", "merged", "skipped")),
                        tuple(sorted((c for p in parts for c in p.conflicts), key=lambda c: c.name)),
                        bool(replace and any(p.conflicts for p in parts)))


def _import_parallel(lib, file, replace: bool, processes: int) -> ImportReport:
    """:func:`import_library` of a large export into a database, decoded by ``processes``
    workers (:mod:`taptune.library.bulk`); raises bulk.NotParallel, with the transaction
    rolled back, when the serial reader must take over.

    A holder the library does not hold yet is written from the workers' row; one it holds
    is decoded again here and merged as the serial import merges it.
    """
    parts: list[ImportReport] = []
    # closing(): a refused holder stops the workers now, not when the traceback is freed.
    with lib._transaction() as tx, contextlib.closing(bulk.parallel_holders(file, processes, tx.row)) as pieces:
        for holders in pieces:
            current = tx.load_many(sorted(name for name, *_ in holders))
            rows, added, known = [], [], {}
            for name, document, row, hashes, warned in holders:
                if name in current:
                    known[name] = document
                    continue
                if warned:
                    where = f"{file}: holder {name!r}"
                    refuse_implausible(HolderEntry.from_dict(decode(document.encode(), where), where), where,
                                       "nothing was imported")
                rows.append((row, document, hashes))
                added.append(name)
            tx.store_rows(rows)
            parts.append(ImportReport(str(file), tuple(added), (), (), (), False))
            if known:
                theirs = {name: HolderEntry.from_dict(decode(document.encode(), f"{file}: holder {name!r}"),
                                                      f"{file}: holder {name!r}") for name, document in known.items()}
                parts.append(_merge_batch(tx, theirs, replace, file, known))
    return _combined(file, parts, replace)


def _merge_batch(tx, theirs: dict[str, HolderEntry], replace: bool, file, documents: dict[str, str]) -> ImportReport:
    """Merge one batch of read holders; ``documents`` their JSON texts where the reader kept them."""
    current = tx.load_many(sorted(theirs))
    for name, entry in theirs.items():
        # A read keeps an implausible holder (with a warning); the library takes no new
        # one, but one it already holds unchanged (an export of itself) is no reason to refuse.
        # Only an entry with a warning from its read (HolderEntry.from_dict) can be one.
        mine = current.get(name)
        if entry.warnings and (mine is None or (replace and mine.holder != entry.holder)):
            refuse_implausible(entry, f"{file}: holder {name!r}", "nothing was imported")
    merged = dict(current)
    report = merge_entries(merged, theirs, replace, source=str(file))
    for name, entry in merged.items():
        if current.get(name) != entry:
            # The file's text only for a holder taken as it was read (not merged with ours).
            tx.store(entry, documents.get(name) if entry is theirs.get(name) else None)
    return report


def merge_entries(holders: dict[str, HolderEntry], theirs: dict[str, HolderEntry], replace: bool, source: str) -> ImportReport:
    """Merge ``theirs`` into the dict ``holders`` in place; returns what was done.

    New holders are added; identical ones skipped; a holder whose parameters match but
    whose history has new records gets them appended. A holder with the same name but
    different parameters (or sets, geometry, model options) is a conflict: kept as it is,
    or replaced by the imported one when ``replace`` (the identification history of both
    is kept).
    """
    added, merged, skipped, conflicts = [], [], [], []
    for name in sorted(theirs):
        incoming, current = theirs[name], holders.get(name)
        if current is None:
            holders[name] = incoming
            added.append(name)
            continue
        differences = current.differences(incoming)
        combined = incoming.superseding(current)
        if not differences:
            if combined == current:
                skipped.append(name)
            else:
                holders[name] = combined
                merged.append(name)
            continue
        conflicts.append(Conflict(name, tuple(differences)))
        if replace:
            holders[name] = combined
    return ImportReport(source, tuple(added), tuple(merged), tuple(skipped), tuple(conflicts), bool(replace and conflicts))


# --------------------------------------------------------------------------- a holder with a tool


def frequency_grid(f_min_hz: float = 10.0, f_max_hz: float = 20000.0, step_hz: float = 5.0) -> np.ndarray:
    """Uniform frequency grid f_min, f_min + step, … ≤ f_max [Hz] (what receptance files use)."""
    if not (0 < f_min_hz < f_max_hz) or not step_hz > 0 or not np.isfinite([f_min_hz, f_max_hz, step_hz]).all():
        raise InputError(
            f"frequency grid needs 0 < min < max and step > 0, got min {f_min_hz:g}, max {f_max_hz:g}, step {step_hz:g} Hz"
        )
    n = int(np.floor((f_max_hz - f_min_hz) / step_hz + 1e-9)) + 1
    if n > 2_000_000:
        raise InputError(f"frequency grid of {n} points is too fine; use a larger step")
    # Multiplying (not accumulating) keeps every point exact to the step's precision.
    return f_min_hz + step_hz * np.arange(n)


def holder_receptance(entry: HolderEntry, assembly, freq_hz) -> np.ndarray:
    """Tool-tip receptance H_tt(f) [m/N] of ``assembly`` with the holder's best parameters.

    The model is built with the options stored with the entry, so the prediction uses the
    same discretisation as the identification.
    """
    from taptune.model import build_model, tip_receptance

    fe = build_model(assembly, entry.options())
    return np.asarray(tip_receptance(fe, entry.params, np.asarray(freq_hz, dtype=float)), dtype=complex)


def identified_setups(entry: HolderEntry) -> list[tuple[dict, float]]:
    """Distinct (tool geometry, stick-out [mm]) pairs of the entry's identifications, oldest first."""
    out: list[tuple[dict, float]] = []
    for r in entry.identifications:
        if (r.tool, r.stickout_mm) not in out:
            out.append((r.tool, r.stickout_mm))
    return out


def predict_setup(entry: HolderEntry, tool: dict, stickout_mm: float):
    """Bending modes with spread of the holder with ``tool`` at ``stickout_mm`` (an identify Prediction)."""
    return entry.predict(entry.assembly(tool, stickout_mm))


# --------------------------------------------------------------------------- receptance files


def _check_frf(freq_hz, H) -> tuple[np.ndarray, np.ndarray]:
    f = np.asarray(freq_hz, dtype=float)
    h = np.asarray(H, dtype=complex)
    if f.ndim != 1 or h.shape != f.shape or f.size < 2:
        raise ValueError(f"receptance needs two 1-D arrays of the same length >= 2, got shapes {f.shape} and {h.shape}")
    if not (np.isfinite(f).all() and np.isfinite(h).all()):
        raise ValueError("receptance frequencies and values must be finite")
    if f[0] <= 0 or np.any(np.diff(f) <= 0):
        raise ValueError("receptance frequencies must be > 0 and strictly increasing")
    return f, h


def write_receptance_csv(path: str | os.PathLike, freq_hz, H) -> None:
    """Write a receptance as CSV: ``frequency [Hz], real [m/N], imag [m/N]`` (full precision)."""
    f, h = _check_frf(freq_hz, H)
    lines = ["frequency [Hz],real [m/N],imag [m/N]"]
    lines += [f"{fi!r},{hi.real!r},{hi.imag!r}" for fi, hi in zip(f.tolist(), h.tolist())]
    data = ("\n".join(lines) + "\n").encode("ascii")
    path = Path(path)
    _write_output(path, lambda: atomic_write_bytes(path, data))


def uff58_dataset(freq_hz, H, name: str, description: str = "", binary: bool = False) -> dict:
    """The pyuff dict of a UFF dataset 58: complex FRF, receptance (displacement / force), tip X / tip X."""
    pyuff = _pyuff()

    f, h = _check_frf(freq_hz, H)
    step = f[1] - f[0]
    even = bool(np.allclose(np.diff(f), step, rtol=1e-9, atol=0))
    return pyuff.prepare_58(
        binary=int(bool(binary)),
        id1=name[:80],
        id2=description[:80] or "tool-tip receptance H_tt [m/N]",
        id3="taptune",
        id4="NONE",
        id5="NONE",
        func_type=4,  # frequency response function
        load_case_id=0,
        rsp_ent_name="tip",
        rsp_node=1,
        rsp_dir=1,  # +X translation: a bending (lateral) receptance
        ref_ent_name="tip",
        ref_node=1,
        ref_dir=1,
        abscissa_spacing=int(even),
        abscissa_spec_data_type=18,  # frequency
        abscissa_axis_units_lab="Hz",
        ordinate_spec_data_type=8,  # displacement
        ordinate_len_unit_exp=1,
        ordinate_axis_units_lab="m",
        orddenom_spec_data_type=13,  # excitation force
        orddenom_force_unit_exp=1,
        orddenom_axis_units_lab="N",
        data=h,
        x=f,
    )


def _pyuff():
    try:
        import pyuff
    except ImportError:
        raise LibraryError("writing UFF files needs pyuff: pip install 'taptune[export]'") from None
    return pyuff


def write_receptance_uff58(
    path: str | os.PathLike, freq_hz, H, name: str, description: str = "", binary: bool = False
) -> None:
    """Write a receptance as a universal file, dataset 58 (complex FRF, receptance, translational).

    ASCII by default (double precision, ~12 significant digits), ``binary=True`` for exact
    doubles. pyuff is imported here, so only this function needs it.
    """
    dataset = uff58_dataset(freq_hz, H, name, description, binary)
    path = Path(path)
    pyuff = _pyuff()

    def write(tmp: Path) -> None:
        # pyuff 2.5.8 writes a 7-byte file for dataset 58 with mode="overwrite"; writing
        # into the empty temporary file with mode="add" is correct (ENV-NOTES.md).
        pyuff.UFF(str(tmp)).write_sets(dataset, mode="add")

    _write_output(path, lambda: atomic_write(path, write))


def receptance_format(path: str | os.PathLike) -> str:
    """``"uff58"`` for ``.uff``/``.unv``, ``"csv"`` for ``.csv``; InputError for anything else."""
    kind = RECEPTANCE_SUFFIXES.get(Path(path).suffix.lower())
    if kind is None:
        raise InputError(f"{path}: unknown receptance file type; use .uff or .unv (UFF dataset 58) or .csv")
    return kind


def write_receptance(path: str | os.PathLike, freq_hz, H, name: str, description: str = "") -> str:
    """Write UFF58 (``.uff``/``.unv``) or CSV (``.csv``) by the file's extension; returns the format."""
    kind = receptance_format(path)
    if kind == "csv":
        write_receptance_csv(path, freq_hz, H)
    else:
        write_receptance_uff58(path, freq_hz, H, name, description)
    return kind
