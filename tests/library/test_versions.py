"""Library format versions: 1 without checks (older taptunes read it), 2 with checks, 3 with stated
stick-out tolerances (older taptunes refuse them clearly), and a newer version than this build
knows is one line and never overwritten."""

import json
from dataclasses import replace

import pytest

from taptune.cli import main
from taptune.library.schema import VERSION, LibraryFormatError, decode, encode, parse_library

from .entries import make_entry
from .test_checks import make_check


def _version(path) -> int:
    return json.loads(path.read_text())["version"]


def test_a_library_is_written_with_the_oldest_version_that_holds_it(lib):
    lib.put(make_entry("A"))
    assert _version(lib.path) == 1  # what every taptune before `check` reads
    lib.put(replace(make_entry("B"), checks=(make_check(),)))
    assert _version(lib.path) == 2  # what every taptune before stated tolerances reads
    assert lib.get("B").checks == (make_check(),)
    entry = make_entry("C")
    stated = replace(entry.identifications[0], stickout_tolerance_mm=0.05)
    lib.put(replace(entry, identifications=(stated,)))
    assert _version(lib.path) == VERSION - 1 == 3  # version 4 only with cut observations
    assert lib.get("C").identifications[0].stickout_tolerance_mm == 0.05
    assert lib.get("A").identifications[0].stickout_tolerance_mm is None
    lib.remove("C")
    assert _version(lib.path) == 2


def test_a_reader_of_version_1_refuses_a_library_with_checks_by_its_version():
    # What a taptune from before checks does with the file this build writes: its own
    # rule "version > 1 → written by a newer taptune" is met before the unknown key.
    raw = encode({"B": replace(make_entry("B"), checks=(make_check(),))}, "lib.json")
    assert json.loads(raw)["version"] > 1


def test_an_interim_version_1_file_with_checks_still_reads():
    doc = json.loads(encode({"B": replace(make_entry("B"), checks=(make_check(),))}, "lib.json"))
    doc["version"] = 1
    assert parse_library(doc, "old.json")["B"].checks == (make_check(),)


@pytest.mark.parametrize("extra", [{}, {"machines": {}}])
def test_a_newer_version_is_one_line_even_with_keys_this_build_does_not_know(extra):
    doc = {"schema": "taptune-holder-library", "version": VERSION + 1, "holders": {"A": {"new": 1}}} | extra
    with pytest.raises(LibraryFormatError) as info:
        parse_library(decode(json.dumps(doc).encode(), "new.json"), "new.json")
    assert str(info.value) == (f"new.json: version is {VERSION + 1}: written by a newer taptune (this one reads "
                               f"versions 1–{VERSION}); update taptune to use it (the file is left as it is)")


@pytest.mark.parametrize("argv", [
    ["library", "list"],
    ["library", "remove", "A"],
    ["library", "import", "{good}"],
    ["library", "export", "{tmp}/out.json"],
    ["predict", "{toml}", "--holder", "A"],
])
def test_no_command_overwrites_a_newer_library(argv, tmp_path, reference_toml, capsys):
    newer = tmp_path / "holders.json"
    newer.write_text(json.dumps({"schema": "taptune-holder-library", "version": VERSION + 1,
                                 "holders": {}, "machines": {}}))
    before = newer.read_bytes()
    good = tmp_path / "good.json"
    good.write_bytes(encode({"A": make_entry("A")}, str(good)))
    argv = [a.format(good=good, tmp=tmp_path, toml=reference_toml) for a in argv] + ["--library", str(newer)]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "written by a newer taptune" in err and "Traceback" not in err
    assert newer.read_bytes() == before
    assert not (tmp_path / "out.json").exists()
