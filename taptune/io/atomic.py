"""Files that are either wholly old or wholly new: write beside, fsync, rename, fsync the folder.

Every file taptune writes for the user (holder library, JSON results, CSV and PDF
reports, recordings) goes through :func:`atomic_write`, so a reader never sees half a
file and a crash mid-write leaves the previous file intact.
"""

from __future__ import annotations

import glob
import os
import secrets
import signal
import stat
import sys
import threading
from pathlib import Path
from typing import Callable

from taptune.errors import InputError, InterruptedAfterWrite


def fsync_dir(folder: Path) -> None:
    """Make a rename in ``folder`` durable (POSIX); Windows has no directory handles to sync."""
    if sys.platform == "win32":
        return
    fd = os.open(folder, os.O_RDONLY)
    try:
        os.fsync(fd)
    finally:
        os.close(fd)


def atomic_write(path: str | os.PathLike, write: Callable[[Path], None]) -> None:
    """Create or replace ``path`` atomically with what ``write(tmp_path)`` puts into an empty file.

    The temporary file sits in the same folder (so the rename cannot cross file systems),
    is fsynced before :func:`os.replace`, and the folder is fsynced after it. If anything
    fails, the temporary file is removed and ``path`` is untouched. Parent folders are
    created. The new file keeps the old one's permissions.
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(f"{_tmp_prefix(path)}{os.getpid()}.{secrets.token_hex(4)}.tmp")
    # os.open applies the umask to 0o666, as a plain open() of a new file would.
    os.close(os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o666))
    try:
        write(tmp)
        fd = os.open(tmp, os.O_RDWR)
        try:
            os.fsync(fd)
        finally:
            os.close(fd)
        if path.exists():
            os.chmod(tmp, stat.S_IMODE(path.stat().st_mode))
        held = _hold_interrupts()
        try:
            os.replace(tmp, path)
        except BaseException:
            _release_interrupts(held, None)
            raise
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise
    try:
        fsync_dir(path.parent)
    finally:
        _release_interrupts(held, path)


def _hold_interrupts():
    """Hold Ctrl-C while a file is put in place: (previous SIGINT handler, caught list), or
    None off the main thread (only it may set handlers; Python runs them there, whichever
    thread the signal reached).

    A Ctrl-C that lands just after the rename would otherwise report "interrupted" for a
    change that was made (a large library's write).
    """
    if threading.current_thread() is not threading.main_thread():
        return None
    caught: list[bool] = []
    return signal.signal(signal.SIGINT, lambda *_: caught.append(True)), caught


def _release_interrupts(held, written) -> None:
    """Restore the SIGINT handler; a Ctrl-C that arrived meanwhile is raised as
    :class:`InterruptedAfterWrite` when ``written`` (the file is in place), else as the
    KeyboardInterrupt it was; a handler of the program's own gets it instead."""
    if held is None:
        return
    previous, caught = held
    signal.signal(signal.SIGINT, signal.SIG_DFL if previous is None else previous)
    if not caught:
        return
    if previous is not signal.default_int_handler:
        signal.raise_signal(signal.SIGINT)
        return
    raise InterruptedAfterWrite(written) if written is not None else KeyboardInterrupt()


def check_writable(path: str | Path) -> None:
    """Refuse, without creating anything, a file that could not be written later.

    The nearest existing folder on the way to ``path`` must be a folder this user may
    write into (the missing ones below it are created with the first write).

    Raises
    ------
    InputError
        ``path`` is a folder, or sits under a file or a folder that cannot be written.
    """
    path = Path(path).expanduser()
    if path.is_dir():
        raise InputError(f"{path}: is a folder; give a file name")
    folder = path.absolute().parent
    while not folder.exists() and folder != folder.parent:
        folder = folder.parent
    if not folder.is_dir():
        raise InputError(f"{path}: cannot be written ({folder} is a file, not a folder)")
    if not os.access(folder, os.W_OK | os.X_OK):
        raise InputError(f"{path}: cannot be written (no permission to write into {folder})")


def atomic_write_bytes(path: str | os.PathLike, data: bytes) -> None:
    """Create or replace ``path`` atomically with ``data`` (see :func:`atomic_write`)."""

    def write(tmp: Path) -> None:
        with open(tmp, "wb") as f:
            f.write(data)
            f.flush()

    atomic_write(path, write)


def _tmp_prefix(path: Path) -> str:
    return f".{path.name}."


def remove_stale_temporaries(path: str | os.PathLike) -> None:
    """Delete temporary files a killed writer of ``path`` left behind.

    Only safe while holding a lock that every writer of ``path`` takes (the holder
    library's); otherwise a live writer's temporary file could be removed.
    """
    path = Path(path)
    for stale in path.parent.glob(f"{glob.escape(_tmp_prefix(path))}*.tmp"):
        stale.unlink(missing_ok=True)
