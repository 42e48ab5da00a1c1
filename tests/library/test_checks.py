"""Checks in the holder history: validated like the other records, optional in old files, never lost."""

import json
import re
from dataclasses import replace

import pytest

from taptune.library.checks import append_check
from taptune.library.schema import CheckRecord, HolderEntry, LibraryFormatError, UnknownHolderError

from .entries import make_entry


def make_check(i: int = 0, verdict: str = "consistent") -> CheckRecord:
    modes = ({"mode": 1, "measured_hz": 3051.0 + i, "predicted_hz": 3049.5, "band_hz": 4.0},
             {"mode": 2, "measured_hz": None, "predicted_hz": 8121.0, "band_hz": 9.5})
    return CheckRecord(date=f"2026-11-23T10:00:{i:02d}Z", recording=f"check{i}.m4a", sha256=f"{i + 7:064x}",
                       tool="solid carbide end mill D16 4FL", stickout_mm=63.5, verdict=verdict, modes=modes,
                       taptune_version="0.1.0")


def test_an_old_entry_without_checks_loads_and_is_written_as_before():
    entry = make_entry()
    data = entry.to_dict()
    assert "checks" not in data, "an entry without checks keeps the old format (older taptune reads it)"
    assert HolderEntry.from_dict(json.loads(json.dumps(data))) == entry


def test_checks_round_trip_and_are_validated():
    entry = replace(make_entry(), checks=(make_check(0), make_check(1, "differs")))
    data = json.loads(json.dumps(entry.to_dict()))
    assert HolderEntry.from_dict(data) == entry
    for change, key in [({"verdict": "fine"}, "checks[1].verdict"), ({"sha256": "abc"}, "checks[1].sha256"),
                        ({"date": "yesterday"}, "checks[1].date"), ({"extra": 1}, "checks[1].extra"),
                        ({"modes": [{"mode": 1, "measured_hz": -3.0, "predicted_hz": 1.0, "band_hz": 0.1}]},
                         "checks[1].modes[0].measured_hz")]:
        bad = json.loads(json.dumps(data))
        bad["checks"][1].update(change)
        with pytest.raises(LibraryFormatError, match=re.escape(key)):
            HolderEntry.from_dict(bad, "lib.json: holder 'x'")
    bad = json.loads(json.dumps(data))
    bad["checks"] = {"not": "a list"}
    with pytest.raises(LibraryFormatError, match="checks must be a list"):
        HolderEntry.from_dict(bad)


def test_append_check_adds_one_record_and_changes_nothing_else(any_lib, tmp_path):
    lib = any_lib
    lib.put(make_entry())
    lib.put(make_entry("another holder", scale=2.0))
    lib.export(tmp_path / "before.json")
    append_check(lib, "another holder", make_check(3))
    lib.export(tmp_path / "after.json")
    before, after = (json.loads((tmp_path / f"{w}.json").read_text()) for w in ("before", "after"))
    assert after["holders"]["another holder"].pop("checks") == [make_check(3).to_dict()]
    assert (before.pop("version"), after.pop("version")) == (1, 2)  # checks make it format 2
    assert after == before
    with pytest.raises(UnknownHolderError):
        append_check(lib, "nope", make_check(4))


def test_a_re_identification_keeps_the_checks(any_lib):
    lib = any_lib
    lib.put(make_entry())
    append_check(lib, "ER32 collet chuck HSK-A63 x 100", make_check(0, "differs"))
    stored = lib.put(make_entry(scale=0.5, records=1, first=5))
    assert stored.checks == (make_check(0, "differs"),) and len(stored.identifications) == 2
