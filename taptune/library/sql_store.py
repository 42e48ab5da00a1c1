"""The holder library in a database: SQLite on one computer, PostgreSQL for a shop.

Both keep the same tables (schema version :data:`SCHEMA_VERSION`, migrated forward on
open; SQLite records it in ``PRAGMA user_version`` as well):

* ``taptune_library`` (key, value): what this database is (``schema`` =
  ``taptune-holder-library``) and its ``version``. A database without it is another
  program's, and is reported and never written to.
* ``holders``: one row per holder with what the list shows (interface, stiffnesses,
  counts and dates of identifications and checks), indexed by the case-folded name.
* ``documents``: each holder whole, as the JSON the library file format keeps for it
  (:meth:`HolderEntry.to_dict`), so every field — also ones added later, such as cut
  observations — is kept exactly, and reading one holder reads only its row.
* ``recordings`` (sha256, holder): which recordings identified which holder (batch runs
  skip what was identified before without reading the library).

Every change is one transaction under the library's write lock (SQLite ``BEGIN
IMMEDIATE`` with a busy timeout; PostgreSQL a transaction-level advisory lock), reads the
holder it changes inside that transaction and writes only that holder's rows: concurrent
writers lose nothing, and a process killed mid-write leaves the old or the new state.
"""

from __future__ import annotations

import json
import os
import re
import sqlite3
import sys
import threading
import time
from abc import abstractmethod
from contextlib import AbstractContextManager, contextmanager
from pathlib import Path
from typing import Iterable
from urllib.parse import urlsplit, urlunsplit

from taptune.errors import InputError, LibraryError
from taptune.io.atomic import fsync_dir
from taptune.library.schema import SCHEMA, VERSION, HolderEntry, LibraryFormatError, decode, library_version, utc_now
from taptune.library.base import (OLD_FILE_NAME, SUGGESTION_POOL, HolderLibrary, HolderSummary, Transaction,
                                   is_server_url, register)

#: Version of the tables (not of the holder documents, which carry the file format's version).
SCHEMA_VERSION = 1
META_TABLE = "taptune_library"
SQLITE_HEADER = b"SQLite format 3\x00"
#: Key of PostgreSQL's advisory lock that serialises the library's writers ("taptune" in ASCII, folded).
PG_LOCK_KEY = 0x7461_7074
#: Size the WAL file is cut back to after a checkpoint [bytes].
WAL_LIMIT_BYTES = 64 << 20
_SUMMARY = ("name", "interface", "k_tt", "k_rr", "identifications", "last_identified", "checks",
            "last_checked", "last_verdict", "warnings")

# Per version: the statements that bring a database from the version before to it.
_TABLES_V1 = """
CREATE TABLE taptune_library (key TEXT PRIMARY KEY, value TEXT NOT NULL);
CREATE TABLE holders (
    name TEXT {name_collation} PRIMARY KEY,
    name_fold TEXT NOT NULL,
    interface TEXT NOT NULL,
    k_tt {real} NOT NULL,
    k_rr {real} NOT NULL,
    identifications INTEGER NOT NULL,
    last_identified TEXT,
    checks INTEGER NOT NULL,
    last_checked TEXT,
    last_verdict TEXT,
    warnings TEXT NOT NULL,
    format INTEGER NOT NULL,
    changed TEXT NOT NULL
);
CREATE INDEX holders_by_folded_name ON holders (name_fold {fold_ops});
CREATE TABLE documents (name TEXT {name_collation} PRIMARY KEY, document TEXT NOT NULL);
CREATE TABLE recordings (sha256 TEXT NOT NULL, name TEXT {name_collation} NOT NULL, PRIMARY KEY (sha256, name));
CREATE INDEX recordings_by_holder ON recordings (name);
"""
MIGRATIONS = {1: _TABLES_V1}


def _like_pattern(text: str) -> str:
    """``%text%`` for LIKE on the case-folded name, with ``\\``, ``%`` and ``_`` taken literally."""
    return "%" + re.sub(r"([\\%_])", r"\\\1", text.casefold()) + "%"


def _prefix_pattern(text: str) -> str:
    return re.sub(r"([\\%_])", r"\\\1", text.casefold()) + "%"


def entry_format(entry: HolderEntry) -> int:
    """The library file format version this holder needs (what an export of it alone would state)."""
    return library_version([entry])


def entry_row(entry: HolderEntry, document: str | None = None) -> tuple[tuple, str, list[str]]:
    """(holders row, document JSON, recording hashes) of an entry; ``document`` if given (see
    :meth:`~taptune.library.base.Transaction.store`), else the entry encoded."""
    s = HolderSummary.of(entry)
    if document is None:
        document = json.dumps(entry.to_dict(), ensure_ascii=False, allow_nan=False, separators=(",", ":"))
    row = (s.name, s.name.casefold(), s.interface, s.k_tt, s.k_rr, s.identifications, s.last_identified, s.checks,
           s.last_checked, s.last_verdict, "\n".join(s.warnings), entry_format(entry), utc_now())
    return row, document, sorted({r.sha256 for r in entry.identifications})


_UPSERT_HOLDER = (
    "INSERT INTO holders (name, name_fold, interface, k_tt, k_rr, identifications, last_identified, checks, "
    "last_checked, last_verdict, warnings, format, changed) VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?) "
    "ON CONFLICT (name) DO UPDATE SET name_fold = excluded.name_fold, interface = excluded.interface, "
    "k_tt = excluded.k_tt, k_rr = excluded.k_rr, identifications = excluded.identifications, "
    "last_identified = excluded.last_identified, checks = excluded.checks, last_checked = excluded.last_checked, "
    "last_verdict = excluded.last_verdict, warnings = excluded.warnings, format = excluded.format, "
    "changed = excluded.changed")
_UPSERT_DOCUMENT = ("INSERT INTO documents (name, document) VALUES (?, ?) "
                    "ON CONFLICT (name) DO UPDATE SET document = excluded.document")


class _SqlTransaction(Transaction):
    #: (row, document, hashes) of an entry as :meth:`store_rows` takes them.
    row = staticmethod(entry_row)

    def __init__(self, lib: "SqlLibrary", cursor):
        self.lib, self.cursor = lib, cursor

    def load(self, name):
        return self.load_many([name]).get(name)

    def load_many(self, names):
        return self.lib._documents(self.cursor, names)

    def store(self, entry, document=None):
        self.store_rows([entry_row(entry, document)])

    def store_rows(self, rows):
        """Store holders given as :func:`entry_row` triples (a bulk import's workers make them)."""
        q = self.lib._q
        names = [(row[0],) for row, _, _ in rows]
        self.cursor.executemany(q(_UPSERT_HOLDER), [row for row, _, _ in rows])
        self.cursor.executemany(q(_UPSERT_DOCUMENT), [(row[0], document) for row, document, _ in rows])
        self.cursor.executemany(q("DELETE FROM recordings WHERE name = ?"), names)
        hashes = [(h, row[0]) for row, _, hs in rows for h in hs]
        if hashes:
            self.cursor.executemany(q("INSERT INTO recordings (sha256, name) VALUES (?, ?)"), hashes)

    def delete(self, name):
        q = self.lib._q
        for table in ("holders", "documents", "recordings"):
            self.cursor.execute(q(f"DELETE FROM {table} WHERE name = ?"), (name,))


class SqlLibrary(HolderLibrary):
    """What the SQLite and the PostgreSQL library share: the queries and the schema checks."""

    #: Placeholder of the driver (SQL here is written with ``?``).
    placeholder = "?"
    collate = ""
    ddl = {"name_collation": "", "real": "REAL", "fold_ops": ""}

    def _q(self, sql: str) -> str:
        return sql if self.placeholder == "?" else sql.replace("?", self.placeholder)

    @abstractmethod
    def _reading(self) -> AbstractContextManager:
        """A context manager giving a cursor on a checked database; None when the library
        does not exist yet (an empty library)."""

    # ---- schema

    @abstractmethod
    def _existing_tables(self, cursor) -> list[str]:
        """The names of the tables the database holds."""

    def _stored_version(self, cursor) -> int:
        cursor.execute(self._q(f"SELECT value FROM {META_TABLE} WHERE key = ?"), ("schema",))
        row = cursor.fetchone()
        if row is None or row[0] != SCHEMA:
            self._foreign(cursor, f"its {META_TABLE} table does not say {SCHEMA}")
        cursor.execute(self._q(f"SELECT value FROM {META_TABLE} WHERE key = ?"), ("version",))
        row = cursor.fetchone()
        try:
            return int(row[0])
        except (TypeError, ValueError):
            raise LibraryFormatError(f"{self.location}: the holder library's schema version is missing or "
                                     f"not a number ({row and row[0]!r}); it is left as it is") from None

    def _foreign(self, cursor, why: str = ""):
        tables = [t for t in self._existing_tables(cursor)]
        shown = ", ".join(tables[:5]) + (", …" if len(tables) > 5 else "")
        raise LibraryFormatError(
            f"{self.location}: is the database of another program (tables {shown}{'; ' + why if why else ''}), "
            "not a taptune holder library; it is left as it is: give taptune a database of its own")

    def _check_schema(self, cursor, create: bool) -> bool:
        """Check (and if ``create``, make or migrate) the tables; False if there are none and not ``create``."""
        tables = self._existing_tables(cursor)
        if not tables:
            if not create:
                return False
            self._migrate(cursor, 0)
            return True
        if META_TABLE not in tables:
            self._foreign(cursor)
        version = self._stored_version(cursor)
        if version > SCHEMA_VERSION:
            raise LibraryFormatError(
                f"{self.location}: holder library schema version {version} was written by a newer taptune "
                f"(this one knows versions 1–{SCHEMA_VERSION}); update taptune to use it (it is left as it is)")
        if version < SCHEMA_VERSION:
            self._migrate(cursor, version)  # in the caller's transaction: all of it or nothing
        return True

    def _migrate(self, cursor, version: int) -> None:
        for v in range(version + 1, SCHEMA_VERSION + 1):
            for statement in MIGRATIONS[v].format(**self.ddl).split(";"):
                if statement.strip():
                    cursor.execute(statement)
        if version == 0:
            cursor.executemany(self._q(f"INSERT INTO {META_TABLE} (key, value) VALUES (?, ?)"),
                               [("schema", SCHEMA), ("version", str(SCHEMA_VERSION)), ("created", utc_now())])
        else:
            cursor.execute(self._q(f"UPDATE {META_TABLE} SET value = ? WHERE key = ?"), (str(SCHEMA_VERSION), "version"))
        self._set_version(cursor)

    def _set_version(self, cursor) -> None:
        """Where the backend records the schema version besides the table (SQLite: user_version)."""

    # ---- reading

    def _documents(self, cursor, names: list[str]) -> dict[str, HolderEntry]:
        out = {}
        for i in range(0, len(names), 500):
            chunk = list(names[i:i + 500])
            marks = ", ".join("?" * len(chunk))
            cursor.execute(self._q(f"SELECT d.name, d.document, h.format FROM documents d JOIN holders h "
                                   f"ON h.name = d.name WHERE d.name IN ({marks})"), chunk)
            for name, document, fmt in cursor.fetchall():
                out[name] = self._entry(name, document, fmt)
        return out

    def _entry(self, name: str, document: str, fmt: int) -> HolderEntry:
        where = f"{self.location}: holder {name!r}"
        if fmt > VERSION:
            raise LibraryFormatError(f"{where}: was written by a newer taptune (library format {fmt}, this one "
                                     f"reads 1–{VERSION}); update taptune to use it (it is left as it is)")
        entry = HolderEntry.from_dict(decode(document.encode("utf-8"), where), where)
        if entry.name != name:
            raise LibraryFormatError(f"{where}: its document names holder {entry.name!r}; the library is damaged")
        return entry

    def _load(self, name: str) -> HolderEntry | None:
        with self._reading() as cursor:
            return None if cursor is None else self._documents(cursor, [name]).get(name)

    def _where(self, match: str | None) -> tuple[str, tuple]:
        if not match:
            return "", ()
        return " WHERE name_fold LIKE ? ESCAPE '\\'", (_like_pattern(match),)

    def _window(self, limit, offset) -> str:
        if limit is None and not offset:
            return ""
        return f" LIMIT {int(limit) if limit is not None else -1 if self.kind == 'sqlite' else 'ALL'} OFFSET {int(offset)}"

    def summaries(self, match=None, limit=None, offset=0) -> list[HolderSummary]:
        where, args = self._where(match)
        with self._reading() as cursor:
            if cursor is None:
                return []
            cursor.execute(self._q(f"SELECT {', '.join(_SUMMARY)} FROM holders{where} ORDER BY name{self.collate}"
                                   f"{self._window(limit, offset)}"), args)
            return [HolderSummary(*row[:-1], tuple(row[-1].split("\n")) if row[-1] else ())
                    for row in cursor.fetchall()]

    def count(self, match=None) -> int:
        where, args = self._where(match)
        with self._reading() as cursor:
            if cursor is None:
                return 0
            cursor.execute(self._q(f"SELECT COUNT(*) FROM holders{where}"), args)
            return int(cursor.fetchone()[0])

    def page(self, match=None, limit=None, offset=0) -> dict[str, HolderEntry]:
        where, args = self._where(match)
        with self._reading() as cursor:
            if cursor is None:
                return {}
            cursor.execute(self._q(f"SELECT h.name, d.document, h.format FROM holders h JOIN documents d ON "
                                   f"d.name = h.name{where.replace('name_fold', 'h.name_fold')} "
                                   f"ORDER BY h.name{self.collate}{self._window(limit, offset)}"), args)
            return {name: self._entry(name, document, fmt) for name, document, fmt in cursor.fetchall()}

    def _candidates(self, query: str) -> list[str]:
        """Names containing the query, starting like it, or (in a small library) all of them."""
        with self._reading() as cursor:
            if cursor is None:
                return []
            cursor.execute("SELECT COUNT(*) FROM holders")
            if cursor.fetchone()[0] <= SUGGESTION_POOL:
                cursor.execute("SELECT name FROM holders")
                return [r[0] for r in cursor.fetchall()]
            out = []
            for pattern in (_like_pattern(query), _prefix_pattern(query[:3]), _prefix_pattern(query[:1])):
                cursor.execute(self._q(f"SELECT name FROM holders WHERE name_fold LIKE ? ESCAPE '\\' "
                                       f"ORDER BY name{self.collate} LIMIT {SUGGESTION_POOL // 2}"), (pattern,))
                out += [r[0] for r in cursor.fetchall()]
                if len(out) >= SUGGESTION_POOL // 2:
                    break
            return list(dict.fromkeys(out))[:SUGGESTION_POOL]

    def with_recordings(self, sha256s: Iterable[str]) -> dict[str, HolderEntry]:
        wanted = sorted(set(sha256s))
        with self._reading() as cursor:
            if cursor is None or not wanted:
                return {}
            names: list[str] = []
            for i in range(0, len(wanted), 500):
                chunk = wanted[i:i + 500]
                cursor.execute(self._q(f"SELECT DISTINCT name FROM recordings WHERE sha256 IN "
                                       f"({', '.join('?' * len(chunk))})"), chunk)
                names += [r[0] for r in cursor.fetchall()]
            return self._documents(cursor, sorted(set(names)))

    def iter_entries(self, batch: int = 500):
        """Every (name, holder) sorted by name, ``batch`` at a time (keyset paging: no OFFSET rescans)."""
        last = None
        while True:
            with self._reading() as cursor:
                if cursor is None:
                    return
                after = "" if last is None else f" WHERE h.name{self.collate} > ?"
                cursor.execute(self._q(f"SELECT h.name, d.document, h.format FROM holders h JOIN documents d ON "
                                       f"d.name = h.name{after} ORDER BY h.name{self.collate} LIMIT {int(batch)}"),
                               () if last is None else (last,))
                rows = cursor.fetchall()
            for name, document, fmt in rows:
                yield name, self._entry(name, document, fmt)
            if len(rows) < batch:
                return
            last = rows[-1][0]

    def export_version(self) -> int:
        """The library file format an export of the whole library needs (the newest any holder needs)."""
        with self._reading() as cursor:
            if cursor is None:
                return 1
            cursor.execute("SELECT MAX(format) FROM holders")
            return int(cursor.fetchone()[0] or 1)

    def check_writable(self) -> None:
        with self._transaction():
            pass


# --------------------------------------------------------------------------- SQLite


class SqliteLibrary(SqlLibrary):
    """The holder library in an SQLite database file (WAL journal, one transaction per change).

    A missing file is an empty library; the first change creates it (with its folders).
    When the file is a ``holders.db`` that does not exist yet and a ``holders.json`` lies
    beside it (the old default library), that JSON library is taken over first: every
    holder copied into the new database in one transaction, the JSON file kept as
    ``holders.json.bak``, and one line on stderr says so.
    """

    kind = "sqlite"

    def __init__(self, location, lock_timeout: float | None = None):
        super().__init__(location, lock_timeout)
        self.path = Path(location).expanduser()
        self._local = threading.local()
        #: What opening the library did that the user should know (the take-over of a JSON library).
        self.notice: str | None = None

    def _connection(self, create: bool):
        """An open, checked connection of this thread and process; None if there is no database and not ``create``."""
        conn = getattr(self._local, "conn", None)
        if conn is not None and self._local.pid == os.getpid():
            return conn
        path = self.path
        if not path.exists():
            self._take_over_json()
        if path.is_dir():
            raise LibraryFormatError(f"{path}: is a folder, not a holder library")
        if not path.exists():
            if not create:
                return None
            try:
                path.parent.mkdir(parents=True, exist_ok=True)
            except OSError as err:
                raise LibraryError(f"{path}: cannot create the folder of the holder library ({err.strerror})") from None
        else:
            self._check_header()
        try:
            conn = sqlite3.connect(str(path), timeout=self.lock_timeout, isolation_level=None,
                                   check_same_thread=False)
        except sqlite3.Error as err:
            raise LibraryError(f"{path}: cannot open the holder library ({err})") from None
        try:
            conn.execute(f"PRAGMA busy_timeout = {int(self.lock_timeout * 1000)}")
            with self._sqlite_errors():
                ready = self._set_up(conn, create)
        except BaseException:
            conn.close()
            raise
        if not ready:
            conn.close()
            return None
        self._local.conn, self._local.pid = conn, os.getpid()
        return conn

    def _set_up(self, conn, create: bool) -> bool:
        """Check (and with ``create`` make) the schema, then WAL; whether the library is ready.

        SQLite answers "locked" at once, without waiting its busy timeout, in a few cases
        (a journal-mode change or a WAL recovery while another process opens the same new
        library): that is retried here until ``lock_timeout`` has passed. Seen once in CI,
        four processes creating one library at once: one failed with "locked" here,
        though each writer holds the lock for milliseconds."""
        deadline = time.monotonic() + self.lock_timeout
        while True:
            try:
                cursor = conn.cursor()
                cursor.execute("BEGIN IMMEDIATE" if create else "BEGIN")
                try:
                    ready = self._check_schema(cursor, create)
                    cursor.execute("COMMIT")
                except BaseException:
                    cursor.execute("ROLLBACK")
                    raise
                # Only now that it is ours (another program's database is never changed):
                # WAL, so readers never wait for the writer; FULL, so a committed change
                # survives a power cut.
                if ready and conn.execute("PRAGMA journal_mode").fetchone()[0].lower() != "wal":
                    conn.execute("PRAGMA journal_mode = WAL")
                conn.execute("PRAGMA synchronous = FULL")
                # A bulk import writes its whole transaction (up to ~1 GB) to the WAL: after
                # the checkpoint the file shrinks back to this size instead of keeping that one.
                conn.execute(f"PRAGMA journal_size_limit = {WAL_LIMIT_BYTES}")
                return ready
            except sqlite3.OperationalError as err:
                text = str(err)
                if not ("locked" in text or "busy" in text) or time.monotonic() > deadline:
                    raise
                time.sleep(0.05)

    def close(self) -> None:
        conn = getattr(self._local, "conn", None)
        if conn is not None and self._local.pid == os.getpid():
            conn.close()
        self._local.conn = None

    def check_writable(self) -> None:
        """A library not made yet: only whether its folder can be written (nothing is created)."""
        from taptune.io.atomic import check_writable

        if self._reading_connection_exists():
            super().check_writable()
        else:
            check_writable(self.path)

    def _reading_connection_exists(self) -> bool:
        with self._reading() as cursor:
            return cursor is not None

    def _check_header(self) -> None:
        try:
            with open(self.path, "rb") as f:
                head = f.read(len(SQLITE_HEADER))
        except OSError as err:
            raise LibraryFormatError(f"{self.path}: cannot read the holder library ({err.strerror})") from None
        if head and head != SQLITE_HEADER:
            raise LibraryFormatError(f"{self.path}: is neither a taptune holder database (SQLite) nor a JSON "
                                     "library; it is left as it is")

    def _existing_tables(self, cursor) -> list[str]:
        cursor.execute("SELECT name FROM sqlite_master WHERE type = 'table' AND name NOT LIKE 'sqlite_%' ORDER BY name")
        return [r[0] for r in cursor.fetchall()]

    def _stored_version(self, cursor) -> int:
        version = super()._stored_version(cursor)
        cursor.execute("PRAGMA user_version")
        user_version = cursor.fetchone()[0]
        if user_version != version:
            raise LibraryFormatError(f"{self.location}: schema version {version} in its table but {user_version} "
                                     "in PRAGMA user_version: the database was changed by another program; "
                                     "it is left as it is")
        return version

    def _set_version(self, cursor) -> None:
        cursor.execute(f"PRAGMA user_version = {SCHEMA_VERSION}")

    @contextmanager
    def _sqlite_errors(self):
        """SQLite's exceptions as one line naming the library."""
        try:
            yield
        except sqlite3.OperationalError as err:
            text = str(err)
            if "locked" in text or "busy" in text:
                raise LibraryError(f"{self.path}: another process has been writing the holder library for more "
                                   f"than {self.lock_timeout:g} s; try again when it has finished") from None
            raise LibraryError(f"{self.path}: cannot use the holder library ({text})") from None
        except sqlite3.DatabaseError as err:
            raise LibraryFormatError(f"{self.path}: is damaged or not a taptune holder library ({err}); "
                                     "it is left as it is") from None

    @contextmanager
    def _reading(self):
        with self._sqlite_errors():
            conn = self._connection(create=False)
            if conn is None:
                yield None
                return
            cursor = conn.cursor()
            try:
                yield cursor
            finally:
                cursor.close()

    @contextmanager
    def _transaction(self):
        with self._sqlite_errors():
            conn = self._connection(create=True)
            cursor = conn.cursor()
            cursor.execute("BEGIN IMMEDIATE")
            try:
                yield _SqlTransaction(self, cursor)
            except BaseException:
                cursor.execute("ROLLBACK")
                raise
            cursor.execute("COMMIT")

    def _take_over_json(self) -> None:
        """Copy the ``holders.json`` beside a new ``holders.db`` into it, once (see the class docstring)."""
        from taptune.library.json_store import JsonLibrary

        old = self.path.with_name(OLD_FILE_NAME)
        if self.path.name != "holders.db" or not old.is_file():
            return
        source = JsonLibrary(old, lock_timeout=self.lock_timeout)
        with source._locked():  # the old library's writers wait; a second taker finds the database made
            if self.path.exists():
                return
            holders = source.entries()  # a broken JSON library raises here: nothing is taken over
            tmp = self.path.with_name(f".{self.path.name}.{os.getpid()}.takeover")
            for leftover in (tmp, tmp.with_name(tmp.name + "-journal")):
                leftover.unlink(missing_ok=True)
            staging = SqliteLibrary(tmp, lock_timeout=self.lock_timeout)
            try:
                with staging._transaction() as tx:
                    for entry in holders.values():
                        tx.store(entry)
                staging._local.conn.execute("PRAGMA wal_checkpoint(TRUNCATE)")
                staging.close()
                for suffix in ("-wal", "-shm"):
                    Path(str(tmp) + suffix).unlink(missing_ok=True)
                os.replace(tmp, self.path)
                fsync_dir(self.path.parent)  # the database is in place before the JSON file moves
            except BaseException:
                staging.close()
                for suffix in ("", "-wal", "-shm"):
                    Path(str(tmp) + suffix).unlink(missing_ok=True)
                raise
            backup = old.with_name(old.name + ".bak")
            os.replace(old, backup)
        self.notice = (f"taptune: took over the holder library {old} ({len(holders)} holders) into {self.path}; "
                       f"the JSON file is kept as {backup}")
        print(self.notice, file=sys.stderr)



# --------------------------------------------------------------------------- PostgreSQL


def redacted(url: str) -> str:
    """``url`` without its password (for every message and the window title)."""
    try:
        parts = urlsplit(url)
    except ValueError:
        return "postgresql://…"
    if parts.password is None:
        return url
    user = parts.username or ""
    host = parts.hostname or ""
    port = f":{parts.port}" if parts.port else ""
    return urlunsplit((parts.scheme, f"{user}:***@{host}{port}", parts.path, parts.query, parts.fragment))


def _pg_reason(err: Exception) -> str:
    """What went wrong connecting, in a few words, from psycopg's (multi-line) message."""
    text = " ".join(str(err).split())
    low = text.lower()
    if "password authentication failed" in low or "no password supplied" in low:
        return "wrong user name or password (the server refused the login)"
    if "does not exist" in low and "database" in low:
        m = re.search(r'database "([^"]+)" does not exist', text)
        return f"no database {m.group(1)!r} on the server" if m else "no such database on the server"
    if "role" in low and "does not exist" in low:
        m = re.search(r'role "([^"]+)" does not exist', text)
        return f"the server has no user {m.group(1)!r}" if m else "no such user on the server"
    if any(s in low for s in ("connection refused", "no such file or directory", "could not translate host",
                              "timeout expired", "network is unreachable", "name or service not known",
                              "could not connect", "connection timed out")):
        return "the server cannot be reached (is it running, and are host and port right?)"
    if "permission denied" in low:
        return "permission denied: " + text[:160]
    return text[:200]


class PostgresLibrary(SqlLibrary):
    """The holder library in a PostgreSQL database that several computers share.

    ``location`` is a libpq URL, ``postgresql://user@host:port/database`` (the password
    best in ``~/.pgpass`` or ``PGPASSWORD``, not in the URL). The database must be empty
    (taptune creates its tables) or one taptune made; psycopg 3 is imported on first use.
    """

    kind = "postgresql"
    placeholder = "%s"
    collate = ' COLLATE "C"'  # code-point order, as Python sorts names
    ddl = {"name_collation": 'COLLATE "C"', "real": "DOUBLE PRECISION", "fold_ops": "text_pattern_ops"}
    connect_timeout_s = 10

    def __init__(self, location, lock_timeout: float | None = None):
        super().__init__(".", lock_timeout)
        self.url = str(location).strip()
        self.path = redacted(self.url)
        self._local = threading.local()
        self._ready = False

    @property
    def target(self):
        return None

    def _psycopg(self):
        try:
            import psycopg
        except ImportError:
            raise LibraryError(f"{self.location}: a PostgreSQL holder library needs psycopg: "
                               "pip install 'taptune[shop]'") from None
        return psycopg

    def _connection(self):
        """This thread's (and process's) open connection to the server."""
        conn = getattr(self._local, "conn", None)
        if conn is not None and self._local.pid == os.getpid() and not conn.closed:
            return conn
        psycopg = self._psycopg()
        try:
            conn = psycopg.connect(self.url, autocommit=True, connect_timeout=self.connect_timeout_s,
                                   application_name="taptune")
        except psycopg.Error as err:
            raise LibraryError(f"{self.location}: cannot open the holder library: {_pg_reason(err)}") from None
        except (ValueError, TypeError) as err:  # a malformed URL
            raise InputError(f"{self.location}: is not a usable PostgreSQL URL ({err})") from None
        self._local.conn, self._local.pid = conn, os.getpid()
        return conn

    def _prepare(self, conn, create: bool) -> None:
        with self._pg_errors(), conn.transaction(), conn.cursor() as cursor:
            if not create:
                # A reader of a library that is there and current takes no lock: it would
                # wait for every writer's transaction (a predict for the whole of another
                # computer's bulk import). Making or migrating the tables takes it below.
                tables = self._existing_tables(cursor)
                if not tables:
                    self._ready = False
                    return
                if META_TABLE in tables and self._stored_version(cursor) == SCHEMA_VERSION:
                    self._ready = True
                    return
            cursor.execute("SELECT pg_advisory_xact_lock(%s)", (PG_LOCK_KEY,))
            self._ready = self._check_schema(cursor, create)

    def close(self) -> None:
        conn = getattr(self._local, "conn", None)
        if conn is not None and self._local.pid == os.getpid():
            conn.close()
        self._local.conn = None

    def _existing_tables(self, cursor) -> list[str]:
        # pg_tables lists every table; information_schema only those this user may use.
        cursor.execute("SELECT tablename FROM pg_tables WHERE schemaname = current_schema() ORDER BY tablename")
        return [r[0] for r in cursor.fetchall()]

    @contextmanager
    def _pg_errors(self):
        psycopg = self._psycopg()
        try:
            yield
        except psycopg.errors.LockNotAvailable:
            raise LibraryError(f"{self.location}: another computer has been writing the holder library for more "
                               f"than {self.lock_timeout:g} s; try again when it has finished") from None
        except psycopg.errors.QueryCanceled:
            raise LibraryError(f"{self.location}: another computer has been writing the holder library for more "
                               f"than {self.lock_timeout:g} s; try again when it has finished") from None
        except psycopg.OperationalError as err:
            self.close()
            raise LibraryError(f"{self.location}: lost the connection to the holder library: {_pg_reason(err)}") from None
        except psycopg.errors.InsufficientPrivilege as err:
            raise LibraryError(f"{self.location}: the server refused: {_pg_reason(err)}") from None
        except psycopg.Error as err:
            raise LibraryError(f"{self.location}: {_pg_reason(err)}") from None

    @contextmanager
    def _reading(self):
        conn = self._connection()
        if not self._ready:
            # No tables yet is an empty library (another computer may make them any time).
            self._prepare(conn, create=False)
            if not self._ready:
                yield None
                return
        with self._pg_errors(), conn.cursor() as cursor:
            yield cursor

    @contextmanager
    def _transaction(self):
        conn = self._connection()
        if not self._ready:
            self._prepare(conn, create=True)
        with self._pg_errors(), conn.transaction(), conn.cursor() as cursor:
            cursor.execute(f"SET LOCAL lock_timeout = '{int(self.lock_timeout * 1000)}ms'")
            cursor.execute("SELECT pg_advisory_xact_lock(%s)", (PG_LOCK_KEY,))
            yield _SqlTransaction(self, cursor)


register("sqlite", SqliteLibrary)
register("postgresql", PostgresLibrary)
