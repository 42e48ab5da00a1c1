"""The holder library on disk: one JSON file, atomic writes, a lock around every change.

Readers never lock: every write replaces the file atomically (:mod:`taptune.io.atomic`:
temporary file in the same folder, fsync, :func:`os.replace`, fsync of the folder), so a
reader sees the old or the new library, never half of one, and a crash mid-write leaves the old file intact.
Writers take an exclusive lock on a sidecar ``<library>.lock`` file and re-read the
library under it, so two processes adding holders at the same time keep both. A library
file that does not validate is reported and never overwritten.
"""

from __future__ import annotations

import difflib
import errno
import os
import sys
import time
from contextlib import contextmanager
from pathlib import Path
from typing import Iterator

from taptune.errors import LibraryError
from taptune.io.atomic import atomic_write_bytes, remove_stale_temporaries
from taptune.library.exchange import ImportReport, export_library, import_library, read_library_file
from taptune.library.schema import HolderEntry, UnknownHolderError, checked_entry, encode

ENV_VAR = "TAPTUNE_LIBRARY"
FILE_NAME = "holders.json"
LOCK_TIMEOUT_S = 10.0
_LOCK_POLL_S = 0.02


def default_library_path(arg: str | os.PathLike | None = None) -> Path:
    """Where the holder library lives: ``arg`` (``--library``), else ``$TAPTUNE_LIBRARY``, else the user data folder.

    The user data folder is ``$XDG_DATA_HOME/taptune`` (default ``~/.local/share/taptune``)
    on Linux and other Unix systems, ``~/Library/Application Support/taptune`` on macOS and
    ``%APPDATA%\\taptune`` on Windows; the file in it is ``holders.json``.
    """
    if arg:
        return Path(arg).expanduser()
    env = os.environ.get(ENV_VAR, "").strip()
    if env:
        return Path(env).expanduser()
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


# --------------------------------------------------------------------------- lock


def _try_lock(fd: int) -> bool:
    """Take the exclusive lock on ``fd`` without waiting; False if another holder has it."""
    try:
        if sys.platform == "win32":
            import msvcrt

            msvcrt.locking(fd, msvcrt.LK_NBLCK, 1)
        else:
            import fcntl

            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except OSError as err:
        if err.errno in (errno.EAGAIN, errno.EACCES, errno.EWOULDBLOCK, errno.EDEADLK):
            return False
        raise
    return True


def _unlock(fd: int) -> None:
    if sys.platform == "win32":
        import msvcrt

        os.lseek(fd, 0, os.SEEK_SET)
        msvcrt.locking(fd, msvcrt.LK_UNLCK, 1)
    else:
        import fcntl

        fcntl.flock(fd, fcntl.LOCK_UN)


# --------------------------------------------------------------------------- library


class HolderLibrary:
    """The holder library stored in one JSON file at ``path``.

    Parameters
    ----------
    path : str or path-like
        The library file; a missing file is an empty library (created, with its
        folders, on the first write).
    lock_timeout : float, optional
        Seconds a write waits for another process's lock (default :data:`LOCK_TIMEOUT_S`)
        before giving up with a :class:`~taptune.errors.LibraryError`.

    Every read validates the whole file (:class:`LibraryFormatError` names the file, the
    holder and the key). Every change (:meth:`put`, :meth:`remove`, :meth:`edit`) runs
    under the lock on a fresh read of the file and replaces it atomically.
    """

    def __init__(self, path: str | os.PathLike, lock_timeout: float | None = None):
        self.path = Path(path)
        self.lock_timeout = float(LOCK_TIMEOUT_S if lock_timeout is None else lock_timeout)

    @property
    def target(self) -> Path:
        """The file that is really written: ``path`` with symbolic links resolved.

        Replacing a symbolic link would turn it into a plain file and silently detach the
        library from wherever the link pointed (a shared or synced folder).
        """
        return Path(os.path.realpath(self.path))

    @property
    def lock_path(self) -> Path:
        """The sidecar lock file, beside the real library file (one lock whatever the link)."""
        target = self.target
        return target.with_name(target.name + ".lock")

    def __repr__(self) -> str:
        return f"HolderLibrary({str(self.path)!r})"

    # ---- reading

    def _read(self) -> dict[str, HolderEntry]:
        return read_library_file(self.path, missing_ok=True)

    def entries(self) -> dict[str, HolderEntry]:
        """All holders by name, sorted by name (a fresh, validated read of the file)."""
        holders = self._read()
        return {name: holders[name] for name in sorted(holders)}

    def names(self) -> list[str]:
        """Holder names, sorted."""
        return sorted(self._read())

    def __contains__(self, name: str) -> bool:
        return name in self._read()

    def __len__(self) -> int:
        return len(self._read())

    def get(self, name: str) -> HolderEntry:
        """The holder called ``name``; :class:`UnknownHolderError` (with close matches) if none."""
        holders = self._read()
        if name not in holders:
            raise self._unknown(name, holders)
        return holders[name]

    def _unknown(self, name: str, holders: dict) -> UnknownHolderError:
        names = sorted(holders)
        lowered = {n.lower(): n for n in names}
        query = name.lower()
        close = [n for n in names if query in n.lower()]
        close += [lowered[n] for n in difflib.get_close_matches(query, list(lowered), n=3, cutoff=0.5)]
        # Users often type only the start of a long name ("ER32" for "ER32 collet chuck …").
        close += [n for n in names if difflib.SequenceMatcher(None, query, n.lower()[: len(query)]).ratio() >= 0.6]
        close = list(dict.fromkeys(close))[:3]
        if close:
            hint = "did you mean " + " or ".join(repr(n) for n in close) + "?"
        elif names:
            shown = ", ".join(repr(n) for n in names[:5]) + (", …" if len(names) > 5 else "")
            hint = f"it holds {shown}"
        else:
            hint = "the library is empty"
        message = f"{self.path}: no holder {name!r} in the library; {hint}"
        return UnknownHolderError(message, name, tuple(close))

    # ---- writing

    @contextmanager
    def _locked(self) -> Iterator[None]:
        """Hold the exclusive library lock (waits up to ``lock_timeout`` seconds)."""
        lock_path = self.lock_path
        try:
            lock_path.parent.mkdir(parents=True, exist_ok=True)
            fd = os.open(lock_path, os.O_RDWR | os.O_CREAT, 0o666)
        except OSError as err:
            raise LibraryError(f"{self.path}: cannot create the lock file {lock_path} ({err.strerror})") from None
        try:
            deadline = time.monotonic() + self.lock_timeout
            while not _try_lock(fd):
                if time.monotonic() >= deadline:
                    raise LibraryError(
                        f"{self.path}: another process has held the library lock ({lock_path}) "
                        f"for more than {self.lock_timeout:g} s; try again when it has finished"
                    )
                time.sleep(_LOCK_POLL_S)
            try:
                yield
            finally:
                _unlock(fd)
        finally:
            os.close(fd)

    @contextmanager
    def edit(self) -> Iterator[dict[str, HolderEntry]]:
        """Change the library in one locked read-modify-write.

        Yields a dict of the entries as they are on disk now; add, replace or delete
        entries in it. When the block ends normally and something changed, the library is
        replaced atomically; an exception in the block writes nothing. A broken library
        file raises before the block runs and is never overwritten.
        """
        with self._locked():
            current = self._read()
            draft = dict(current)
            yield draft
            if draft != current:
                raw = encode(draft, str(self.path))
                try:
                    # Only library writers make these files, and they hold the lock while
                    # they exist: any found now belong to a writer that was killed.
                    remove_stale_temporaries(self.target)
                    atomic_write_bytes(self.target, raw)
                except OSError as err:
                    raise LibraryError(
                        f"{self.path}: cannot write the holder library ({err.strerror}); it was not changed"
                    ) from None

    def put(self, entry: HolderEntry) -> HolderEntry:
        """Add or update a holder; returns the entry as stored.

        An existing holder of the same name takes ``entry``'s parameters, uncertainty set,
        geometry and model options; its identification history is kept and ``entry``'s
        new records are appended (a re-identification never loses the history, even when
        another process wrote in between). ``entry`` is validated first; an invalid one
        raises LibraryFormatError naming the key and writes nothing.
        """
        entry = checked_entry(entry, f"{self.path}: new entry for holder {getattr(entry, 'name', '?')!r}")
        with self.edit() as holders:
            old = holders.get(entry.name)
            stored = entry if old is None else entry.superseding(old)
            holders[entry.name] = stored
        return stored

    def update(self, name: str, fn) -> HolderEntry:
        """Replace the holder called ``name`` by ``fn(entry)`` in one locked read-modify-write; returns it.

        ``fn`` gets the entry as it is on disk now (another process's change made in
        between is kept) and returns the new entry of the same name. UnknownHolderError if
        absent; nothing is written when ``fn`` raises.
        """
        with self.edit() as holders:
            if name not in holders:
                raise self._unknown(name, holders)
            new = checked_entry(fn(holders[name]), f"{self.path}: holder {name!r}")
            if new.name != name:
                raise LibraryError(f"{self.path}: updating holder {name!r} must keep its name, got {new.name!r}")
            holders[name] = new
        return new

    def remove(self, name: str) -> HolderEntry:
        """Delete the holder called ``name``; returns it. UnknownHolderError if absent."""
        with self.edit() as holders:
            if name not in holders:
                raise self._unknown(name, holders)
            return holders.pop(name)

    # ---- exchange (see taptune.library.exchange)

    def export(self, out: str | os.PathLike, format: str = "json") -> int:
        """Write the library to ``out`` as JSON (the library format) or CSV; returns the holder count."""
        return export_library(self, out, format)

    def import_file(self, file: str | os.PathLike, replace: bool = False) -> ImportReport:
        """Merge a library file into this one; returns an :class:`~taptune.library.exchange.ImportReport`."""
        return import_library(self, file, replace=replace)
