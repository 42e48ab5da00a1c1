"""Bulk import of a large library export on every core.

Decoding and checking a holder costs about five times what writing it into the database
does, so for an export as :func:`taptune.library.exchange.export_library` writes it (one
holder per line-initial ``    "name": {`` member of ``holders``) worker processes decode
and check byte ranges of holders, each a whole number of holders, and send back only
what the database stores: the holder's compact JSON text and its indexed columns
(strings and numbers, cheap to pass between processes). The main process writes them in
its one transaction.

Anything unusual (another layout, a bad holder, a duplicate name) makes
:func:`parallel_holders` give up before its caller has written anything it keeps: the
caller then reads the file holder by holder (the serial reader) inside a fresh
transaction, which reports the first problem with its usual one-line message, so a
parallel import is never judged by other rules than a serial one.
"""

from __future__ import annotations

import json
import multiprocessing as mp
import os
import re
from collections import deque
from concurrent.futures import ProcessPoolExecutor
from concurrent.futures.process import BrokenProcessPool
from pathlib import Path

from taptune.library.schema import SCHEMA
from taptune.workers import ignore_interrupt

#: Bytes of export per piece a worker decodes (≈ 600 holders of a 9 KB holder).
PIECE_BYTES = 4 << 20
#: A holder member of ``holders`` starts a line with exactly four spaces and a quote.
_MEMBER = b',\n    "'
_HEAD = re.compile(rb'\{\n  "schema": "taptune-holder-library",\n  "version": (\d{1,9}),\n  "holders": \{')
_TAIL = re.compile(rb'\n  \}\n\}\s*\Z')


def library_document_head(version: int) -> str:
    """The start of a library JSON document up to the opening brace of ``holders`` (as :func:`taptune.library.schema.encode` writes it)."""
    head = json.dumps({"schema": SCHEMA, "version": version, "holders": {}}, indent=2)
    return head[: head.rindex("{}") + 1]


def _compact(text: str) -> str:
    """JSON ``text`` without the indentation after each line break.

    A JSON string holds no raw line break and valid JSON never puts two values side by
    side, so what follows a line break is whitespace between tokens: the text decodes to
    the same value.
    """
    return "".join(map(str.lstrip, text.split("\n")))


class NotParallel(Exception):
    """The file is not one the parallel reader takes as it is: read it serially instead."""


def workers() -> int:
    """Worker processes for a bulk import: the cores this process may use (0 or 1: none)."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # not on Linux
        return os.cpu_count() or 1


def pieces(path: str | os.PathLike, piece_bytes: int | None = None) -> tuple[int, list[tuple[int, int]]]:
    """(version, byte ranges of whole holders) of an export; NotParallel for another layout.

    The ranges start at a member's line (after the comma that ends the previous one) and
    together cover every byte between ``"holders": {`` and its closing brace. Only a
    few kilobytes are read at each boundary.
    """
    piece_bytes = piece_bytes or PIECE_BYTES
    size = os.path.getsize(path)
    with open(path, "rb") as f:
        start = f.read(4096)
        head = _HEAD.match(start)
        if head is None or not start[head.end():].startswith(b'\n    "'):
            raise NotParallel("not an export's layout")
        version = int(head.group(1))
        if library_document_head(version).encode() != start[:head.end()]:
            raise NotParallel("not an export's head")
        f.seek(max(0, size - 64))
        tail = _TAIL.search(f.read())
        if tail is None:
            raise NotParallel("not an export's end")
        end = size - 64 + tail.start() if size > 64 else tail.start()
        bounds = [head.end()]
        at = head.end() + piece_bytes
        while at < end:
            f.seek(at)
            window = f.read(1 << 16)
            i = window.find(_MEMBER)
            if i < 0:
                at += (1 << 16) - len(_MEMBER)  # within one large holder (or the last): read on
                continue
            cut = at + i + 1  # after the comma
            if cut >= end:
                break
            bounds.append(cut)
            at = cut + piece_bytes
        bounds.append(end)
    return version, list(zip(bounds[:-1], bounds[1:]))


def decode_piece(path: str, start: int, end: int, last: bool, row) -> list[tuple[str, str, tuple, list[str], bool]]:
    """(name, compact JSON text, holders row, recording hashes, has warnings) of every holder
    in ``path``'s bytes [start, end) (see :func:`pieces`); NotParallel at any problem.

    ``row(entry, document)`` gives (row, document, hashes) as the database stores them (the
    store's own function, passed by reference: this module imports no store)."""
    from taptune.errors import TaptuneError
    from taptune.library.schema import HolderEntry, _reject_constant, _unique_keys

    with open(path, "rb") as f:
        f.seek(start)
        data = f.read(end - start)
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError:
        raise NotParallel("not UTF-8") from None
    text = text.rstrip()
    if not last:
        if not text.endswith(","):
            raise NotParallel("a piece does not end between holders")
        text = text[:-1]
    decoder = json.JSONDecoder(object_pairs_hook=_unique_keys, parse_constant=_reject_constant)
    ws = re.compile(r"[ \t\r\n]*")
    out = []
    pos = ws.match(text, 0).end()
    try:
        while True:
            if text[pos:pos + 1] != '"':
                raise NotParallel("expected a holder name")
            name, pos = decoder.raw_decode(text, pos)
            pos = ws.match(text, pos).end()
            if text[pos:pos + 1] != ":":
                raise NotParallel("expected ':'")
            pos = ws.match(text, pos + 1).end()
            value, end_value = decoder.raw_decode(text, pos)
            entry = HolderEntry.from_dict(value, f"{path}: holder {name!r}")
            if entry.name != name:
                raise NotParallel("a holder's name differs from its key")
            columns, document, hashes = row(entry, _compact(text[pos:end_value]))
            out.append((name, document, columns, hashes, bool(entry.warnings)))
            pos = ws.match(text, end_value).end()
            if pos == len(text):
                return out
            if text[pos] != ",":
                raise NotParallel("expected ','")
            pos = ws.match(text, pos + 1).end()
    except (ValueError, RecursionError, TaptuneError) as err:  # JSONDecodeError is a ValueError
        raise NotParallel(str(err)) from None


def parallel_holders(path: str | os.PathLike, processes: int, row):
    """Lists of :func:`decode_piece` results in file order, decoded by ``processes`` workers
    (``row``: see there).

    Raises NotParallel (before or between the lists) when the serial reader must take
    over; also for a version this library cannot read and for a duplicate name.
    """
    from taptune.library.schema import LibraryFormatError, parse_library

    path = str(Path(path))
    version, ranges = pieces(path)
    try:
        parse_library({"schema": SCHEMA, "version": version, "holders": {}}, path)
    except LibraryFormatError as err:
        raise NotParallel(str(err)) from None
    names: set[str] = set()
    # concurrent.futures, not multiprocessing.Pool: leaving early (a duplicate name, a bad
    # holder) must stop the workers without killing them mid-result. Pool.terminate()
    # SIGTERMs workers and can then wait forever on a queue lock a killed worker held
    # (CPython issues 73945, 96995); it hung a CI run. shutdown() here lets the pieces
    # already handed to workers (about two per worker) finish and drops the rest. A worker
    # that dies makes the pool broken: the serial reader takes over. The workers are fresh
    # interpreters (nothing of the open database is shared) that leave Ctrl-C to this process.
    pool = ProcessPoolExecutor(processes, mp_context=mp.get_context("spawn"), initializer=ignore_interrupt)
    try:
        queue: deque = deque()
        jobs = iter(enumerate(ranges))
        # A few pieces in flight per worker: memory stays bounded when writing is slower.
        for i, (a, b) in jobs:
            queue.append(pool.submit(decode_piece, path, a, b, i == len(ranges) - 1, row))
            if len(queue) >= 3 * processes:
                break
        while queue:
            holders = queue.popleft().result()
            for i, (a, b) in jobs:
                queue.append(pool.submit(decode_piece, path, a, b, i == len(ranges) - 1, row))
                break
            for name, *_ in holders:
                if name in names:
                    raise NotParallel(f"duplicate holder {name!r}")
                names.add(name)
            yield holders
    except BrokenProcessPool as err:  # from result() or submit()
        raise NotParallel(f"a worker stopped: {err}") from None
    finally:
        pool.shutdown(wait=True, cancel_futures=True)
