"""A folder of re-computable arrays: what a fresh process would otherwise rebuild.

The reduced model of an assembly costs a third of a second to build, and a user taps the
same assembly again and again, often one ``taptune identify`` per tap. Its arrays are
kept here between processes, keyed by a hash of everything they are computed from.

Nothing in the cache is user data: a missing, unreadable, foreign or corrupt entry is
rebuilt and replaced, an unwritable folder only means nothing is kept. The folder is
``$TAPTUNE_CACHE_DIR`` (``off`` turns the cache off), else the user cache folder:
``$XDG_CACHE_HOME/taptune`` (default ``~/.cache/taptune``) on Linux and other Unix
systems, ``~/Library/Caches/taptune`` on macOS, ``%LOCALAPPDATA%\\taptune\\cache`` on
Windows. It holds at most :data:`MAX_ENTRIES` entries (the least recently used go).
"""

from __future__ import annotations

import hashlib
import os
import sys
import zipfile
from pathlib import Path

import numpy as np

ENV_VAR = "TAPTUNE_CACHE_DIR"
# About 2.5 MB each (a reduced model): at most 40 MB.
MAX_ENTRIES = 16


def cache_dir() -> Path | None:
    """The cache folder (see the module docstring); None when ``$TAPTUNE_CACHE_DIR`` is ``off``."""
    env = os.environ.get(ENV_VAR, "").strip()
    if env.lower() == "off":
        return None
    if env:
        return Path(env).expanduser()
    home = Path.home()
    if sys.platform == "win32":
        local = os.environ.get("LOCALAPPDATA", "")
        return (Path(local) if local else home / "AppData" / "Local") / "taptune" / "cache"
    if sys.platform == "darwin":
        return home / "Library" / "Caches" / "taptune"
    xdg = os.environ.get("XDG_CACHE_HOME", "")
    # The XDG spec says a relative value is invalid and must be ignored.
    return (Path(xdg) if xdg and os.path.isabs(xdg) else home / ".cache") / "taptune"


def digest(*parts) -> str:
    """Hex SHA-256 of ``parts``: arrays by dtype, shape and bytes, anything else by ``repr``."""
    h = hashlib.sha256()
    for part in parts:
        if isinstance(part, np.ndarray):
            a = np.ascontiguousarray(part)
            h.update(f"{a.dtype.str}{a.shape}".encode())
            h.update(a.tobytes())
        else:
            h.update(repr(part).encode())
        h.update(b"\x00")
    return h.hexdigest()


# An entry's file name: what the cache may prune in a folder it shares with other files.
_ENTRY = "*-" + "[0-9a-f]" * 40 + ".npz"


def _path(kind: str, key: str) -> Path | None:
    try:
        folder = cache_dir()
    except (RuntimeError, OSError):  # no home folder to find: nothing is kept
        return None
    return None if folder is None else folder / f"{kind}-{key[:40]}.npz"


def load_arrays(kind: str, key: str) -> dict[str, np.ndarray] | None:
    """The arrays stored under ``key`` (see :func:`save_arrays`), or None.

    None also for an entry that cannot be read or whose stored key differs (a corrupt
    or foreign file): the caller rebuilds and saves over it.
    """
    path = _path(kind, key)
    if path is None:
        return None
    try:  # a missing file, a folder in its place or no permission: OSError
        with np.load(path, allow_pickle=False) as z:
            arrays = {name: z[name] for name in z.files}
    except (OSError, ValueError, KeyError, EOFError, zipfile.BadZipFile):
        return None
    if str(arrays.pop("_key", "")) != key:
        return None
    try:
        os.utime(path)  # recently used: pruned last
    except OSError:
        pass  # a read-only cache still serves
    return arrays


def save_arrays(kind: str, key: str, arrays: dict[str, np.ndarray]) -> bool:
    """Keep ``arrays`` under ``key``; False when the folder cannot take them (nothing kept).

    Written beside and renamed (:func:`taptune.io.atomic.atomic_write`), so a reader sees
    the whole entry or none; then the oldest entries beyond :data:`MAX_ENTRIES` are removed.
    """
    from taptune.io.atomic import atomic_write

    path = _path(kind, key)
    if path is None:
        return False

    def write(tmp: Path) -> None:
        with open(tmp, "wb") as f:  # a file object: given a name, np.savez would append ".npz"
            np.savez(f, _key=np.array(key), **arrays)

    try:
        atomic_write(path, write)  # an interrupted write leaves no temporary file behind
    except OSError:
        return False
    _prune(path.parent)
    return True


def _prune(folder: Path) -> None:
    try:
        # Only the cache's own entries: the folder may be one the user keeps other files in.
        entries = sorted(folder.glob(_ENTRY), key=lambda p: p.stat().st_mtime, reverse=True)
        for old in entries[MAX_ENTRIES:]:
            old.unlink(missing_ok=True)
    except OSError:
        pass  # another process pruned first
