"""Atomic file writing: the file is wholly old or wholly new, never half of either."""

import os
import signal
import stat

import pytest

from taptune.io.atomic import atomic_write, atomic_write_bytes, remove_stale_temporaries


def test_a_failed_write_leaves_the_old_file_and_no_temporary(tmp_path):
    path = tmp_path / "out.json"
    path.write_bytes(b"old")

    def half_then_fail(tmp):
        tmp.write_bytes(b"half")
        raise RuntimeError("disk full")

    with pytest.raises(RuntimeError):
        atomic_write(path, half_then_fail)
    assert path.read_bytes() == b"old"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out.json"]


def test_replacing_keeps_permissions_and_creates_folders(tmp_path):
    path = tmp_path / "a" / "b" / "out.csv"
    atomic_write_bytes(path, b"one")
    os.chmod(path, 0o600)
    atomic_write_bytes(path, b"two")
    assert path.read_bytes() == b"two"
    assert stat.S_IMODE(path.stat().st_mode) == 0o600


def test_stale_temporaries_of_that_file_only_are_removed(tmp_path):
    path = tmp_path / "holders.json"
    stale = tmp_path / ".holders.json.123.abcd.tmp"
    other = tmp_path / ".other.json.123.abcd.tmp"
    stale.write_bytes(b"x")
    other.write_bytes(b"x")
    remove_stale_temporaries(path)
    assert not stale.exists() and other.exists()


def test_ctrl_c_while_the_file_is_put_in_place_says_it_was_written(tmp_path, monkeypatch):
    """A black-box test: Ctrl-C late in a large library's write reported 'interrupted'
    (exit 130) for a change that had been made. Ctrl-C just after the rename now raises
    InterruptedAfterWrite, naming the file, also with other threads running (a Ctrl-C
    goes to the process, any thread may take it); before it, the old file stays."""
    import threading
    import time

    from taptune.errors import InterruptedAfterWrite
    from taptune.io import atomic

    target = tmp_path / "lib.json"
    target.write_text("old")
    real_replace = os.replace
    stop = threading.Event()
    other = threading.Thread(target=stop.wait)
    other.start()

    def replace_then_ctrl_c(src, dst):
        real_replace(src, dst)
        os.kill(os.getpid(), signal.SIGINT)  # as a terminal's Ctrl-C: to the process
        time.sleep(0.05)

    try:
        monkeypatch.setattr(atomic.os, "replace", replace_then_ctrl_c)
        with pytest.raises(InterruptedAfterWrite) as info:
            atomic_write_bytes(target, b"new")
    finally:
        stop.set()
        other.join()
    assert info.value.path == target and target.read_bytes() == b"new"
    assert signal.getsignal(signal.SIGINT) is signal.default_int_handler
    monkeypatch.undo()

    def ctrl_c_while_writing(tmp):
        tmp.write_bytes(b"half")
        signal.raise_signal(signal.SIGINT)

    with pytest.raises(KeyboardInterrupt) as info:
        atomic.atomic_write(target, ctrl_c_while_writing)
    assert not isinstance(info.value, InterruptedAfterWrite) and target.read_bytes() == b"new"
    assert not list(tmp_path.glob("*.tmp"))
