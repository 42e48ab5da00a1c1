"""Discovery and planning: which recordings, with which assembly, and what is left to do.

:func:`discover` the recordings (every suffix :mod:`taptune.io.audio` reads, recursively, sorted, so every run sees the same
order), :func:`find_assembly` for each, then :func:`plan`: load each assembly, hash each
recording, skip what was already identified with the same content (result JSON or
library provenance, unless ``force``), and group the rest into jobs (one recording each,
or one holder each for a joint fit).
"""

from __future__ import annotations

import json
import os
from collections import Counter
from dataclasses import dataclass
from pathlib import Path
from typing import Sequence

from taptune.batch.on_machine import skipped_note
from taptune.batch.records import AUDIO_SUFFIXES, BatchOptions, Item, Row, first_three, one_line
from taptune.errors import InputError
from taptune.io.assembly import assembly_beside, load_assembly
from taptune.library.schema import sha256_file
from taptune.library.store import HolderLibrary, default_library_path, library_files


# ----------------------------------------------------------------------------- discovery


def _is_audio(path: Path) -> bool:
    return path.suffix.lower() in AUDIO_SUFFIXES


def discover(paths: Sequence[str | os.PathLike]) -> tuple[list[Path], list[Row]]:
    """The recordings under ``paths``, and a failed row for each path that does not exist.

    Folders are searched recursively for every suffix :func:`~taptune.io.audio.read_audio`
    reads (:data:`~taptune.io.audio.AUDIO_SUFFIXES`: WAV, FLAC, MP3, Ogg, M4A …, any case); a file named
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
    """The assembly file of ``recording``: ``assembly`` if given, else the one beside it
    (:func:`taptune.io.assembly.assembly_beside`, as ``taptune identify`` finds it); None
    if there is none."""
    if assembly is not None:
        return Path(assembly)
    return assembly_beside(recording)


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
    clashes = {s for s, n in Counter(stems).items() if n > 1}
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


def _skip_from_json(item: Item, group_hashes: frozenset[str], machine=None) -> Row | None:
    """A skipped row if ``item``'s result JSON holds a result for the same content
    (with its machine numbers when ``machine``, the batch's MachineSetup, is what made them)."""
    data = _read_json(item.json_path)
    if data is None or data.get("sha256") != item.sha256 or data.get("assembly_sha256") != item.assembly_sha256:
        return None
    joint = data.get("joint")
    previous_group = frozenset(joint.get("sha256", ())) if isinstance(joint, dict) else frozenset({item.sha256})
    if previous_group != group_hashes:
        return None
    try:
        measured = first_three(data.get("bending_measured_hz") or ())
        model = first_three(data.get("bending_model_hz") or ())
        objective = data.get("objective")
    except TypeError:
        return None
    row = Row(str(item.path), item.holder, "skipped", measured, model, objective, None,
              f"identified before (same sha256 {item.sha256[:12]}; {item.json_path.name})")
    return skipped_note(row, data, machine, item.assembly, item.json_path)


def _skip_from_library(item: Item, entries: dict, group_hashes: frozenset[str], machine=None) -> Row | None:
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
            row = Row(str(item.path), item.holder, "skipped", first_three(record.bending_measured_hz),
                      first_three(record.bending_model_hz), record.objective, None,
                      f"identified before (same sha256 {item.sha256[:12]} in the library, {record.date})")
            return skipped_note(row, None, machine, item.assembly, item.json_path, entry.params,
                                model_options=entry.options() if machine is not None else None)
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


def _library_entries(options: BatchOptions, items: Sequence[Item]) -> dict:
    """The library's holders that these recordings identified before (none if there is no library yet);
    a broken library stops the batch up front. Only those holders are read, not the whole library."""
    library = HolderLibrary(default_library_path(options.library))
    try:
        library.check_writable()
        return library.with_recordings({i.sha256 for i in items})
    finally:
        library.close()


def _protect_library(items: Sequence[Item], options: BatchOptions) -> None:
    """Refuse up front a result JSON that would land on the holder library file (even with
    --no-save: ``holders.wav`` with ``--out`` the library's folder would replace the library)."""
    files = library_files(default_library_path(options.library))  # none for a server
    library = files[0].resolve() if files else None
    for item in items:
        if library is not None and item.json_path.resolve() == library:
            raise InputError(f"{item.json_path}: is the holder library; the result of {item.path} would "
                             "overwrite it; choose another --out folder")


def plan(paths: Sequence[str | os.PathLike], options: BatchOptions, assembly: str | None = None) -> Plan:
    """Discover, pair, hash and group the recordings; decide what is skipped or cannot run.

    Raises
    ------
    InputError
        No recording found at all, an ``assembly`` file that cannot be used, a result
        JSON that would overwrite the library file, or a library file that does not validate.
    """
    if assembly is not None:
        load_assembly(assembly)  # a bad --assembly concerns every file: bad input up front, exit 2
    files, rows = discover(paths)
    if not files and not rows:
        raise InputError(f"no recording (WAV, FLAC, MP3, Ogg, M4A …) under {', '.join(map(str, paths))}")
    items, bad = _prepare(files, assembly, Path(options.out_dir))
    _protect_library(items, options)
    rows += bad
    entries = _library_entries(options, items) if options.save and not options.force else {}
    jobs = []
    for group in _group(items, options.joint):
        hashes = frozenset(i.sha256 for i in group)
        skipped = [] if options.force else [
            _skip_from_json(i, hashes, options.machine)
            or (_skip_from_library(i, entries, hashes, options.machine) if entries else None) for i in group
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
