"""Assembly files: a misspelt optional key is a warning naming the key it resembles, never silently lost;
a misspelt required key stays an error (with the same hint)."""

import pytest

from taptune.cli import main
from taptune.errors import InputError
from taptune.io.assembly import assembly_from_toml
from tests.conftest import REFERENCE_TOML


def test_a_misspelt_optional_key_is_a_warning_that_names_the_right_one():
    text = (REFERENCE_TOML.replace("clamp_length = 40.0", "clamp_length = 40.0\ngauge_lenght = 100.0")
            .replace("flute_diameter = 16.0", "flute_diameter = 16.0\nflute_ratoi = 0.7")
            .replace('interface = "HSK-A63"', 'interface = "HSK-A63"\nmaterial = { density = 7800.0, poison = 0.3 }'))
    asm = assembly_from_toml(text, "typo.toml")
    assert asm.holder.gauge_length is None and asm.tool.flute_ratio == 0.8  # the defaults were used …
    assert list(asm.warnings) == [  # … and the user is told, one line each
        "typo.toml: [holder] unknown key 'gauge_lenght' is ignored; did you mean 'gauge_length'?",
        "typo.toml: [holder] material: unknown key 'poison' is ignored; did you mean 'poisson'?",
        "typo.toml: [tool] unknown key 'flute_ratoi' is ignored; did you mean 'flute_ratio'?",
    ]


def test_the_warning_survives_another_stickout_and_a_clean_file_has_none():
    asm = assembly_from_toml(REFERENCE_TOML.replace("stickout = 53.5", "stickout = 53.5\nstickout_tolerence = 0.1"),
                             "t.toml")
    assert any("did you mean 'stickout_tolerance'" in w for w in asm.with_stickout(0.06).warnings)
    assert assembly_from_toml(REFERENCE_TOML, "ok.toml").warnings == ()


def test_an_unrelated_extra_key_is_reported_without_a_guess():
    asm = assembly_from_toml(REFERENCE_TOML.replace("[setup]", "[setup]\nwho = 'Mo'"), "x.toml")
    assert list(asm.warnings) == ["x.toml: [setup] unknown key 'who' is ignored"]


@pytest.mark.parametrize("old, new, message", [
    ("clamp_length = 40.0", "clamp_lenght = 40.0",
     "x.toml: [holder] clamp_length is missing (is 'clamp_lenght' a misspelling of 'clamp_length'?)"),
    ("[holder]", "[holders]", "x.toml: [holder] is missing (is 'holders' a misspelling of 'holder'?)"),
    ("stickout = 53.5", "stick_out = 53.5",
     "x.toml: [setup] stickout is missing (is 'stick_out' a misspelling of 'stickout'?)"),
])
def test_a_misspelt_required_key_stays_an_error_with_the_hint(old, new, message):
    with pytest.raises(InputError) as info:
        assembly_from_toml(REFERENCE_TOML.replace(old, new), "x.toml")
    assert str(info.value) == message


def test_the_cli_shows_the_warning_on_one_line(tmp_path, capsys):
    path = tmp_path / "typo.toml"
    path.write_text(REFERENCE_TOML.replace("clamp_length = 40.0", "clamp_length = 40.0\ngauge_lenght = 100.0"))
    assert main(["model", str(path)]) == 0
    out = capsys.readouterr()
    lines = [line for line in (out.out + out.err).splitlines() if "gauge_lenght" in line]
    assert len(lines) == 1 and "did you mean 'gauge_length'?" in lines[0]


def test_spectrum_carries_the_assembly_warnings(tmp_path, capsys):
    # Before, spectrum and identify showed none of the assembly's warnings.
    import json

    from taptune.io.assembly import load_assembly
    from taptune.model.params import NOMINAL
    from taptune.synthetic import write_tap_recording

    path = tmp_path / "typo.toml"
    path.write_text(REFERENCE_TOML.replace("clamp_length = 40.0", "clamp_length = 40.0\ngauge_lenght = 100.0"))
    wav = write_tap_recording(tmp_path / "tap.wav", load_assembly(path), NOMINAL, seed=1, sample_rate=96000,
                              mic_lp_hz=None, snr_db=60.0)
    out = tmp_path / "s.json"
    assert main(["spectrum", str(wav), "--assembly", str(path), "--json", str(out)]) == 0
    assert "did you mean 'gauge_length'?" in json.loads(out.read_text())["warnings"][0]
    assert "did you mean 'gauge_length'?" in capsys.readouterr().out
