"""Atomic file writing: the file is wholly old or wholly new, never half of either."""

import os
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
