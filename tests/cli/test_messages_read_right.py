"""Small things a user reads: no "-0.000", a warning count that matches what is shown,
the stick-out change as given, and identify finding the assembly file beside the WAV."""

from __future__ import annotations

import shutil

from taptune.cli import main
from tests.conftest import REPO


def test_a_number_that_rounds_to_zero_has_no_sign():
    from taptune.report.text import signed

    assert [signed(v, 3) for v in (-0.0004, 0.0004, 0.0, -0.0)] == ["0.000"] * 4
    assert signed(0.0234, 3) == "+0.023" and signed(-1.5, 2) == "-1.50" and signed(-0.006, 2) == "-0.01"


def test_the_batch_line_names_as_many_warnings_as_it_shows_or_says_where_the_rest_are():
    from taptune.batch.job import _warning_note

    assert _warning_note({"warnings": []}, "out/tap.json") == ""
    assert _warning_note({"warnings": ["faint mode 3"]}, "out/tap.json") == "1 warning: faint mode 3"
    two = _warning_note({"warnings": ["faint mode 3", "one recording only"]}, "out/tap.json")
    assert two == "2 warnings: faint mode 3 (and 1 more in tap.json)"


def test_the_band_says_the_stick_out_change_as_given():
    from taptune.identify.bands import Band
    from taptune.io.assembly import Tolerances

    band = Band(half_width_hz=(50.0, 100.0, 150.0), set_hz=(10.0,) * 3, geometry_hz=(40.0,) * 3,
                model_form_hz=(20.0,) * 3, geometry_parts_hz={}, delta_stickout_mm=6.5, recordings=1,
                tolerances=Tolerances())
    assert " 6.5 mm from the tapped stick-out" in band.text((3000.0, 9000.0, 15000.0))


def test_identify_without_assembly_takes_the_one_beside_the_wav(tmp_path, capsys):
    from taptune.cli.cmd_identify import assemblies_beside

    wav = tmp_path / "er32_d16_tap.wav"
    shutil.copyfile(REPO / "recordings" / "er32_d16_tap.wav", wav)
    shutil.copyfile(REPO / "recordings" / "er32_d16.toml", tmp_path / "er32_d16.toml")
    assert assemblies_beside([str(wav)]) == [str(tmp_path / "er32_d16.toml")]
    assert "er32_d16.toml (beside it)" in capsys.readouterr().err
    (tmp_path / "er32_d16_tap.toml").write_text("")  # the recording's own name comes first
    assert assemblies_beside([str(wav)]) == [str(tmp_path / "er32_d16_tap.toml")]


def test_identify_of_a_recording_that_is_not_there_says_so_not_that_its_assembly_is_missing(tmp_path, capsys):
    assert main(["identify", str(tmp_path / "tap.wav"), "--no-save"]) == 2
    assert capsys.readouterr().err == f"taptune identify: {tmp_path / 'tap.wav'}: no such file\n"


def test_identify_without_assembly_and_none_beside_is_one_line(tmp_path, capsys):
    wav = tmp_path / "lonely.wav"
    shutil.copyfile(REPO / "recordings" / "er32_d16_tap.wav", wav)
    code = main(["identify", str(wav), "--no-save"])
    err = capsys.readouterr().err
    assert code == 2 and err.count("\n") == 1
    assert ("lonely.wav: no assembly file beside it (lonely.toml, else the .toml named like the start of lonely "
            "(er32_d16_tap.wav -> er32_d16.toml), else assembly.toml); give one with --assembly FILE") in err


def test_identify_says_how_far_the_fit_carries_in_words_not_a_formula():
    import io
    from types import SimpleNamespace

    from taptune.cli.cmd_identify import print_summary
    from taptune.model.params import NOMINAL

    result = SimpleNamespace(bending_measured_hz=((4686.2, 14934.8, None),), bending_model_hz=((4687.3, 14934.7, 19894.5),),
                             params=NOMINAL, param_spread={"k_tt": 1e8, "k_rr": 1e3}, objective=0.1, evaluations=10,
                             seconds=1.0)
    out = {"holder": "H", "warnings": [], "transfer_outlook": {
        "stickout": 73.5, "bending_hz": [3000.0, 11000.0, 17000.0], "bending_hz_spread": [60.0, 330.0, 340.0],
        "band": {"method": "sqrt(set^2 + geometry^2 + model_form^2)"}}}
    text = io.StringIO()
    print_summary(out, result, text)
    assert ("other stick-outs: at 73.5 mm the predicted f1–f3 are good to ±2.0–3.0 % "
            "(each ± holds the true frequency about 9 times in 10)") in text.getvalue()
    assert "sqrt" not in text.getvalue() and "—" in text.getvalue()  # the mode not measured
