"""The coupling plane: [holder] gauge_length, the interface table, the cut holder (docs/machine.md)."""

from __future__ import annotations

import pytest

from taptune.errors import InputError
from taptune.io.assembly import (assembly_from_toml, assembly_to_toml, holder_from_dict, holder_to_dict,
                                 load_holder, parse_holder)
from taptune.machine.plane import coupling_plane, cut_assembly, cut_holder, plane_warning, shank_length
from tests.conftest import REFERENCE_TOML

MM = 1e-3


def reference(extra: str = "", interface: str = "HSK-A63"):
    text = REFERENCE_TOML.replace('interface = "HSK-A63"', f'interface = "{interface}"\n{extra}')
    return assembly_from_toml(text, "ref.toml")


def test_hsk_a63_without_gauge_length_cuts_the_32_mm_taper():
    asm = reference()
    assert asm.holder.gauge_length is None
    assert coupling_plane(asm.holder) == pytest.approx(32 * MM)
    cut = cut_assembly(asm)
    assert cut.holder.length == pytest.approx(68 * MM)
    assert [s.length / MM for s in cut.holder.segments] == pytest.approx([10.0, 58.0])
    # Tool and stick-out unchanged; the contact zone is measured from the front face.
    assert cut.stickout == asm.stickout and cut.contact_length == pytest.approx(asm.contact_length)


def test_gauge_length_sets_the_plane_and_may_split_a_segment():
    asm = reference("gauge_length = 63.0")
    assert asm.holder.gauge_length == pytest.approx(63 * MM)
    assert coupling_plane(asm.holder) == pytest.approx(37 * MM)
    cut = cut_holder(asm.holder)
    assert [s.length / MM for s in cut.segments] == pytest.approx([5.0, 58.0])
    assert [s.od / MM for s in cut.segments] == pytest.approx([63.0, 50.0])


@pytest.mark.parametrize("spelling", ["HSK-A63", "hsk a63", "HSK63A", "HSK-C63", "HSK_A 63"])
def test_interface_spellings(spelling):
    assert shank_length(spelling) == pytest.approx(32 * MM)


def test_unknown_interface_without_gauge_length_is_a_clear_error_only_for_the_machine_stage():
    asm = reference(interface="SK40")  # the tap test still works
    with pytest.raises(InputError, match=r"ref.toml: \[holder\] gauge_length is missing.*SK40"):
        cut_assembly(asm)


@pytest.mark.parametrize("value, problem", [("0", "must be > 0"), ("-5", "must be > 0"), ("100.5", "longer than the holder")])
def test_bad_gauge_length_is_rejected_in_one_line(value, problem):
    with pytest.raises(InputError, match=rf"ref.toml: \[holder\] gauge_length .*{problem}") as err:
        reference(f"gauge_length = {value}")
    assert "\n" not in str(err.value)


def test_tool_behind_the_plane_is_an_error_naming_the_file():
    # Inserted 90 mm into a 100 mm holder: the tool's end sits 10 mm from the back, behind the 32 mm plane.
    asm = reference().with_stickout(3.5 * MM)
    with pytest.raises(InputError, match=r"ref.toml: the tool reaches 22 mm behind the coupling plane"):
        cut_assembly(asm)


def test_gauge_length_survives_toml_and_library_round_trips():
    asm = reference("gauge_length = 68")
    again = assembly_from_toml(assembly_to_toml(asm), "again.toml")
    assert again.holder == asm.holder
    assert holder_from_dict(holder_to_dict(asm.holder)) == asm.holder
    assert "gauge_length" not in holder_to_dict(reference().holder)  # unchanged records without it


def test_library_schema_accepts_gauge_length():
    from taptune.library.schema import check_holder_dict

    d = holder_to_dict(reference("gauge_length = 68").holder)
    assert check_holder_dict(d, "lib.json")["gauge_length"] == pytest.approx(68)


def test_holder_only_file(tmp_path):
    p = tmp_path / "dummy.toml"
    p.write_text('[holder]\nname = "dummy"\ninterface = "HSK-A63"\nclamp_length = 1\n'
                 'segments = [{ length = 32, od = 48, id = 24 }, { length = 100, od = 50 }]\n')
    h = load_holder(p)
    assert h.length == pytest.approx(0.132) and h.segments[1].id == 0
    assert cut_holder(h).length == pytest.approx(0.1)
    with pytest.raises(InputError, match=r"dummy.toml: \[holder\] segments\[1\].od must be > 0"):
        parse_holder({"holder": {"name": "d", "clamp_length": 1, "segments": [{"length": 1, "od": 0}]}}, "dummy.toml")


def test_same_interface_ignores_case_spaces_and_punctuation():
    """The machine-vs-holder interface check of toolpoint, lobes and batch."""
    from taptune.machine.plane import same_interface

    assert same_interface("HSK-A63", "hsk a63") and same_interface("SK40", "sk 40")
    assert not same_interface("HSK-A63", "HSK-A100")


def test_a_gauge_length_off_the_taper_end_is_questioned_naming_the_file():
    """The reference holder's segments include the 32 mm HSK-A63 taper, 100 mm in all: its
    gauge length is 68 mm. The catalogue's "x 100" copied into the file would put the
    plane at the back end, inside the taper."""
    assert plane_warning(reference().holder) is None  # the interface decides
    assert plane_warning(reference("gauge_length = 68.0").holder) is None
    assert plane_warning(reference("gauge_length = 69.5").holder) is None  # within 2 mm
    text = plane_warning(reference("gauge_length = 100.0").holder, "ref.toml")
    assert text.startswith("ref.toml: ") and "0 mm" in text and "32 mm" in text and "68 mm" in text
    assert plane_warning(reference("gauge_length = 100.0", interface="Capto C6").holder) is None  # unknown taper


def test_interface_warning_names_both_interfaces_or_is_none():
    from taptune.machine.plane import interface_warning

    holder = reference().holder
    assert interface_warning("hsk-a 63", holder) is None
    assert interface_warning("BT40", holder) == "the machine's interface 'BT40' differs from the holder's 'HSK-A63'"
