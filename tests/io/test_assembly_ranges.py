"""Assembly files: implausible numbers (unit mistakes, typos) are refused naming the key, before the
model meshes them; an empty file says it is empty."""

import time

import pytest

from taptune.errors import InputError
from taptune.io.assembly import assembly_from_toml
from tests.conftest import REFERENCE_TOML


@pytest.mark.parametrize("old, new, message", [
    # A 10 km segment hung `taptune model` for minutes (meshing it); a 1 km tool too.
    ("{ length = 32.0, od = 48.0, id = 24.0 }", "{ length = 1e7, od = 48.0, id = 24.0 }",
     "[holder] segments[1].length (1e+07 mm) is implausible: above 2000 mm"),
    ("total_length = 93.5", "total_length = 1e6\nsegments = [{ length = 1e6, od = 16 }]",
     "[tool] segments[1].length (1e+06 mm) is implausible: above 2000 mm"),
    ("od = 63.0", "od = 1e7", "[holder] segments[2].od (1e+07 mm) is implausible: above 1000 mm"),
    ("flute_diameter = 16.0", "flute_diameter = 1e-6", "[tool] flute_diameter (1e-06 mm) is implausible"),
    ("shank_diameter = 16.0", "shank_diameter = 16000.0", "[tool] shank_diameter (16000 mm) is implausible"),
    ('interface = "HSK-A63"', 'interface = "HSK-A63"\nmaterial = { youngs_modulus = 210e9 }',
     "[holder] material.youngs_modulus must lie in 0.1…1500 GPa (steel 210, carbide 580; in GPa, not Pa)"),
    ('total_length = 93.5', 'total_length = 93.5\nmaterial = { density = 15.6 }',
     "[tool] material.density must lie in 100…30000 kg/m³"),
])
def test_implausible_numbers_are_refused_at_once_naming_the_key(old, new, message):
    t0 = time.perf_counter()
    with pytest.raises(InputError) as info:
        assembly_from_toml(REFERENCE_TOML.replace(old, new, 1), "x.toml")
    assert str(info.value).startswith("x.toml: ") and message in str(info.value)
    assert time.perf_counter() - t0 < 1.0


def test_holder_segments_adding_up_beyond_two_metres_are_refused():
    segs = ",\n".join(["  { length = 1500.0, od = 48.0, id = 24.0 }"] * 2 + ["  { length = 58.0, od = 50.0, id = 16.0 }"])
    text = REFERENCE_TOML.replace(
        "  { length = 32.0, od = 48.0, id = 24.0 },\n  { length = 10.0, od = 63.0, id = 24.0 },\n"
        "  { length = 58.0, od = 50.0, id = 16.0 },", segs)
    with pytest.raises(InputError, match=r"x.toml: \[holder\] segments add up to 3058 mm: implausible"):
        assembly_from_toml(text, "x.toml")


@pytest.mark.parametrize("text", ["", "  \n\n"])
def test_an_empty_assembly_file_says_it_is_empty(text):
    with pytest.raises(InputError, match=r"e.toml: is empty \(an assembly file has \[holder\], \[tool\] and \[setup\]"):
        assembly_from_toml(text, "e.toml")


def test_an_assembly_written_in_metres_is_refused_in_mm_words():
    """Before: exit 1, 'the free-free model has no rigid-body pair (…): the matrices are
    broken', naming no file. Every length of the reference file in metres, then the tool's
    only, then the stick-out only."""
    import re

    def metres(m):
        return f"{m.group(1)} = {float(m.group(2)) / 1000:g}"

    lengths = r"\b(length|od|id|clamp_length|total_length|shank_diameter|flute_length|flute_diameter|stickout) = ([\d.]+)"
    all_metres = re.sub(lengths, metres, REFERENCE_TOML)
    with pytest.raises(InputError, match=r"x.toml: \[holder\] segments add up to 0.1 mm: implausible, below 10 mm "
                                         r"\(lengths are in millimetres; this looks like metres\)"):
        assembly_from_toml(all_metres, "x.toml")
    head, tool = REFERENCE_TOML.split("[tool]")
    tool, setup = tool.split("[setup]")
    tool_metres = head + "[tool]" + re.sub(lengths, metres, tool) + "[setup]" + setup
    with pytest.raises(InputError, match=r"x.toml: \[tool\] total_length \(0.0935 mm\) is implausible: below 10 mm"):
        assembly_from_toml(tool_metres, "x.toml")
    with pytest.raises(InputError, match=r"x.toml: \[setup\] stickout \(0.0535 mm\) is implausible: below 1 mm"):
        assembly_from_toml(REFERENCE_TOML.replace("stickout = 53.5", "stickout = 0.0535"), "x.toml")


def test_a_name_the_library_could_not_keep_is_refused_before_the_fit():
    """A holder name with a line break was refused only when the fit was saved, naming the library."""
    with pytest.raises(InputError, match=r"x.toml: \[holder\] name must be one line of at most 200 characters"):
        assembly_from_toml(REFERENCE_TOML.replace('name = "ER32 collet chuck HSK-A63 x 100"',
                                                  'name = "ER32\\nline two"'), "x.toml")
    with pytest.raises(InputError, match=r"x.toml: \[tool\] name must be one line"):
        assembly_from_toml(REFERENCE_TOML.replace('name = "solid carbide end mill D16 4FL"',
                                                  f'name = "{"x" * 201}"'), "x.toml")
