"""``taptune record``: clear one-line errors without audio, and a full headless capture.

The capture runs against :class:`FakeInputStream` playing synthetic taps, put in place
of sounddevice's stream; nothing here needs a sound card.
"""

import soundfile

from taptune.cli import main
from taptune.io import recording
from taptune.io.recording import FakeInputStream, InputDevice
from tests.io.test_recording import FS, synthetic_taps


def _fake_device(monkeypatch, stream):
    monkeypatch.setattr(recording, "input_devices", lambda: [InputDevice(4, "Fake USB mic", 1, 48000.0)])
    monkeypatch.setattr(recording, "default_input_index", lambda: 4)
    monkeypatch.setattr(recording, "sounddevice_stream", stream.factory)


def test_no_input_device_is_one_line_and_exit_2(monkeypatch, tmp_path, capsys):
    monkeypatch.setattr(recording, "input_devices", lambda: [])
    assert main(["record", "--out", str(tmp_path / "x.wav")]) == 2
    err = capsys.readouterr().err
    assert err.strip() == "taptune record: no audio input device found: connect a microphone (or headset) and try again"
    assert not (tmp_path / "x.wav").exists()


def test_no_portaudio_is_one_line_and_exit_2(monkeypatch, tmp_path, capsys):
    from taptune.errors import DeviceError

    def no_library():
        raise DeviceError("no audio library: the PortAudio library was not found")

    monkeypatch.setattr(recording, "_sounddevice", no_library)
    assert main(["record", "--out", str(tmp_path / "x.wav")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "PortAudio" in err and "Traceback" not in err


def test_records_taps_and_the_sidecar_assembly(monkeypatch, tmp_path, capsys, reference_toml):
    _fake_device(monkeypatch, FakeInputStream(synthetic_taps([0.3, 1.1, 1.9])))
    out = tmp_path / "recordings" / "er32.wav"
    status = main(["record", "--out", str(out), "--taps", "3", "--device", "usb", "--assembly", str(reference_toml)])
    captured = capsys.readouterr()
    assert status == 0, captured.err
    assert "tap 3/3" in captured.err and "Fake USB mic" in captured.err
    assert soundfile.info(out).frames == 3 * int(0.7 * FS)
    assert out.with_suffix(".toml").read_text() == reference_toml.read_text()


def test_device_lost_keeps_the_taps_and_exits_1(monkeypatch, tmp_path, capsys):
    _fake_device(monkeypatch, FakeInputStream(synthetic_taps([0.3], seconds=1.5), end="lost"))
    out = tmp_path / "lost.wav"
    assert main(["record", "--out", str(out), "--taps", "3"]) == 1
    err = capsys.readouterr().err
    assert "unplugged" in err and "1 tap(s) recorded so far are saved" in err
    assert soundfile.info(out).frames == int(0.7 * FS)


def test_bad_assembly_is_exit_2_before_recording(monkeypatch, tmp_path, capsys):
    _fake_device(monkeypatch, FakeInputStream(synthetic_taps([0.3])))
    bad = tmp_path / "bad.toml"
    bad.write_text("[holder]\n")
    assert main(["record", "--out", str(tmp_path / "x.wav"), "--assembly", str(bad)]) == 2
    assert str(bad) in capsys.readouterr().err
