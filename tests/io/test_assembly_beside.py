"""Which assembly file beside a recording describes it: one rule for identify, batch and the app."""

import pytest

from taptune.io.assembly import assembly_beside, assembly_candidates


def _touch(folder, *names):
    for name in names:
        (folder / name).write_text("")


def test_the_recordings_folder_naming_takes_the_name_without_the_take(tmp_path):
    # recordings/: er32_d16_tap.wav + er32_d16.toml; further takes share the file.
    _touch(tmp_path, "er32_d16.toml", "er32.toml", "assembly.toml", "er32_d1.toml")
    for take in ("er32_d16_tap.wav", "er32_d16_tap2.flac", "er32_d16-2.m4a", "er32_d16 take 3.wav", "er32_d16.1.wav"):
        assert assembly_beside(tmp_path / take) == tmp_path / "er32_d16.toml", take  # the longest name that fits
    assert assembly_beside(tmp_path / "er32_d160_tap.wav") == tmp_path / "er32.toml"  # "d16" is no start of "d160"


def test_the_recordings_own_name_comes_first(tmp_path):
    _touch(tmp_path, "er32_d16.toml", "er32_d16_tap.toml", "assembly.toml")
    assert assembly_beside(tmp_path / "er32_d16_tap.wav") == tmp_path / "er32_d16_tap.toml"


def test_a_plain_tap_wav_takes_assembly_toml(tmp_path):
    # A folder per assembly: tap.wav + assembly.toml (what 'taptune record' into a folder gives).
    assert assembly_beside(tmp_path / "tap.wav") is None
    _touch(tmp_path, "assembly.toml", "ta.toml", "tap1.toml")  # neither "ta" nor "tap1" starts "tap" at a break
    assert assembly_beside(tmp_path / "tap.wav") == tmp_path / "assembly.toml"


def test_the_candidates_are_in_order_and_a_missing_folder_is_no_error(tmp_path):
    _touch(tmp_path, "a.toml", "a_b.toml", "a_b_c.toml")
    assert assembly_candidates(tmp_path / "a_b_c_tap.wav") == [
        tmp_path / "a_b_c_tap.toml", tmp_path / "a_b_c.toml", tmp_path / "a_b.toml", tmp_path / "a.toml",
        tmp_path / "assembly.toml"]
    assert assembly_beside(tmp_path / "nowhere" / "tap.wav") is None


@pytest.mark.parametrize("front_end", ["identify", "batch", "gui"])
def test_every_front_end_uses_the_one_rule(tmp_path, front_end, monkeypatch):
    from taptune.io import assembly

    _touch(tmp_path, "er32_d16.toml", "er32_d16_tap2.wav")
    wav = tmp_path / "er32_d16_tap2.wav"
    if front_end == "identify":
        from taptune.cli.cmd_identify import assemblies_beside

        assert assemblies_beside([str(wav)]) == [str(tmp_path / "er32_d16.toml")]
    elif front_end == "batch":
        from taptune.batch import find_assembly

        assert find_assembly(wav) == tmp_path / "er32_d16.toml"
    else:
        pytest.importorskip("PySide6")
        from taptune.gui import main_window

        assert main_window.assembly_beside is assembly.assembly_beside
