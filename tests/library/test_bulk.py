"""Bulk import on every core (taptune.library.bulk): the same library, the same refusals as one process."""

from __future__ import annotations

import json
from dataclasses import replace

import pytest

from taptune.library import LibraryFormatError, bulk, exchange
from taptune.library.exchange import export_entries
from taptune.library.sql_store import entry_row
from tests.library.entries import make_entry


@pytest.fixture
def parallel(monkeypatch):
    """Every import file counts as large, is cut into pieces of a few holders, on two workers."""
    monkeypatch.setattr(exchange, "WHOLE_FILE_BYTES", 0)
    monkeypatch.setattr(bulk, "PIECE_BYTES", 4000)
    monkeypatch.setattr(bulk, "workers", lambda: 2)


def export(tmp_path, n: int = 12, name: str = "all.json"):
    entries = {f"H{i:02d}": make_entry(f"H{i:02d}", records=1 + i % 2, first=i) for i in range(n)}
    export_entries(entries, tmp_path / name)
    return entries, tmp_path / name


def test_pieces_are_whole_holders_covering_the_holders(tmp_path, monkeypatch):
    entries, path = export(tmp_path)
    version, ranges = bulk.pieces(path, piece_bytes=3000)
    assert len(ranges) > 3 and all(b == c for (_, b), (c, _) in zip(ranges, ranges[1:]))
    names = [n for i, (a, b) in enumerate(ranges) for n, *_ in bulk.decode_piece(str(path), a, b, i == len(ranges) - 1,
                                                                                 entry_row)]
    assert names == sorted(entries)
    # A file of another layout (the same holders, other indentation) is left to the serial reader.
    (tmp_path / "flat.json").write_text(json.dumps(json.loads(path.read_text())))
    with pytest.raises(bulk.NotParallel):
        bulk.pieces(tmp_path / "flat.json")


def test_parallel_import_stores_what_the_serial_one_stores(db, tmp_path, parallel):
    entries, path = export(tmp_path)
    older = replace(entries["H03"], identifications=entries["H03"].identifications[:1])
    db.put(older)  # held already, with less history: merged as the serial import merges it
    report = db.import_file(path)
    assert report.added == tuple(n for n in sorted(entries) if n != "H03") and report.merged == ("H03",)
    assert db.entries() == entries
    db.export(tmp_path / "again.json")
    assert (tmp_path / "again.json").read_bytes() == path.read_bytes()


def test_a_bad_holder_late_in_the_file_refuses_everything(db, tmp_path, parallel):
    db.put(make_entry("A"))
    _, path = export(tmp_path)
    doc = json.loads(path.read_text())
    doc["holders"]["H10"]["__reduce__"] = "os.system"
    (tmp_path / "evil.json").write_text(json.dumps(doc, indent=2, ensure_ascii=False))
    with pytest.raises(LibraryFormatError, match=r"evil\.json: holder 'H10'.*__reduce__"):
        db.import_file(tmp_path / "evil.json")
    assert db.names() == ["A"]


def test_a_name_twice_in_different_pieces_is_refused(db, tmp_path, parallel):
    _, path = export(tmp_path)
    text = path.read_text().replace('"H09": {\n      "name": "H09"', '"H01": {\n      "name": "H01"')
    (tmp_path / "twice.json").write_text(text)
    with pytest.raises(LibraryFormatError, match="duplicate key 'H01'"):
        db.import_file(tmp_path / "twice.json")
    assert db.names() == []


def _worker_dies(entry, document):
    """A ``row`` function that ends its worker process (as the kernel's OOM killer would)."""
    import os

    os._exit(1)


def test_a_worker_that_dies_hands_over_to_the_serial_reader_without_hanging(tmp_path):
    _, path = export(tmp_path)
    pieces = bulk.parallel_holders(path, 2, _worker_dies)
    with pytest.raises(bulk.NotParallel, match="a worker stopped"):
        next(pieces)


def test_leaving_early_with_pieces_in_flight_stops_every_worker(tmp_path, monkeypatch):
    import multiprocessing

    monkeypatch.setattr(bulk, "PIECE_BYTES", 1000)
    _, path = export(tmp_path, n=40)
    before = set(multiprocessing.active_children())  # other tests' pools, if any
    pieces = bulk.parallel_holders(path, 2, entry_row)
    assert next(pieces)
    pieces.close()  # as a refused holder in the consumer does: queued pieces dropped, workers joined
    assert set(multiprocessing.active_children()) <= before


def _sigint_row(entry, document):
    """A ``row`` function that reports whether its worker leaves Ctrl-C to the parent."""
    import signal

    return (signal.getsignal(signal.SIGINT) == signal.SIG_IGN,), document, []


def test_workers_leave_ctrl_c_to_the_parent(tmp_path):
    """A worker interrupted while sending a piece left half a message in the pipe: the import hung."""
    _, path = export(tmp_path)
    rows = [row for holders in bulk.parallel_holders(path, 2, _sigint_row) for _, _, row, _, _ in holders]
    assert len(rows) == 12 and all(ignored for ignored, in rows)
