"""The disk cache of re-computable arrays: whole entries or none, never an error."""

import os

import numpy as np
import pytest

from taptune.io import cache


@pytest.fixture
def folder(tmp_path, monkeypatch):
    monkeypatch.setenv(cache.ENV_VAR, str(tmp_path / "cache"))
    return tmp_path / "cache"


def test_arrays_come_back_exactly(folder):
    arrays = {"a": np.arange(6.0).reshape(2, 3), "b": np.array([1 + 2j, 3 - 4j]), "n": np.array(7)}
    assert cache.save_arrays("kind", "k1", arrays)
    back = cache.load_arrays("kind", "k1")
    assert set(back) == set(arrays)
    for name, value in arrays.items():
        np.testing.assert_array_equal(back[name], value)
        assert back[name].dtype == value.dtype
    assert cache.load_arrays("kind", "k2") is None
    assert cache.load_arrays("other", "k1") is None


def test_a_foreign_or_corrupt_entry_reads_as_missing(folder):
    cache.save_arrays("kind", "key", {"a": np.ones(3)})
    (entry,) = folder.glob("kind-*.npz")
    # The file name holds 40 hex digits of the key; the stored key must match in full.
    assert cache.load_arrays("kind", "key-but-longer") is None
    for bad in (b"", b"garbage", entry.read_bytes()[:50]):
        entry.write_bytes(bad)
        assert cache.load_arrays("kind", "key") is None


def test_turned_off_or_unwritable_keeps_nothing(folder, tmp_path, monkeypatch):
    monkeypatch.setenv(cache.ENV_VAR, "off")
    assert cache.cache_dir() is None
    assert not cache.save_arrays("kind", "key", {"a": np.ones(3)})
    assert cache.load_arrays("kind", "key") is None
    blocker = tmp_path / "a-file"
    blocker.write_text("not a folder")
    monkeypatch.setenv(cache.ENV_VAR, str(blocker / "cache"))
    assert not cache.save_arrays("kind", "key", {"a": np.ones(3)})
    assert not any(p.name.endswith(".tmp") for p in tmp_path.iterdir())


def test_the_user_cache_folder_follows_xdg(tmp_path, monkeypatch):
    monkeypatch.delenv(cache.ENV_VAR, raising=False)
    monkeypatch.setattr(cache.sys, "platform", "linux")
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "xdg"))
    assert cache.cache_dir() == tmp_path / "xdg" / "taptune"
    monkeypatch.setenv("XDG_CACHE_HOME", "relative/ignored")
    monkeypatch.setenv("HOME", str(tmp_path))
    assert cache.cache_dir() == tmp_path / ".cache" / "taptune"


def test_only_the_most_recently_used_entries_are_kept(folder, monkeypatch):
    monkeypatch.setattr(cache, "MAX_ENTRIES", 3)
    for i in range(3):
        cache.save_arrays("kind", f"key{i}", {"a": np.full(2, i)})
        entry = next(p for p in folder.glob("*.npz") if cache.load_arrays("kind", f"key{i}") is not None)
        os.utime(entry, (1000 + i, 1000 + i))
    cache.load_arrays("kind", "key0")  # used again: now the newest
    cache.save_arrays("kind", "key3", {"a": np.full(2, 3)})
    kept = {k for k in ("key0", "key1", "key2", "key3") if cache.load_arrays("kind", k) is not None}
    assert kept == {"key0", "key2", "key3"}


def test_the_digest_tells_arrays_apart_by_value_dtype_and_shape():
    a = np.arange(4.0)
    assert cache.digest(a, "x") == cache.digest(a.copy(), "x")
    assert cache.digest(a) != cache.digest(a.astype(np.float32))
    assert cache.digest(a) != cache.digest(a.reshape(2, 2))
    assert cache.digest(a) != cache.digest(a + 1e-15 * (a == 3))
    assert cache.digest("a", "b") != cache.digest("ab")
