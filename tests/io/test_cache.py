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
    assert (folder / "kind-k1.npz").is_file()
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


def test_only_the_most_recently_used_entries_are_kept_and_nothing_else_is_touched(folder, monkeypatch):
    monkeypatch.setattr(cache, "MAX_ENTRIES", 3)
    folder.mkdir(parents=True)
    # The user's own files in a folder the cache was pointed at: never pruned.
    mine = [folder / "measurement_01.npz", folder / "my-data.npz", folder / ("x-" + "0" * 39 + ".npz")]
    for i, path in enumerate(mine):
        np.savez(path, a=np.ones(2))
        os.utime(path, (10 + i, 10 + i))
    keys = [cache.digest(i) for i in range(4)]
    for i in range(3):
        cache.save_arrays("kind", keys[i], {"a": np.full(2, i)})
        (entry,) = folder.glob(f"kind-{keys[i][:40]}.npz")
        os.utime(entry, (1000 + i, 1000 + i))
    cache.load_arrays("kind", keys[0])  # used again: now the newest
    cache.save_arrays("kind", keys[3], {"a": np.full(2, 3)})
    kept = {i for i in range(4) if cache.load_arrays("kind", keys[i]) is not None}
    assert kept == {0, 2, 3}
    assert all(path.is_file() for path in mine)


def test_odd_folders_keep_nothing_and_raise_nothing(tmp_path, monkeypatch):
    arrays = {"a": np.ones(3)}
    key = cache.digest("odd")
    # No home folder to be found (some containers): no cache.
    monkeypatch.setenv(cache.ENV_VAR, "~nosuchuser-taptune/cache")
    assert cache.load_arrays("kind", key) is None and not cache.save_arrays("kind", key, arrays)
    # A folder where the entry's file should be.
    monkeypatch.setenv(cache.ENV_VAR, str(tmp_path))
    (tmp_path / f"kind-{key[:40]}.npz").mkdir()
    assert cache.load_arrays("kind", key) is None and not cache.save_arrays("kind", key, arrays)


def test_an_interrupted_write_leaves_no_temporary_file(folder, monkeypatch):
    def interrupted(*args, **kwargs):
        raise KeyboardInterrupt

    monkeypatch.setattr(cache.np, "savez", interrupted)
    with pytest.raises(KeyboardInterrupt):
        cache.save_arrays("kind", cache.digest(1), {"a": np.ones(3)})
    assert list(folder.iterdir()) == []


def test_the_digest_tells_arrays_apart_by_value_dtype_and_shape():
    a = np.arange(4.0)
    assert cache.digest(a, "x") == cache.digest(a.copy(), "x")
    assert cache.digest(a) != cache.digest(a.astype(np.float32))
    assert cache.digest(a) != cache.digest(a.reshape(2, 2))
    assert cache.digest(a) != cache.digest(a + 1e-15 * (a == 3))
    assert cache.digest("a", "b") != cache.digest("ab")
