"""The database libraries: every test here runs on SQLite and on a real PostgreSQL server (fixture ``db``)."""

from __future__ import annotations

import json
import os
import signal
import sqlite3
import subprocess
import sys
import time
from dataclasses import replace
from pathlib import Path

import pytest

from taptune.errors import InputError, LibraryError
from taptune.library import HolderLibrary, LibraryFormatError, UnknownHolderError, base, default_library_path
from taptune.library import exchange
from taptune.library.exchange import export_entries
from taptune.library.schema import CheckRecord
from tests.library.entries import make_entry, make_record
from tests.library.test_store import run_workers

REPO = Path(__file__).resolve().parents[2]


def a_check(i: int = 0, verdict: str = "consistent") -> CheckRecord:
    return CheckRecord(date=f"2026-11-23T08:{i:02d}:00Z", recording=f"check{i}.wav", sha256=f"{i + 500:064x}",
                       tool="solid carbide end mill D16 4FL", stickout_mm=53.5, verdict=verdict,
                       modes=({"mode": 1, "measured_hz": 4780.0, "predicted_hz": 4783.0, "band_hz": 40.0},),
                       taptune_version="0.1.0")


# --------------------------------------------------------------------------- the operations


def test_store_is_chosen_by_the_location(tmp_path, pg_url):
    assert HolderLibrary(tmp_path / "h.db").kind == "sqlite"
    assert HolderLibrary(tmp_path / "h.json").kind == "json"
    assert HolderLibrary(pg_url).kind == "postgresql"
    json_content = tmp_path / "old-library"
    make = HolderLibrary(tmp_path / "x.json")
    make.put(make_entry("A"))
    json_content.write_bytes(make.path.read_bytes())
    assert HolderLibrary(json_content).kind == "json"  # an existing JSON file keeps working, whatever its name


def test_missing_library_is_empty_and_reading_creates_nothing(db, tmp_path):
    assert len(db) == 0 and db.names() == [] and "A" not in db and db.summaries() == []
    with pytest.raises(UnknownHolderError, match="the library is empty"):
        db.get("A")
    if db.kind == "sqlite":
        assert not db.path.parent.exists()


def test_put_get_update_remove_round_trip(db):
    a = make_entry("A", records=2)
    assert db.put(a) == a and db.get("A") == a
    b = replace(make_entry("B"), checks=(a_check(1),))
    db.put(b)
    assert db.names() == ["A", "B"] and len(db) == 2 and "B" in db
    assert db.get("B").to_dict() == b.to_dict()
    stored = db.put(make_entry("A", scale=1.3, records=1, first=7))  # re-identified: history kept
    assert [r.seed for r in stored.identifications] == [0, 1, 7] and db.get("A") == stored
    checked = db.update("A", lambda e: replace(e, checks=e.checks + (a_check(2, "differs"),)))
    assert db.get("A") == checked and checked.checks[-1].verdict == "differs"
    assert db.remove("B") == b and db.names() == ["A"]
    with pytest.raises(UnknownHolderError):
        db.remove("B")


def test_update_writes_nothing_when_the_function_fails_or_renames(db):
    db.put(make_entry("A"))
    before = db.get("A")

    def boom(entry):
        raise RuntimeError("interrupted")

    with pytest.raises(RuntimeError):
        db.update("A", boom)
    with pytest.raises(LibraryError, match="keep its name"):
        db.update("A", lambda e: replace(e, name="B"))
    with pytest.raises(LibraryFormatError, match="k_tt must be > 0"):
        bad = replace(before.params, k_tt=-1.0)
        db.update("A", lambda e: replace(e, params=bad))
    with pytest.raises(UnknownHolderError, match="did you mean 'A'"):
        db.update("a", lambda e: e)
    assert db.get("A") == before and db.names() == ["A"]


def test_summaries_match_case_insensitively_with_limit_and_offset(db):
    names = ["ER32 collet 100", "er32 collet 120", "Shrink fit 80", "100% weldon_x", "100x weldonyx"]
    for i, n in enumerate(names):
        db.put(replace(make_entry(n, records=1, first=i), checks=(a_check(i),) if i == 1 else ()))
    assert db.names() == sorted(names)
    assert db.names("ER32") == ["ER32 collet 100", "er32 collet 120"]
    assert db.count("er32") == 2 and db.count() == 5 and db.count("nothing") == 0
    assert db.names("0% w") == ["100% weldon_x"]  # % and _ are literal text, not wildcards
    assert db.names("n_x") == ["100% weldon_x"]
    assert db.names(limit=2) == sorted(names)[:2]
    assert [s.name for s in db.summaries(offset=3)] == sorted(names)[3:]
    s = db.summaries("er32 collet 120")[0]
    assert (s.identifications, s.checks, s.last_verdict, s.last_checked) == (1, 1, "consistent", a_check(1).date)
    assert s.k_tt == pytest.approx(2.81e9) and s.last_identified == make_record(1).date
    assert list(db.page("collet", limit=1, offset=1)) == ["er32 collet 120"]


def test_did_you_mean_works_beyond_the_suggestion_pool(db, monkeypatch):
    monkeypatch.setattr(base, "SUGGESTION_POOL", 4)
    monkeypatch.setattr("taptune.library.sql_store.SUGGESTION_POOL", 4)
    for i in range(12):
        db.put(make_entry(f"filler {i:02d}", records=0))
    db.put(make_entry("ER32 collet chuck HSK-A63 x 100", records=0))
    with pytest.raises(UnknownHolderError) as info:
        db.get("ER32")
    assert info.value.close_matches == ("ER32 collet chuck HSK-A63 x 100",)
    assert str(db.location) in str(info.value)


def test_with_recordings_reads_only_the_holders_of_those_recordings(db):
    db.put(make_entry("A", records=2, first=0))
    db.put(make_entry("B", records=1, first=5))
    assert list(db.with_recordings([f"{1:064x}", "f" * 64])) == ["A"]
    assert db.with_recordings([]) == {}


# --------------------------------------------------------------------------- exchange


def test_export_is_byte_for_byte_what_a_json_library_writes(db, tmp_path):
    entries = {n: replace(make_entry(n, records=2, first=i), checks=(a_check(i),) if i else ())
               for i, n in enumerate(["Ä holder", "B", "zz"])}
    for e in entries.values():
        db.put(e)
    for fmt in ("json", "csv"):
        assert db.export(tmp_path / f"db.{fmt}", fmt) == 3
        export_entries(entries, tmp_path / f"ref.{fmt}", fmt)
        assert (tmp_path / f"db.{fmt}").read_bytes() == (tmp_path / f"ref.{fmt}").read_bytes()


@pytest.mark.parametrize("streamed", [False, True])
def test_hostile_import_is_refused_and_changes_nothing(db, tmp_path, monkeypatch, streamed):
    if streamed:
        monkeypatch.setattr(exchange, "WHOLE_FILE_BYTES", 0)  # read holder by holder, inside the transaction
    db.put(make_entry("A"))
    good = {f"new {i}": make_entry(f"new {i}") for i in range(3)}
    export_entries(good, tmp_path / "good.json")
    doc = json.loads((tmp_path / "good.json").read_text())
    doc["holders"]["zz evil"] = {**doc["holders"]["new 0"], "name": "zz evil", "__reduce__": "os.system"}
    (tmp_path / "evil.json").write_text(json.dumps(doc))
    with pytest.raises(LibraryFormatError, match="zz evil.*__reduce__"):
        db.import_file(tmp_path / "evil.json")
    assert db.names() == ["A"]
    report = db.import_file(tmp_path / "good.json")
    assert report.added == ("new 0", "new 1", "new 2") and db.count() == 4


# --------------------------------------------------------------------------- broken and foreign


def test_foreign_sqlite_database_is_reported_and_never_written(tmp_path):
    path = tmp_path / "crm.db"
    with sqlite3.connect(path) as conn:
        conn.execute("CREATE TABLE customers (id INTEGER, name TEXT)")
    before = path.read_bytes()
    lib = HolderLibrary(path)
    for action in (lambda: lib.names(), lambda: lib.put(make_entry("A")), lambda: lib.get("A")):
        with pytest.raises(LibraryFormatError, match=r"crm\.db: is the database of another program \(tables customers"):
            action()
    assert path.read_bytes() == before


@pytest.mark.parametrize("content", [b"not a database at all, just text", b"SQLite format 3\x00" + b"\x00" * 200])
def test_broken_database_file_is_reported_and_never_written(tmp_path, content):
    path = tmp_path / "holders.db"
    path.write_bytes(content)
    lib = HolderLibrary(path)
    with pytest.raises(LibraryFormatError) as info:
        lib.put(make_entry("A"))
    assert str(path) in str(info.value) and "\n" not in str(info.value)
    assert path.read_bytes() == content


def test_newer_schema_is_refused(db):
    db.put(make_entry("A"))
    db.close()
    if db.kind == "sqlite":
        with sqlite3.connect(db.path) as conn:
            conn.execute("UPDATE taptune_library SET value = '99' WHERE key = 'version'")
            conn.execute("PRAGMA user_version = 99")
    else:
        import psycopg

        with psycopg.connect(db.url, autocommit=True) as conn:
            conn.execute("UPDATE taptune_library SET value = '99' WHERE key = 'version'")
    with pytest.raises(LibraryFormatError, match="newer taptune"):
        HolderLibrary(db.location if db.kind == "sqlite" else db.url).names()


def test_foreign_postgresql_database_is_reported_and_untouched(postgres_server):
    import psycopg

    from tests.library.pg import fresh_database

    url = postgres_server.url(fresh_database(postgres_server))
    with psycopg.connect(url, autocommit=True) as conn:
        conn.execute("CREATE TABLE parts (id int)")
    lib = HolderLibrary(url)
    with pytest.raises(LibraryFormatError, match="another program.*tables parts"):
        lib.put(make_entry("A"))
    with psycopg.connect(url, autocommit=True) as conn:
        tables = [r[0] for r in conn.execute("SELECT table_name FROM information_schema.tables "
                                             "WHERE table_schema = 'public'")]
    assert tables == ["parts"]


def test_server_errors_are_one_line_naming_the_library_never_the_password(postgres_server):
    from tests.library.pg import PASSWORD, fresh_database

    name = fresh_database(postgres_server)
    cases = [
        (postgres_server.tcp_url(name, password="wrong-pw"), "wrong user name or password"),
        (postgres_server.url("no_such_db"), "no database 'no_such_db'"),
        (f"postgresql://someone:{PASSWORD}@127.0.0.1:1/{name}", "cannot be reached"),
    ]
    for url, problem in cases:
        with pytest.raises(LibraryError) as info:
            HolderLibrary(url).names()
        message = str(info.value)
        assert problem in message and "\n" not in message
        assert "wrong-pw" not in message and PASSWORD not in message
        assert message.startswith(url.split("@")[0].split(":")[0])  # names the library (scheme and user)
    # The right password works over TCP.
    assert HolderLibrary(postgres_server.tcp_url(name)).names() == []


# --------------------------------------------------------------------------- concurrency and kill -9


def test_four_processes_saving_lose_nothing(db_location):
    run_workers(db_location, 4, 5)
    lib = HolderLibrary(db_location)
    assert lib.names() == sorted(f"w{w}-{i:02d}" for w in range(4) for i in range(5))
    assert all(len(e.identifications) == 1 for e in lib.page().values())


@pytest.mark.slow
def test_three_processes_reidentifying_one_holder_keep_every_record(db_location):
    run_workers(db_location, 3, 6, "same")
    seeds = sorted(r.seed for r in HolderLibrary(db_location).get("shared").identifications)
    assert seeds == sorted(1000 * w + i for w in range(3) for i in range(6))


SAVER = """
import sys
from taptune.library import HolderLibrary
from tests.library.entries import make_entry
lib = HolderLibrary(sys.argv[1], lock_timeout=60.0)
for i in range(100000):
    lib.put(make_entry(f"saved {i:05d}", records=2, first=i))
    print(i, flush=True)
"""


def test_kill_9_while_saving_loses_no_finished_save(db_location):
    proc = subprocess.Popen([sys.executable, "-c", SAVER, db_location], cwd=REPO, stdout=subprocess.PIPE, text=True)
    done = []
    deadline = time.monotonic() + 20
    while len(done) < 15 and time.monotonic() < deadline:  # kill it mid-run, after some saves
        done.append(int(proc.stdout.readline()))
    os.kill(proc.pid, signal.SIGKILL)
    done += [int(line) for line in proc.stdout.read().split()]
    proc.wait()
    assert len(done) >= 15
    lib = HolderLibrary(db_location)
    names = lib.names()
    assert all(f"saved {i:05d}" in names for i in done)
    assert len(names) in (len(done), len(done) + 1)  # at most the save in flight when killed, whole
    assert all(len(e.identifications) == 2 for e in lib.page().values())


# --------------------------------------------------------------------------- taking over the JSON library


def test_old_default_json_library_is_taken_over_once_with_everything(tmp_path, monkeypatch, capsys):
    monkeypatch.delenv("TAPTUNE_LIBRARY", raising=False)
    monkeypatch.setattr(base.sys, "platform", "linux")
    monkeypatch.setenv("XDG_DATA_HOME", str(tmp_path / "xdg"))
    old = tmp_path / "xdg" / "taptune" / "holders.json"
    json_lib = HolderLibrary(old)
    stated = replace(make_record(9), stickout_tolerance_mm=0.2)
    entries = {
        "ER32 collet chuck HSK-A63 x 100": replace(make_entry(records=3), checks=(a_check(1), a_check(2, "differs"))),
        "Shrink fit Ø12": replace(make_entry("Shrink fit Ø12", scale=1.4, records=1, first=4),
                                  identifications=(make_record(4), stated)),
        "no history": make_entry("no history", records=0),
    }
    for e in entries.values():
        json_lib.put(e)
    original = old.read_bytes()
    before = {name: e.to_dict() for name, e in json_lib.entries().items()}

    lib = HolderLibrary(default_library_path())
    assert lib.kind == "sqlite" and lib.path == old.with_name("holders.db")
    after = {name: e.to_dict() for name, e in lib.entries().items()}
    assert after == before  # every record, field by field
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "took over" in err and "3 holders" in err and "holders.json.bak" in err
    assert not old.exists() and old.with_name("holders.json.bak").read_bytes() == original
    lib.export(tmp_path / "back.json")
    assert (tmp_path / "back.json").read_bytes() == original  # exported back: identical content
    # Once: a new holders.json beside the database is not taken over again.
    HolderLibrary(old).put(make_entry("later"))
    assert "later" not in HolderLibrary(default_library_path()).names()
    assert capsys.readouterr().err == ""


def test_broken_old_json_library_is_not_taken_over(tmp_path):
    old = tmp_path / "holders.json"
    old.write_text('{"schema": "taptune-holder-library", "version": 1, "holders": {"A": {')
    with pytest.raises(LibraryFormatError, match="holders.json: is not valid JSON"):
        HolderLibrary(tmp_path / "holders.db").names()
    assert not (tmp_path / "holders.db").exists() and old.exists()


def test_explicit_json_library_still_works_as_before(tmp_path):
    lib = HolderLibrary(tmp_path / "team.json")
    lib.put(make_entry("A"))
    assert json.loads(lib.path.read_text())["holders"]["A"]["name"] == "A"
    assert not (tmp_path / "team.db").exists()
    assert lib.update("A", lambda e: replace(e, checks=(a_check(),))).checks == (a_check(),)


def test_check_writable_creates_nothing(tmp_path):
    lib = HolderLibrary(tmp_path / "new" / "holders.db")
    lib.check_writable()
    assert not (tmp_path / "new").exists()
    (tmp_path / "file").write_text("x")
    with pytest.raises(InputError, match="is a file"):
        HolderLibrary(tmp_path / "file" / "holders.db").check_writable()


@pytest.mark.parametrize("chunk", [7, 300, 1 << 20])
def test_reading_a_file_in_pieces_gives_what_reading_it_whole_does(tmp_path, chunk):
    entries = {f"H{i}": make_entry(f"H{i}", records=2, first=i) for i in range(4)}
    export_entries(entries, tmp_path / "a.json")
    assert dict(exchange.iter_library_file(tmp_path / "a.json", chunk=chunk)) == entries
    raw = (tmp_path / "a.json").read_text()
    for bad, problem in ((raw[:-30], "not valid JSON"), (raw.replace('"H1"', '"H0"', 1), "duplicate key 'H0'"),
                         (raw.replace('"version": 1', '"version": 99'), "newer taptune"), (raw + "x", "more after")):
        (tmp_path / "b.json").write_text(bad)
        with pytest.raises(LibraryFormatError, match=problem):
            list(exchange.iter_library_file(tmp_path / "b.json", chunk=chunk))


def test_a_server_user_without_rights_gets_one_line_and_no_empty_library(postgres_server):
    from tests.library.pg import fresh_database

    url = postgres_server.url(fresh_database(postgres_server))
    HolderLibrary(url).put(make_entry("A"))
    postgres_server.admin("DO $$ BEGIN IF NOT EXISTS (SELECT FROM pg_roles WHERE rolname = 'stranger') "
                          "THEN CREATE ROLE stranger LOGIN; END IF; END $$")
    stranger = url.replace("taptune_admin@", "stranger@")
    for action in (lambda lib: lib.names(), lambda lib: lib.put(make_entry("B"))):
        with pytest.raises(LibraryError, match="permission denied for table taptune_library") as info:
            action(HolderLibrary(stranger))
        assert str(info.value).startswith("postgresql://stranger@") and "\n" not in str(info.value)
    assert HolderLibrary(url).names() == ["A"]


@pytest.mark.parametrize("streamed", [False, True])
def test_an_imported_export_reads_back_and_exports_to_the_same_bytes(db, tmp_path, monkeypatch, streamed):
    # Streamed, each holder is stored as the file's text (indentation removed), not encoded again.
    if streamed:
        monkeypatch.setattr(exchange, "WHOLE_FILE_BYTES", 0)
    entries = {n: replace(make_entry(n, records=2, first=i), checks=(a_check(i),) if i else ())
               for i, n in enumerate(["Ä holder \\n \"quoted\"", "B", "zz"])}
    export_entries(entries, tmp_path / "all.json")
    assert db.import_file(tmp_path / "all.json").added == tuple(sorted(entries))
    assert db.entries() == entries
    db.export(tmp_path / "again.json")
    assert (tmp_path / "again.json").read_bytes() == (tmp_path / "all.json").read_bytes()


@pytest.mark.parametrize("streamed", [False, True])
def test_an_out_of_range_holder_is_refused_and_nothing_is_imported(db, tmp_path, monkeypatch, streamed):
    if streamed:
        monkeypatch.setattr(exchange, "WHOLE_FILE_BYTES", 0)
    db.put(make_entry("A"))
    export_entries({n: make_entry(n) for n in ("B", "C", "D")}, tmp_path / "all.json")
    doc = json.loads((tmp_path / "all.json").read_text())
    doc["holders"]["C"]["holder"]["segments"][0]["length"] = 5e6
    (tmp_path / "bad.json").write_text(json.dumps(doc, indent=2))
    with pytest.raises(LibraryFormatError, match=r"holder 'C': \[holder\] segments\[1\].length .* nothing was imported$"):
        db.import_file(tmp_path / "bad.json")
    assert db.names() == ["A"]


def test_compacting_an_export_keeps_its_value():
    text = json.dumps({"a b": ["x\n  y", {"k": "  v  "}], "n": [1, 2.5e-300, None]}, indent=4)
    assert "\n" in text and json.loads(exchange._compact(text)) == json.loads(text)


@pytest.mark.parametrize("chunk", [7, 300, 1 << 20])
def test_the_holder_texts_read_in_pieces_decode_to_their_entries(tmp_path, chunk):
    entries = {f"H{i}": make_entry(f"H{i}", records=2, first=i) for i in range(4)}
    export_entries(entries, tmp_path / "a.json")
    for name, entry, document in exchange._iter_holders(tmp_path / "a.json", chunk=chunk):
        assert "\n" not in document and json.loads(document) == entry.to_dict() == entries[name].to_dict()


def test_a_postgresql_reader_does_not_wait_for_a_writer(pg_url):
    """Once the tables are there and current, reading takes no lock: a predict on one
    computer does not wait for another computer's long write (a bulk import holds the
    library's lock for its whole transaction)."""
    import threading

    import psycopg

    from taptune.library.sql_store import PG_LOCK_KEY

    lib = HolderLibrary(pg_url)
    lib.put(make_entry("A"))
    lib.close()
    read = []

    def reader():
        other = HolderLibrary(pg_url)
        read.append(other.get("A").name)
        other.close()

    with psycopg.connect(pg_url) as writer:  # a writer inside its transaction, holding the lock
        writer.execute("SELECT pg_advisory_xact_lock(%s)", (PG_LOCK_KEY,))
        thread = threading.Thread(target=reader)
        thread.start()
        thread.join(10)
        waited = thread.is_alive()
    thread.join()
    assert not waited and read == ["A"]
