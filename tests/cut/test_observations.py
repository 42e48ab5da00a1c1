"""Cut observations in the holder library: the record, its validation, the file version, HolderLibrary.update."""

from __future__ import annotations

import json
import re
from dataclasses import replace

import pytest

from taptune.library.observations import CutObservation
from taptune.library.schema import VERSION, HolderEntry, LibraryFormatError
from taptune.library.store import HolderLibrary
from tests.library.entries import make_entry


def make_observation(i: int = 0, verdict: str = "chatter") -> CutObservation:
    return CutObservation(date=f"2026-11-27T09:00:{i:02d}Z", recording=f"cut{i}.m4a", sha256=f"{i + 3:064x}",
                          rpm=10000.0 + i, depth_mm=2.0, ae_mm=8.0, milling="down", teeth=4, material="al7075",
                          ktc_mpa=767.0, krc_mpa=169.0, verdict=verdict,
                          chatter_hz=4390.0 if verdict == "chatter" else None,
                          chatter_level_db=6.0 if verdict == "chatter" else None, taptune_version="0.1.0")


def test_an_entry_without_observations_is_written_as_before():
    entry = make_entry()
    assert "observations" not in entry.to_dict()
    assert HolderEntry.from_dict(json.loads(json.dumps(entry.to_dict()))) == entry


def test_observations_round_trip_and_are_validated():
    entry = replace(make_entry(), observations=(make_observation(0), make_observation(1, "stable")))
    data = json.loads(json.dumps(entry.to_dict()))
    assert HolderEntry.from_dict(data) == entry
    for change, key in [({"verdict": "fine"}, "observations[1].verdict"), ({"sha256": "abc"}, "observations[1].sha256"),
                        ({"milling": "climb"}, "observations[1].milling"), ({"rpm": -3}, "observations[1].rpm"),
                        ({"teeth": 0}, "observations[1].teeth"), ({"date": "today"}, "observations[1].date"),
                        ({"extra": 1}, "observations[1].extra"), ({"chatter_hz": "x"}, "observations[1].chatter_hz")]:
        bad = json.loads(json.dumps(data))
        bad["observations"][1].update(change)
        with pytest.raises(LibraryFormatError, match=re.escape(key)):
            HolderEntry.from_dict(bad, "lib.json")


def version(path) -> int:
    return json.loads(path.read_text())["version"]


def test_a_library_with_observations_is_version_4_and_update_keeps_the_rest(tmp_path):
    lib = HolderLibrary(tmp_path / "holders.json")
    lib.put(make_entry("A"))
    lib.put(make_entry("B"))
    before = version(lib.path)
    assert before < VERSION == 4
    stored = lib.update("A", lambda e: replace(e, observations=e.observations + (make_observation(),)))
    assert stored.observations == (make_observation(),)
    assert lib.get("A").observations == (make_observation(),) and lib.get("B") == make_entry("B")
    assert version(lib.path) == 4
    # A re-identification keeps the observed cuts.
    lib.put(make_entry("A", scale=1.05, first=5))
    assert lib.get("A").observations == (make_observation(),)


def test_update_of_an_unknown_holder_or_a_failing_change_writes_nothing(tmp_path):
    lib = HolderLibrary(tmp_path / "holders.json")
    lib.put(make_entry("A"))
    raw = lib.path.read_bytes()
    with pytest.raises(LibraryFormatError.__mro__[1], match="no holder 'Z'"):
        lib.update("Z", lambda e: e)

    def broken(e):
        raise RuntimeError("stop")

    with pytest.raises(RuntimeError):
        lib.update("A", broken)
    assert lib.path.read_bytes() == raw
