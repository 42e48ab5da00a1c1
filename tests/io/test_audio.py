"""Reading audio: every common format round-trips; every bad file is one clear InputError."""

import numpy as np
import pytest
import soundfile as sf

from taptune.errors import InputError
from taptune.io.audio import MIN_SAMPLE_RATE, make_recording, read_audio, write_audio


def _tone(fs, channels=1, seconds=0.2, amp=0.5):
    t = np.arange(int(fs * seconds)) / fs
    x = amp * np.sin(2 * np.pi * 1000 * t)
    return np.column_stack([x * (1 - 0.2 * c) for c in range(channels)])


@pytest.mark.parametrize("ext,subtype,tol", [
    ("wav", "PCM_16", 2.0 ** -15), ("wav", "PCM_24", 2.0 ** -23), ("wav", "PCM_32", 2.0 ** -31),
    ("wav", "FLOAT", 1e-7), ("wav", "DOUBLE", 1e-15), ("flac", "PCM_16", 2.0 ** -15),
    ("flac", "PCM_24", 2.0 ** -23),
])
@pytest.mark.parametrize("fs,channels", [(44100, 1), (48000, 2), (96000, 2)])
def test_formats_round_trip_to_within_one_lsb(tmp_path, ext, subtype, tol, fs, channels):
    x = _tone(fs, channels)
    path = tmp_path / f"t.{ext}"
    write_audio(path, x, fs, subtype)
    rec = read_audio(path)
    assert rec.sample_rate == fs and rec.channels == channels and rec.subtype == subtype
    assert rec.samples.shape == x.shape and rec.samples.dtype == np.float64
    assert np.max(np.abs(rec.samples - x)) <= tol
    assert rec.path == str(path) and rec.duration_s == pytest.approx(0.2)


def test_recording_is_read_only(tmp_path):
    path = tmp_path / "t.wav"
    write_audio(path, _tone(48000), 48000)
    with pytest.raises(ValueError):
        read_audio(path).samples[0, 0] = 1.0


def _bad(path, fragment):
    with pytest.raises(InputError) as err:
        read_audio(path)
    msg = str(err.value)
    assert "\n" not in msg and str(path) in msg and fragment in msg
    return msg


def test_missing_file(tmp_path):
    _bad(tmp_path / "nope.wav", "no such file")


def test_folder(tmp_path):
    _bad(tmp_path, "folder")


def test_empty_file(tmp_path):
    p = tmp_path / "empty.wav"
    p.write_bytes(b"")
    _bad(p, "empty")


def test_not_audio(tmp_path):
    p = tmp_path / "notes.wav"
    p.write_text("these are my notes, not a recording\n" * 20)
    _bad(p, "not a readable audio file")


def test_truncated_header(tmp_path):
    p = tmp_path / "t.wav"
    write_audio(p, _tone(48000), 48000)
    p.write_bytes(p.read_bytes()[:30])
    _bad(p, "not a readable audio file")


def test_header_only_has_no_samples(tmp_path):
    p = tmp_path / "t.wav"
    write_audio(p, _tone(48000), 48000, "PCM_16")
    p.write_bytes(p.read_bytes()[:44])
    _bad(p, "")


def test_nan_and_inf_samples(tmp_path):
    x = _tone(48000)
    x[100, 0] = np.nan
    x[200, 0] = np.inf
    p = tmp_path / "nan.wav"
    sf.write(str(p), x, 48000, subtype="FLOAT")
    _bad(p, "NaN or infinite")


def test_rate_too_low(tmp_path):
    p = tmp_path / "low.wav"
    write_audio(p, _tone(4000), 4000)
    msg = _bad(p, "too low")
    assert str(MIN_SAMPLE_RATE) in msg


def test_make_recording_checks_shapes():
    with pytest.raises(InputError):
        make_recording(np.zeros((0, 1)), 48000)
    with pytest.raises(InputError):
        make_recording(np.zeros((10, 12)), 48000)
    assert make_recording(np.zeros(10), 48000).channels == 1


def test_an_unreadable_file_says_permission_denied(tmp_path, monkeypatch):
    """libsndfile said only 'System error' (root reads everything, so access is faked here)."""
    from taptune.io import audio

    path = tmp_path / "locked.wav"
    audio.write_audio(path, np.zeros((4800, 1)), 48000)
    monkeypatch.setattr(audio.os, "access", lambda p, mode: False)
    with pytest.raises(InputError, match=r"locked.wav: cannot read \(permission denied\)"):
        audio.read_audio(path)
