"""The holder library's interface, shared by its three stores (chosen by where the library is).

* ``postgresql://…`` (or ``postgres://…``): a PostgreSQL database a whole shop shares
  (:mod:`taptune.library.sql_store`, psycopg 3 imported on use).
* a ``.json`` file (or an existing file that holds JSON): the JSON library file of
  earlier taptunes, read and written whole under a lock (:mod:`taptune.library.json_store`);
  it still works as before, for small libraries and for exchange.
* any other path: an SQLite database (Python's own ``sqlite3``), the default
  ``holders.db`` in the user data folder (:mod:`taptune.library.sql_store`).

``HolderLibrary(location)`` returns the store for ``location`` (each store module
registers its class: :func:`register`; :mod:`taptune.library.store` imports them all);
every store has the same
methods (:meth:`get`, :meth:`put`, :meth:`update`, :meth:`remove`, :meth:`summaries`,
:meth:`page`, :meth:`export`, :meth:`import_file` …) and the same guarantees: a change is
one transaction (all of it or none), concurrent writers lose nothing, a broken or foreign
library is reported and never overwritten.
"""

from __future__ import annotations

import difflib
import os
import sys
import contextlib
from abc import ABC, abstractmethod
from dataclasses import dataclass
from pathlib import Path
from typing import Callable, Iterable, Iterator

from taptune.errors import LibraryError
from taptune.library.schema import HolderEntry, UnknownHolderError, checked_entry

ENV_VAR = "TAPTUNE_LIBRARY"
FILE_NAME = "holders.db"
#: The default file of taptunes before the database; taken over once into :data:`FILE_NAME`.
OLD_FILE_NAME = "holders.json"
LOCK_TIMEOUT_S = 10.0
URL_SCHEMES = ("postgresql://", "postgres://")
#: At most this many names go through difflib for "did you mean" (the rest is filtered by SQL first).
SUGGESTION_POOL = 2000


def is_server_url(location) -> bool:
    """True for a PostgreSQL connection URL (``postgresql://…`` or ``postgres://…``)."""
    return isinstance(location, str) and location.strip().lower().startswith(URL_SCHEMES)


def default_library_path(arg: str | os.PathLike | None = None) -> Path | str:
    """Where the holder library lives: ``arg`` (``--library``), else ``$TAPTUNE_LIBRARY``, else the user data folder.

    A PostgreSQL URL is returned as it is (a ``str``); a file as a :class:`~pathlib.Path`.
    The user data folder is ``$XDG_DATA_HOME/taptune`` (default ``~/.local/share/taptune``)
    on Linux and other Unix systems, ``~/Library/Application Support/taptune`` on macOS and
    ``%APPDATA%\\taptune`` on Windows; the file in it is ``holders.db``.
    """
    if arg:
        return str(arg).strip() if is_server_url(str(arg)) else Path(arg).expanduser()
    env = os.environ.get(ENV_VAR, "").strip()
    if env:
        return env if is_server_url(env) else Path(env).expanduser()
    return _user_data_dir() / "taptune" / FILE_NAME


def _user_data_dir() -> Path:
    home = Path.home()
    if sys.platform == "win32":
        appdata = os.environ.get("APPDATA", "")
        return Path(appdata) if appdata else home / "AppData" / "Roaming"
    if sys.platform == "darwin":
        return home / "Library" / "Application Support"
    xdg = os.environ.get("XDG_DATA_HOME", "")
    # The XDG spec says a relative value is invalid and must be ignored.
    return Path(xdg) if xdg and os.path.isabs(xdg) else home / ".local" / "share"


def library_files(location) -> list[Path]:
    """The files of a file library (the database and its journal files, or the JSON file and
    its lock); none for a server. Outputs must never land on one of them."""
    if is_server_url(str(location)):
        return []
    path = Path(location)
    return [path] + [path.with_name(path.name + s) for s in ("-wal", "-shm", "-journal", ".lock")]


def _is_json_file(path: Path) -> bool:
    """Whether ``path`` is meant as a JSON library: a ``.json`` name, or a file whose first byte opens JSON."""
    if path.suffix.lower() == ".json":
        return True
    try:
        with open(path, "rb") as f:
            head = f.read(64).lstrip()
    except OSError:
        return False
    return head[:1] == b"{" or head.startswith(b"\xef\xbb\xbf{")


# --------------------------------------------------------------------------- summaries


@dataclass(frozen=True)
class HolderSummary:
    """One line of the holder list: what ``library list`` and the app's table show.

    Read without the holder's history (a database keeps these columns beside each holder).
    """

    name: str
    interface: str
    k_tt: float
    k_rr: float
    identifications: int
    last_identified: str | None
    checks: int
    last_checked: str | None
    last_verdict: str | None
    warnings: tuple[str, ...] = ()

    @classmethod
    def of(cls, entry: HolderEntry) -> "HolderSummary":
        last = entry.checks[-1] if entry.checks else None
        return cls(entry.name, entry.interface, entry.params.k_tt, entry.params.k_rr, len(entry.identifications),
                   entry.last_identified, len(entry.checks), last.date if last else None,
                   last.verdict if last else None, tuple(entry.warnings))

    def to_dict(self) -> dict:
        return {"name": self.name, "interface": self.interface, "k_tt": self.k_tt, "k_rr": self.k_rr,
                "identifications": self.identifications, "last_identified": self.last_identified,
                "checks": self.checks, "last_checked": self.last_checked, "last_verdict": self.last_verdict}


def matches(name: str, match: str | None) -> bool:
    """Whether ``name`` contains ``match`` (case-insensitive); everything matches no ``match``."""
    return not match or match.casefold() in name.casefold()


def suggestions(query: str, names: Iterable[str]) -> list[str]:
    """Up to three names close to ``query``: containing it, similar, or starting similarly."""
    names = sorted(set(names))
    lowered = {n.lower(): n for n in names}
    q = query.lower()
    close = [n for n in names if q in n.lower()]
    close += [lowered[n] for n in difflib.get_close_matches(q, list(lowered), n=3, cutoff=0.5)]
    # Users often type only the start of a long name ("ER32" for "ER32 collet chuck …").
    close += [n for n in names if difflib.SequenceMatcher(None, q, n.lower()[: len(q)]).ratio() >= 0.6]
    return list(dict.fromkeys(close))[:3]


# --------------------------------------------------------------------------- the library


class Transaction(ABC):
    """What a store gives a change while it holds the library's write lock (see :meth:`HolderLibrary._transaction`)."""

    @abstractmethod
    def load(self, name: str) -> HolderEntry | None:
        """The holder called ``name`` as stored now, or None."""

    def load_many(self, names: list[str]) -> dict[str, HolderEntry]:
        return {n: e for n in names if (e := self.load(n)) is not None}

    @abstractmethod
    def store(self, entry: HolderEntry, document: str | None = None) -> None:
        """Write ``entry``. ``document``: its JSON when the caller has it already, as text that
        decodes to what ``entry`` was checked from (a bulk import spares the encoding)."""

    @abstractmethod
    def delete(self, name: str) -> None:
        """Remove the holder called ``name``."""


class HolderLibrary(ABC):
    """The holder library at ``location`` (a file path or a PostgreSQL URL).

    Parameters
    ----------
    location : str or path-like
        ``postgresql://…`` for a server, a ``.json`` file for a JSON library, any other
        path for an SQLite database (a missing one is an empty library, created with its
        folders on the first write).
    lock_timeout : float, optional
        Seconds a change waits for another writer (default :data:`LOCK_TIMEOUT_S`) before
        giving up with a :class:`~taptune.errors.LibraryError`.

    Calling ``HolderLibrary(location)`` returns the store class for ``location``
    (:class:`~taptune.library.json_store.JsonLibrary`,
    :class:`~taptune.library.sql_store.SqliteLibrary` or
    :class:`~taptune.library.sql_store.PostgresLibrary`).
    """

    #: "json", "sqlite" or "postgresql".
    kind = ""

    def __new__(cls, location=None, lock_timeout: float | None = None):
        if cls is HolderLibrary:
            cls = _STORES[store_kind(location)]
        return super().__new__(cls)

    def __init__(self, location, lock_timeout: float | None = None):
        # The module attribute at call time, so tests can shorten it.
        self.lock_timeout = float(sys.modules[__name__].LOCK_TIMEOUT_S if lock_timeout is None else lock_timeout)
        self.path = Path(location)

    def __repr__(self) -> str:
        return f"{type(self).__name__}({str(self.path)!r})"

    @property
    def location(self) -> str:
        """The library as shown to the user (a server URL without its password)."""
        return str(self.path)

    @property
    def target(self) -> Path | None:
        """The library's file with symbolic links resolved; None for a server."""
        return Path(os.path.realpath(self.path))

    def close(self) -> None:
        """Close open connections (a later call opens them again)."""

    # ---- reading: every store implements these

    @abstractmethod
    def _load(self, name: str) -> HolderEntry | None:
        """The holder called ``name``, or None when there is none."""

    @abstractmethod
    def summaries(self, match: str | None = None, limit: int | None = None, offset: int = 0) -> list[HolderSummary]:
        """The holders whose name contains ``match`` (case-insensitive), sorted by name, without their history."""

    @abstractmethod
    def count(self, match: str | None = None) -> int:
        """How many holders' names contain ``match`` (all without one)."""

    @abstractmethod
    def page(self, match: str | None = None, limit: int | None = None, offset: int = 0) -> dict[str, HolderEntry]:
        """Whole holders (with history) whose name contains ``match``, sorted by name: ``limit`` from ``offset``."""

    @abstractmethod
    def _candidates(self, query: str) -> list[str]:
        """A bounded set of names worth comparing with ``query`` (for "did you mean")."""

    @abstractmethod
    def with_recordings(self, sha256s: Iterable[str]) -> dict[str, HolderEntry]:
        """The holders whose identifications include one of these recordings (by SHA-256)."""

    @abstractmethod
    def _transaction(self) -> contextlib.AbstractContextManager[Transaction]:
        """Hold the library's write lock; yield a :class:`Transaction`; commit when the block ends
        normally, write nothing when it raises (a ``contextmanager`` in every store)."""

    @abstractmethod
    def check_writable(self) -> None:
        """Raise a one-line error now if the library cannot be read or changed (before a long fit)."""

    # ---- reading: shared

    def get(self, name: str) -> HolderEntry:
        """The holder called ``name``; :class:`UnknownHolderError` (with close matches) if none."""
        entry = self._load(name)
        if entry is None:
            raise self._unknown(name)
        return entry

    def __contains__(self, name: str) -> bool:
        return self._load(name) is not None

    def __len__(self) -> int:
        return self.count()

    def names(self, match: str | None = None, limit: int | None = None) -> list[str]:
        """Holder names (containing ``match``), sorted."""
        return [s.name for s in self.summaries(match, limit)]

    def entries(self) -> dict[str, HolderEntry]:
        """Every holder by name, sorted. Loads the whole library: use :meth:`page`, :meth:`summaries`
        or :meth:`iter_entries` where it may be large."""
        return dict(self.iter_entries())

    def iter_entries(self, batch: int = 500) -> Iterator[tuple[str, HolderEntry]]:
        """Every (name, holder), sorted by name, read ``batch`` holders at a time."""
        offset = 0
        while True:
            chunk = self.page(limit=batch, offset=offset)
            yield from chunk.items()
            if len(chunk) < batch:
                return
            offset += batch

    def _unknown(self, name: str) -> UnknownHolderError:
        pool = self._candidates(name)
        close = suggestions(name, pool)
        if close:
            hint = "did you mean " + " or ".join(repr(n) for n in close) + "?"
        else:
            first = self.names(limit=6)
            if first:
                shown = ", ".join(repr(n) for n in first[:5]) + (", …" if len(first) > 5 else "")
                hint = f"it holds {shown}"
            else:
                hint = "the library is empty"
        return UnknownHolderError(f"{self.location}: no holder {name!r} in the library; {hint}", name, tuple(close))

    # ---- writing: shared

    def put(self, entry: HolderEntry) -> HolderEntry:
        """Add or update a holder; returns the entry as stored.

        An existing holder of the same name takes ``entry``'s parameters, uncertainty set,
        geometry and model options; its history (identifications, checks, and whatever
        else the entry keeps) stays and ``entry``'s new records are appended — even when
        another process wrote in between. ``entry`` is validated first; an invalid one
        raises LibraryFormatError naming the key and writes nothing.
        """
        entry = checked_entry(entry, f"{self.location}: new entry for holder {getattr(entry, 'name', '?')!r}")
        with self._transaction() as tx:
            old = tx.load(entry.name)
            stored = entry if old is None else entry.superseding(old)
            tx.store(stored)
        return stored

    def update(self, name: str, fn: Callable[[HolderEntry], HolderEntry]) -> HolderEntry:
        """Change holder ``name`` in one read-modify-write transaction; returns it as stored.

        ``fn`` gets the holder as it is now (under the write lock) and returns the new
        entry (same name); nothing is written if it raises.
        UnknownHolderError if there is no such holder; LibraryFormatError if the new
        entry is invalid (nothing written).
        """
        with self._transaction() as tx:
            old = tx.load(name)
            if old is None:
                raise self._unknown(name)
            new = fn(old)
            if getattr(new, "name", None) != name:
                raise LibraryError(f"{self.location}: an update of holder {name!r} must keep its name, "
                                   f"got {getattr(new, 'name', new)!r}; nothing was changed")
            new = checked_entry(new, f"{self.location}: holder {name!r}")
            if new != old:
                tx.store(new)
        return new

    def remove(self, name: str) -> HolderEntry:
        """Delete the holder called ``name``; returns it. UnknownHolderError if absent."""
        with self._transaction() as tx:
            old = tx.load(name)
            if old is None:
                raise self._unknown(name)
            tx.delete(name)
        return old

    # ---- exchange (see taptune.library.exchange)

    def export(self, out: str | os.PathLike, format: str = "json") -> int:
        """Write the library to ``out`` as JSON (the library file format) or CSV; returns the holder count."""
        from taptune.library.exchange import export_library

        return export_library(self, out, format)

    def import_file(self, file: str | os.PathLike, replace: bool = False):
        """Merge a library file into this one; returns an :class:`~taptune.library.exchange.ImportReport`."""
        from taptune.library.exchange import import_library

        return import_library(self, file, replace=replace)


#: The store class of each kind, filled by the store modules (:func:`register`).
_STORES: dict[str, type] = {}


def register(kind: str, cls: type) -> None:
    """Make ``cls`` the store of libraries of ``kind`` (see :func:`store_kind`)."""
    _STORES[kind] = cls


def store_kind(location) -> str:
    """``"postgresql"`` for a server URL, ``"json"`` for a JSON library file, else ``"sqlite"``."""
    if location is None or str(location).strip() == "":
        raise LibraryError("no holder library given")
    if is_server_url(str(location)):
        return "postgresql"
    return "json" if _is_json_file(Path(location).expanduser()) else "sqlite"
