"""Plausible ranges of holder geometry: refused when a holder is saved or imported, only a
warning when a library is read (one holder an older taptune saved with a 1e9 mm segment must
not make the whole library unreadable), and nothing already saved is lost."""

import copy
import json
from dataclasses import replace

import pytest

from taptune.cli import main
from taptune.errors import InputError
from taptune.library import HolderLibrary
from taptune.library.schema import LibraryFormatError, encode

from .entries import make_entry, make_record

#: The first holder segment 1e9 mm long (a µm-for-mm slip), as an older taptune saved it.
ABSURD_MM = 1e9


def _absurd(name: str = "B"):
    entry = make_entry(name)
    holder = copy.deepcopy(entry.holder)
    holder["segments"][0]["length"] = ABSURD_MM
    return replace(entry, holder=holder)


@pytest.fixture
def old_library(tmp_path):
    """A library file with a good holder 'A' and an out-of-range holder 'B'."""
    path = tmp_path / "holders.json"
    doc = json.loads(encode({"A": make_entry("A")}, str(path)))
    bad = json.loads(encode({"B": make_entry("B")}, str(path)))["holders"]["B"]
    bad["holder"]["segments"][0]["length"] = ABSURD_MM
    doc["holders"]["B"] = bad
    path.write_text(json.dumps(doc, indent=2))
    return path


def test_a_library_with_one_out_of_range_holder_reads_with_one_warning_naming_it(old_library):
    entries = HolderLibrary(old_library).entries()
    assert list(entries) == ["A", "B"]
    assert entries["A"].warnings == ()
    (warning,) = entries["B"].warnings
    assert warning.startswith(f"{old_library}: holder 'B': [holder] segments[1].length (1e+09 mm) is implausible")
    assert "taptune library remove 'B'" in warning and "\n" not in warning
    # The good holder predicts; the implausible one refuses with the same one-line reason.
    record = make_record()
    assert entries["A"].assembly(record.tool, record.stickout_mm).stickout == pytest.approx(0.0535)
    with pytest.raises(InputError, match=r"holder 'B' .*segments\[1\].length \(1e\+09 mm\) is implausible"):
        entries["B"].assembly(record.tool, record.stickout_mm)


def test_library_list_lists_both_holders_and_warns_once(old_library, capsys):
    before = old_library.read_bytes()
    assert main(["library", "list", "--library", str(old_library)]) == 0
    out, err = capsys.readouterr()
    assert "2 holders in" in out and "\nA " in out and "\nB " in out
    assert err.count("warning:") == 1 and "holder 'B'" in err and "Traceback" not in err
    assert old_library.read_bytes() == before


def test_saving_an_out_of_range_holder_is_refused_and_the_file_is_untouched(old_library):
    lib = HolderLibrary(old_library)
    before = old_library.read_bytes()
    with pytest.raises(LibraryFormatError) as info:
        lib.put(_absurd("C"))
    message = str(info.value)
    assert message.startswith(f"{old_library}: new entry for holder 'C': [holder] segments[1].length (1e+09 mm) "
                              "is implausible: above 2000 mm")
    assert message.endswith("; not saved") and "\n" not in message
    assert old_library.read_bytes() == before


def test_a_good_holder_saved_beside_an_old_out_of_range_one_keeps_it(old_library):
    lib = HolderLibrary(old_library)
    lib.put(make_entry("C"))
    entries = lib.entries()
    assert list(entries) == ["A", "B", "C"]
    assert entries["B"].holder["segments"][0]["length"] == ABSURD_MM and len(entries["B"].warnings) == 1


def test_importing_an_out_of_range_holder_is_refused_and_imports_nothing(old_library, lib):
    lib.put(make_entry("Z"))
    before = lib.path.read_bytes()
    with pytest.raises(LibraryFormatError, match=r"holder 'B': \[holder\] segments\[1\].length .* nothing was imported$"):
        lib.import_file(old_library)
    assert lib.path.read_bytes() == before
    assert main(["library", "import", str(old_library), "--library", str(lib.path)]) == 2
    assert lib.path.read_bytes() == before


def test_a_library_re_importing_its_own_export_is_not_refused_for_its_old_holder(old_library, tmp_path):
    # A backup restored into the library that made it: holder B enters nothing new.
    lib = HolderLibrary(old_library)
    backup = tmp_path / "backup.json"
    assert lib.export(backup) == 2
    before = old_library.read_bytes()
    report = lib.import_file(backup)
    assert report.skipped == ("A", "B") and not report.added
    assert old_library.read_bytes() == before


def test_a_structural_problem_still_refuses_the_file_naming_the_key(old_library):
    doc = json.loads(old_library.read_text())
    doc["holders"]["A"]["holder"]["segments"][0]["length"] = "100"
    old_library.write_text(json.dumps(doc))
    with pytest.raises(LibraryFormatError, match=r"holder 'A': holder.segments\[1\].length must be a finite number"):
        HolderLibrary(old_library).entries()


def test_predicting_with_the_out_of_range_holder_uses_the_assembly_file_and_warns(old_library, reference_toml, capsys):
    # The contact parameters of 'B' are sound; the assembly file gives the geometry.
    assert main(["predict", str(reference_toml), "--holder", "B", "--library", str(old_library)]) == 0
    out, err = capsys.readouterr()
    assert "f1 [Hz]" in out
    assert err.count(f"warning: {old_library}: holder 'B': [holder] segments[1].length (1e+09 mm) is implausible") == 1
