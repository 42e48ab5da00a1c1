"""A WAV file cut short (a copy or recording interrupted: the header announces more audio than
the file holds) is read, as libsndfile does silently, but with a warning naming the file and
both durations, which reaches the user with the analysis' warnings."""

import json
import struct

import numpy as np
import pytest

from taptune.cli import main
from taptune.errors import InputError
from taptune.io.audio import read_audio, wav_data_sizes, write_audio
from taptune.signal.analysis import analyse_recording

from tests.signal.synthetic import workshop_recording


def _cut(path, fraction: float) -> None:
    raw = path.read_bytes()
    path.write_bytes(raw[: int(len(raw) * fraction)])


def _message(path, n_announced: int, n_holds: int, rate: int = 48000) -> str:
    return (f"{path}: the file is cut short (an interrupted copy or recording?): its header announces "
            f"{n_announced} samples ({n_announced / rate:.3f} s) but it holds only {n_holds} "
            f"({n_holds / rate:.3f} s); the analysis uses what is there")


@pytest.mark.parametrize("subtype,fmt", [("PCM_16", "WAV"), ("PCM_24", "WAV"), ("FLOAT", "WAV"), ("PCM_24", "RF64")])
def test_a_wav_cut_at_60_percent_warns_with_both_durations(tmp_path, subtype, fmt):
    import soundfile as sf

    path = tmp_path / "tap.wav"
    rec = workshop_recording(0)  # 2.000 s at 48 kHz
    sf.write(str(path), rec.samples, 48000, subtype=subtype, format=fmt)
    assert read_audio(path).warnings == ()
    _cut(path, 0.6)
    cut = read_audio(path)
    holds = cut.samples.shape[0]
    assert cut.duration_s == pytest.approx(1.2, abs=1e-3)
    assert cut.warnings == (_message(path, 96000, holds),)
    analysis = analyse_recording(cut)
    assert analysis.warnings[0] == _message(path, 96000, holds)
    assert analysis.bending_hz  # the taps that are there are still analysed


def test_the_cli_prints_the_warning_and_puts_it_in_the_json(tmp_path, capsys):
    path = tmp_path / "copy.wav"
    write_audio(path, workshop_recording(0).samples, 48000, subtype="PCM_16")
    _cut(path, 0.6)
    out_json = tmp_path / "copy.json"
    holds = read_audio(path).samples.shape[0]
    assert main(["spectrum", str(path), "--json", str(out_json)]) == 0
    assert json.loads(out_json.read_text())["warnings"][0] == _message(path, 96000, holds)
    out, err = capsys.readouterr()
    assert f"warning: {_message(path, 96000, holds)}" in out + err and "Traceback" not in err


def test_a_cut_before_the_first_tap_says_so_in_the_error(tmp_path):
    path = tmp_path / "early.wav"
    write_audio(path, workshop_recording(0).samples, 48000, subtype="PCM_16")
    _cut(path, 0.05)  # 0.1 s kept; the first tap is at 0.2 s
    with pytest.raises(InputError) as info:
        analyse_recording(read_audio(path))
    assert str(info.value).startswith(f"{path}: no tap found: the file is cut short (an interrupted copy or recording?): "
                                      "its header announces 96000 samples (2.000 s) but it holds only ")
    assert "(0.100 s)" in str(info.value)


def test_a_cut_of_one_frame_is_told_by_its_samples(tmp_path):
    # Both durations read 2.000 s; the sample counts tell them apart.
    path = tmp_path / "almost.wav"
    write_audio(path, workshop_recording(0).samples, 48000, subtype="PCM_16")
    _cut(path, 1 - 2 / path.stat().st_size)
    assert "announces 96000 samples (2.000 s) but it holds only 95999 (2.000 s)" in read_audio(path).warnings[0]


def test_complete_files_with_chunks_after_the_data_or_an_open_size_do_not_warn(tmp_path):
    x = 0.1 * np.random.default_rng(2).standard_normal(4800)
    path = tmp_path / "list.wav"
    write_audio(path, x, 48000, subtype="PCM_16")
    raw = bytearray(path.read_bytes())
    raw += b"LIST" + struct.pack("<I", 5) + b"INFOx\0"  # odd size, padded
    raw[4:8] = struct.pack("<I", len(raw) - 8)
    path.write_bytes(bytes(raw))
    assert wav_data_sizes(path) == (9600, 9600 + 14, 2, 48000)
    assert read_audio(path).warnings == ()
    # A recorder that streams writes 0xFFFFFFFF until it closes: no size to compare with.
    data = bytes(raw).index(b"data")
    raw[data + 4:data + 8] = b"\xff\xff\xff\xff"
    path.write_bytes(bytes(raw))
    assert wav_data_sizes(path) is None


@pytest.mark.parametrize("content", [b"", b"RIFF", b"RIFF\x10\0\0\0WAVEfmt ", b"fLaC" + bytes(40)])
def test_headers_that_are_no_whole_wav_are_left_to_the_reader(tmp_path, content):
    path = tmp_path / "odd.wav"
    path.write_bytes(content)
    assert wav_data_sizes(path) is None
