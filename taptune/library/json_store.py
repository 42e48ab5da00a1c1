"""The JSON holder library: one file, atomic writes, a lock around every change.

The library format of taptunes before the database, still used for a ``.json`` path
(:class:`~taptune.library.store.HolderLibrary` chooses it): every read validates the
whole file, every change rewrites it. Fine for a few hundred holders and for exchange;
a large library belongs in a database (``taptune library import holders.json --library holders.db``).

Readers never lock: every write replaces the file atomically (:mod:`taptune.io.atomic`:
temporary file in the same folder, fsync, :func:`os.replace`, fsync of the folder), so a
reader sees the old or the new library, never half of one, and a crash mid-write leaves the old file intact.
Writers take an exclusive lock on a sidecar ``<library>.lock`` file and re-read the
library under it, so two processes adding holders at the same time keep both. A library
file that does not validate is reported and never overwritten.
"""

from __future__ import annotations

import errno
import os
import sys
import time
from contextlib import contextmanager
from pathlib import Path
from typing import Iterable, Iterator

from taptune.errors import LibraryError
from taptune.io.atomic import atomic_write_bytes, check_writable, remove_stale_temporaries
from taptune.library.schema import HolderEntry, encode
from taptune.library.base import HolderLibrary, HolderSummary, Transaction, matches, register

_LOCK_POLL_S = 0.02

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


class _DictTransaction(Transaction):
    def __init__(self, holders: dict):
        self.holders = holders

    def load(self, name):
        return self.holders.get(name)

    def store(self, entry, document=None):
        self.holders[entry.name] = entry

    def delete(self, name):
        del self.holders[name]


class JsonLibrary(HolderLibrary):
    """The holder library stored in one JSON file at ``path``.

    Parameters
    ----------
    path : str or path-like
        The library file; a missing file is an empty library (created, with its
        folders, on the first write).
    lock_timeout : float, optional
        Seconds a write waits for another process's lock before giving up with a
        :class:`~taptune.errors.LibraryError`.

    Every read validates the whole file (:class:`LibraryFormatError` names the file, the
    holder and the key). Every change runs under the lock on a fresh read of the file
    and replaces it atomically.
    """

    kind = "json"

    @property
    def lock_path(self) -> Path:
        """The sidecar lock file, beside the real library file (one lock whatever the link)."""
        target = self.target
        return target.with_name(target.name + ".lock")

    # ---- reading

    def _read(self) -> dict[str, HolderEntry]:
        from taptune.library.exchange import read_library_file  # not loaded for a database library

        return read_library_file(self.path, missing_ok=True)

    def entries(self) -> dict[str, HolderEntry]:
        """All holders by name, sorted by name (a fresh, validated read of the file)."""
        holders = self._read()
        return {name: holders[name] for name in sorted(holders)}

    def _load(self, name: str) -> HolderEntry | None:
        return self._read().get(name)

    def page(self, match=None, limit=None, offset=0) -> dict[str, HolderEntry]:
        chosen = [(n, e) for n, e in self.entries().items() if matches(n, match)]
        return dict(chosen[offset:None if limit is None else offset + limit])

    def iter_entries(self, batch: int = 500):
        yield from self.entries().items()

    def summaries(self, match=None, limit=None, offset=0) -> list[HolderSummary]:
        return [HolderSummary.of(e) for e in self.page(match, limit, offset).values()]

    def count(self, match=None) -> int:
        return sum(matches(n, match) for n in self._read())

    def _candidates(self, query: str) -> list[str]:
        return list(self._read())

    def with_recordings(self, sha256s: Iterable[str]) -> dict[str, HolderEntry]:
        wanted = set(sha256s)
        return {n: e for n, e in self.entries().items() if any(r.sha256 in wanted for r in e.identifications)}

    def check_writable(self) -> None:
        self._read()
        check_writable(self.path)

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

    @contextmanager
    def _transaction(self):
        with self.edit() as holders:
            yield _DictTransaction(holders)


register("json", JsonLibrary)
