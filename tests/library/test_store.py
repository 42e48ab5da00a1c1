"""The holder store: round trips, merging, atomic replacement, the lock, real concurrency."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import time
from pathlib import Path

import pytest

from taptune.errors import InputError, LibraryError
from taptune.library import HolderLibrary, LibraryFormatError, UnknownHolderError, default_library_path
from taptune.library import base, json_store
from tests.library.entries import make_entry, make_record

REPO = Path(__file__).resolve().parents[2]


def leftovers(folder: Path) -> list[str]:
    """Temporary files an interrupted write left behind."""
    return sorted(p.name for p in folder.iterdir() if p.name.endswith(".tmp"))


# --------------------------------------------------------------------------- basics


def test_missing_file_is_an_empty_library_and_reading_creates_nothing(lib):
    assert lib.entries() == {}
    assert len(lib) == 0 and "x" not in lib
    assert not lib.path.parent.exists()


def test_put_creates_folders_and_reads_back_equal(lib):
    entry = make_entry()
    assert lib.put(entry) == entry
    assert lib.path.is_file()
    assert lib.get(entry.name) == entry
    assert HolderLibrary(lib.path).entries() == {entry.name: entry}
    doc = json.loads(lib.path.read_text())
    assert doc["schema"] == "taptune-holder-library" and doc["version"] == 1
    assert list(doc["holders"]) == [entry.name]


def test_entries_are_sorted_by_name(lib):
    for name in ("zeta", "Alpha", "mid"):
        lib.put(make_entry(name))
    assert list(lib.entries()) == sorted(["zeta", "Alpha", "mid"])
    assert lib.names() == sorted(["zeta", "Alpha", "mid"])


def test_reidentifying_replaces_parameters_and_keeps_the_history(lib):
    lib.put(make_entry("H", scale=1.0, records=2, first=0))
    stored = lib.put(make_entry("H", scale=1.3, records=1, first=5))
    assert stored.params.k_tt == pytest.approx(1.3 * 2.81e9)
    assert [r.sha256 for r in stored.identifications] == [f"{i:064x}" for i in (0, 1, 5)]
    assert lib.get("H") == stored


def test_putting_back_an_extended_entry_does_not_repeat_records(lib):
    lib.put(make_entry("H", records=2))
    old = lib.get("H")
    extended = make_entry("H", scale=0.9, records=0)
    extended = type(old)(**{**extended.__dict__, "identifications": old.identifications + (make_record(7),)})
    stored = lib.put(extended)
    assert [r.seed for r in stored.identifications] == [0, 1, 7]


def test_remove_deletes_one_holder_and_returns_it(lib):
    a, b = make_entry("A"), make_entry("B")
    lib.put(a)
    lib.put(b)
    assert lib.remove("A") == a
    assert lib.entries() == {"B": b}


def test_unknown_holder_is_bad_input_with_close_matches(lib):
    lib.put(make_entry("ER32 collet chuck HSK-A63 x 100"))
    lib.put(make_entry("Shrink fit HSK-A63 D16"))
    for call in (lib.get, lib.remove):
        with pytest.raises(UnknownHolderError) as info:
            call("ER23")
        err = info.value
        assert isinstance(err, InputError) and isinstance(err, LibraryError)
        assert str(lib.path) in str(err) and "'ER23'" in str(err)
        assert err.close_matches == ("ER32 collet chuck HSK-A63 x 100",)
    with pytest.raises(UnknownHolderError, match="did you mean .Shrink fit HSK-A63 D16"):
        lib.get("shrink")
    assert len(lib) == 2


def test_failed_edit_block_writes_nothing(lib):
    lib.put(make_entry("A"))
    before = lib.path.read_bytes()
    with pytest.raises(RuntimeError):
        with lib.edit() as holders:
            holders.pop("A")
            raise RuntimeError("changed my mind")
    assert lib.path.read_bytes() == before


def test_write_keeps_the_file_permissions(lib):
    lib.put(make_entry("A"))
    os.chmod(lib.path, 0o640)
    lib.put(make_entry("B"))
    assert lib.path.stat().st_mode & 0o777 == 0o640


def test_put_returns_the_entry_as_it_reads_back(lib):
    entry = make_entry("A")
    entry = type(entry)(**{**entry.__dict__, "model_options": {"h_max_mm": 2, "grid": (1, 2)}})
    stored = lib.put(entry)
    assert stored.model_options == {"h_max_mm": 2, "grid": [1, 2]}
    assert lib.get("A") == stored


def test_a_symlinked_library_stays_a_symlink(lib, tmp_path):
    shared = tmp_path / "synced" / "team-holders.json"
    HolderLibrary(shared).put(make_entry("A"))
    lib.path.parent.mkdir(parents=True)
    lib.path.symlink_to(shared)
    lib.put(make_entry("B"))
    assert lib.path.is_symlink()
    assert HolderLibrary(shared).names() == ["A", "B"]
    assert lib.lock_path == shared.with_name("team-holders.json.lock")


# --------------------------------------------------------------------------- location


def test_default_path_prefers_argument_then_environment(monkeypatch, tmp_path):
    monkeypatch.setenv("TAPTUNE_LIBRARY", str(tmp_path / "env.json"))
    assert default_library_path(tmp_path / "arg.json") == tmp_path / "arg.json"
    assert default_library_path() == tmp_path / "env.json"
    assert default_library_path("~/x.json") == Path.home() / "x.json"


def test_default_path_is_the_user_data_folder(monkeypatch, tmp_path):
    monkeypatch.delenv("TAPTUNE_LIBRARY", raising=False)
    monkeypatch.setattr(base.sys, "platform", "linux")
    monkeypatch.setenv("XDG_DATA_HOME", str(tmp_path / "xdg"))
    assert default_library_path() == tmp_path / "xdg" / "taptune" / "holders.db"
    monkeypatch.setenv("XDG_DATA_HOME", "relative/ignored")
    assert default_library_path() == Path.home() / ".local" / "share" / "taptune" / "holders.db"
    monkeypatch.setattr(base.sys, "platform", "darwin")
    assert default_library_path() == Path.home() / "Library" / "Application Support" / "taptune" / "holders.db"
    monkeypatch.setattr(base.sys, "platform", "win32")
    monkeypatch.setenv("APPDATA", str(tmp_path / "Roaming"))
    assert default_library_path() == tmp_path / "Roaming" / "taptune" / "holders.db"


# --------------------------------------------------------------------------- atomicity


def test_write_protocol_is_fsync_file_then_replace_then_fsync_folder(lib, monkeypatch):
    lib.put(make_entry("A"))
    calls = []
    real_fsync, real_replace = os.fsync, os.replace

    def fsync(fd):
        calls.append(("fsync", "folder" if os.path.isdir(f"/proc/self/fd/{fd}") else "file"))
        real_fsync(fd)

    def replace(src, dst):
        calls.append(("replace", Path(src).parent == Path(dst).parent))
        real_replace(src, dst)

    monkeypatch.setattr(json_store.os, "fsync", fsync)
    monkeypatch.setattr(json_store.os, "replace", replace)
    lib.put(make_entry("B"))
    # The temporary file lives in the library's own folder, so the rename is atomic.
    assert calls == [("fsync", "file"), ("replace", True), ("fsync", "folder")]


def test_crash_at_replace_leaves_the_old_file_intact(lib, monkeypatch):
    lib.put(make_entry("A"))
    before = lib.path.read_bytes()

    def crash(src, dst):
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(json_store.os, "replace", crash)
    with pytest.raises(LibraryError, match="No space left on device.*not changed"):
        lib.put(make_entry("B"))
    assert lib.path.read_bytes() == before
    assert leftovers(lib.path.parent) == []


def test_interrupt_while_syncing_leaves_the_old_file_intact(lib, monkeypatch):
    lib.put(make_entry("A"))
    before = lib.path.read_bytes()

    def interrupted(fd):
        raise KeyboardInterrupt

    monkeypatch.setattr(json_store.os, "fsync", interrupted)
    with pytest.raises(KeyboardInterrupt):
        lib.remove("A")
    assert lib.path.read_bytes() == before
    assert leftovers(lib.path.parent) == []


def test_failure_while_encoding_leaves_the_old_file_intact(lib, monkeypatch):
    lib.put(make_entry("A"))
    before = lib.path.read_bytes()

    def broken_encoder(entries, source):
        raise RuntimeError("simulated failure in json.dumps")

    monkeypatch.setattr(json_store, "encode", broken_encoder)
    with pytest.raises(RuntimeError):
        lib.put(make_entry("B"))
    assert lib.path.read_bytes() == before


CRASH_SCRIPT = """
import os, signal, sys
from taptune.library import HolderLibrary, json_store
from tests.library.entries import make_entry
lib = HolderLibrary(sys.argv[1])
real_replace = os.replace
def die(src, dst):
    # The new library is complete and fsynced in the temporary file; the process is
    # killed before it can take the old file's place.
    os.kill(os.getpid(), signal.SIGKILL)
json_store.os.replace = die
lib.put(make_entry("B"))
"""


def test_process_killed_mid_write_leaves_a_readable_old_library(lib):
    lib.put(make_entry("A"))
    before = lib.path.read_bytes()
    proc = subprocess.run([sys.executable, "-c", CRASH_SCRIPT, str(lib.path)], cwd=REPO, capture_output=True)
    assert proc.returncode == -9, proc.stderr.decode()
    assert lib.path.read_bytes() == before
    assert list(lib.entries()) == ["A"]
    assert len(leftovers(lib.path.parent)) == 1  # the complete but orphaned new library
    # The lock died with the process: the next write goes through at once and tidies up.
    fast = HolderLibrary(lib.path, lock_timeout=1.0)
    fast.put(make_entry("C"))
    assert list(fast.entries()) == ["A", "C"]
    assert leftovers(lib.path.parent) == []


@pytest.mark.parametrize(
    "content, problem",
    [
        (b"", "is empty"),
        (b'{"schema": "taptune-holder-library", "version": 1, "holders": {"A": {"na', "not valid JSON"),
        (b'{"schema": "something-else", "version": 1, "holders": {}}', "not a taptune holder library"),
        (b"\x80\x04\x95pickle", "not UTF-8"),
        (b"[1, 2, 3]", "not a taptune holder library"),
    ],
)
def test_broken_file_is_reported_and_never_overwritten(lib, content, problem):
    lib.path.parent.mkdir(parents=True)
    lib.path.write_bytes(content)
    with pytest.raises(LibraryFormatError, match=problem) as info:
        lib.entries()
    assert str(lib.path) in str(info.value)
    for change in (lambda: lib.put(make_entry("B")), lambda: lib.remove("A")):
        with pytest.raises(LibraryFormatError):
            change()
        assert lib.path.read_bytes() == content


def test_truncated_real_library_is_never_overwritten(lib):
    lib.put(make_entry("A", records=3))
    lib.put(make_entry("B"))
    full = lib.path.read_bytes()
    lib.path.write_bytes(full[: len(full) // 2])
    with pytest.raises(LibraryFormatError, match="truncated"):
        lib.put(make_entry("C"))
    assert lib.path.read_bytes() == full[: len(full) // 2]


def test_folder_in_place_of_the_library_is_reported(lib):
    lib.path.mkdir(parents=True)
    with pytest.raises(LibraryFormatError, match="is a folder"):
        lib.entries()


# --------------------------------------------------------------------------- lock


def test_lock_timeout_is_a_clear_library_error(lib):
    lib.put(make_entry("A"))
    impatient = HolderLibrary(lib.path, lock_timeout=0.2)
    with lib._locked():
        start = time.monotonic()
        with pytest.raises(LibraryError, match=r"lock .*holders\.json\.lock.*0\.2 s") as info:
            impatient.put(make_entry("B"))
        assert 0.2 <= time.monotonic() - start < 2.0
    # Waiting for a busy lock is not the user's input error: exit 1, not 2.
    assert not isinstance(info.value, InputError)
    assert impatient.names() == ["A"]
    impatient.put(make_entry("B"))
    assert impatient.names() == ["A", "B"]


WORKER_SCRIPT = """
import sys, time
from taptune.library import HolderLibrary
from tests.library.entries import make_entry
path, worker, count, start = sys.argv[1], int(sys.argv[2]), int(sys.argv[3]), float(sys.argv[4])
same = len(sys.argv) > 5
lib = HolderLibrary(path, lock_timeout=60.0)
while time.time() < start:  # all workers begin together so that they contend
    time.sleep(0.001)
for i in range(count):
    if same:
        lib.put(make_entry("shared", scale=1 + worker / 10, records=1, first=1000 * worker + i))
    else:
        lib.put(make_entry(f"w{worker}-{i:02d}", records=1, first=i))
"""


def run_workers(path: Path, workers: int, count: int, *extra: str) -> None:
    start = time.time() + 1.5
    procs = [
        subprocess.Popen(
            [sys.executable, "-c", WORKER_SCRIPT, str(path), str(w), str(count), repr(start), *extra],
            cwd=REPO,
            stderr=subprocess.PIPE,
        )
        for w in range(workers)
    ]
    for p in procs:
        _, err = p.communicate(timeout=120)
        assert p.returncode == 0, err.decode()


def test_four_processes_putting_twenty_holders_each_lose_nothing(lib):
    run_workers(lib.path, 4, 20)
    names = lib.names()
    assert len(names) == 80
    assert names == sorted(f"w{w}-{i:02d}" for w in range(4) for i in range(20))
    assert leftovers(lib.path.parent) == []


def test_three_processes_reidentifying_one_holder_keep_every_record(lib):
    run_workers(lib.path, 3, 10, "same")
    entry = lib.get("shared")
    seeds = sorted(r.seed for r in entry.identifications)
    assert seeds == sorted(1000 * w + i for w in range(3) for i in range(10))
