"""Holder-library files in and out, and receptance files of a holder with a tool.

* :func:`read_library_file` reads and validates a file in the library format (the
  library's own file, an exported one, one to import).
* :func:`export_library` writes the library as JSON (exactly the library file format, so
  :func:`import_library` round-trips it) or as CSV (one row per holder, units in the
  header) for spreadsheets.
* :func:`import_library` validates a whole file first (plain JSON, never executed or
  unpickled), then merges it under the library lock and reports what it did.
* :func:`holder_receptance` predicts the tool-tip receptance of a library holder with
  another tool or stick-out (MODEL.md §9); :func:`write_receptance_csv` and
  :func:`write_receptance_uff58` write it for other software (pyuff imported lazily).

Every file is written atomically (:func:`taptune.io.atomic.atomic_write`). The functions
work on entries and files; those given a library (``lib``) use only its ``target``,
``entries()`` and ``edit()``, so this module never imports :mod:`taptune.library.store`
(the store imports it).
"""

from __future__ import annotations

import csv
import io
import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from taptune.errors import InputError, LibraryError
from taptune.io.atomic import atomic_write, atomic_write_bytes
from taptune.library.schema import (PARAM_UNITS, HolderEntry, LibraryFormatError, decode, encode, parse_library,
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


# --------------------------------------------------------------------------- export


def library_csv(entries: dict[str, HolderEntry]) -> str:
    """One CSV row per holder: parameters and their ± half-width spreads, geometry, history."""
    header = ["name", "interface"]
    for k in NAMES:
        header += [f"{k} [{PARAM_UNITS[k]}]", f"{k}_spread [{PARAM_UNITS[k]}]"]
    header += ["param_sets", "holder_length [mm]", "clamp_length [mm]", "identifications", "last_identified"]
    out = io.StringIO()
    writer = csv.writer(out, lineterminator="\n")
    writer.writerow(header)
    for name in sorted(entries):
        e = entries[name]
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
        writer.writerow(row)
    return out.getvalue()


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
    """
    _check_format(format)
    out = Path(out)
    if Path(os.path.realpath(out)) == lib.target:
        raise InputError(f"{out}: is the library being exported; choose another file")
    return export_entries(lib.entries(), out, format)


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
    """Merge the holders of a library file into ``lib`` (a HolderLibrary), under its lock.

    The whole file is validated first; geometry that would enter the library (a new holder,
    or a replacing one with other geometry) must also be within the assembly file's
    plausible ranges (else refused, naming the holder). An invalid file changes nothing. See
    :func:`merge_entries` for what happens to each holder.
    """
    theirs = read_library_file(file)
    with lib.edit() as holders:
        for name, entry in theirs.items():
            # A read keeps an implausible holder (with a warning); the library takes no new
            # one, but one it already holds unchanged (an export of itself) is no reason to refuse.
            current = holders.get(name)
            if current is None or (replace and current.holder != entry.holder):
                refuse_implausible(entry, f"{file}: holder {name!r}", "nothing was imported")
        return merge_entries(holders, theirs, replace, source=str(file))


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
