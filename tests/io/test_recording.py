"""Live tap capture: the pure trigger, the recorder with a fake input stream, device errors.

The taps are synthetic: a decaying sine (4.7 kHz, ζ = 0.4 %, the first bending mode of
the reference assembly) on a -70 dBFS noise floor, which is what a tap on a tool tip
sounds like to a microphone.
"""

import builtins
import types

import numpy as np
import pytest
import soundfile

from taptune.errors import DeviceError
from taptune.io import recording as rec
from taptune.io.recording import (
    FakeInputStream,
    InputDevice,
    Recorder,
    TapTrigger,
    TriggerSettings,
    find_input_device,
)

FS = 48000


def synthetic_taps(onsets_s, fs=FS, seconds=None, amplitude=0.5, f_hz=4700.0, zeta=0.004, noise=3e-4, seed=0):
    """Mono tap sounds: decaying sines starting at ``onsets_s`` on white noise, shape (n,)."""
    seconds = seconds if seconds is not None else max(onsets_s) + 1.0
    rng = np.random.default_rng(seed)
    x = noise * rng.standard_normal(int(seconds * fs))
    t = np.arange(int(0.5 * fs)) / fs
    burst = amplitude * np.exp(-zeta * 2 * np.pi * f_hz * t) * np.sin(2 * np.pi * f_hz * t)
    for t0 in onsets_s:
        i = int(round(t0 * fs))
        n = min(burst.size, x.size - i)
        x[i:i + n] += burst[:n]
    return x


def feed_in_blocks(trigger, x, blocksize):
    events = []
    for start in range(0, x.shape[0], blocksize):
        events += trigger.feed(x[start:start + blocksize])
    return events


def test_trigger_captures_each_tap_with_its_pre_trigger_sound():
    settings = TriggerSettings(sample_rate=FS, n_taps=3, pre_trigger_s=0.1, tap_s=0.6)
    x = synthetic_taps([0.5, 1.4, 2.3])
    trigger = TapTrigger(settings)
    events = feed_in_blocks(trigger, x, 512)
    assert [e.index for e in events if e.kind == "tap"] == [1, 2, 3]
    assert [e.kind for e in events if e.kind in ("done",)] == ["done"]
    assert trigger.done and len(trigger.taps) == 3
    for segment, t0 in zip(trigger.taps, [0.5, 1.4, 2.3]):
        assert segment.shape == (settings.pre_samples + settings.tap_samples, 1)
        # The onset (first sample above the -40 dBFS threshold) sits right after the
        # 0.1 s of pre-trigger sound: the sine's second sample already exceeds it.
        onset = int(np.flatnonzero(np.abs(segment[:, 0]) > settings.min_threshold)[0])
        assert settings.pre_samples <= onset <= settings.pre_samples + 2
        # The pre-trigger part is the noise floor (-70 dBFS), not the tap.
        assert np.max(np.abs(segment[: settings.pre_samples - 5])) < 0.01
    start = int(round(0.5 * FS)) - settings.pre_samples
    np.testing.assert_allclose(trigger.taps[0][:, 0], x[start + 1:start + 1 + trigger.taps[0].shape[0]], atol=0)


def test_capture_does_not_depend_on_the_block_size():
    settings = TriggerSettings(sample_rate=FS, n_taps=2)
    x = synthetic_taps([0.3, 1.2])
    a, b = TapTrigger(settings), TapTrigger(settings)
    feed_in_blocks(a, x, 128)
    feed_in_blocks(b, x, 4096)
    np.testing.assert_array_equal(a.samples(), b.samples())


def test_a_slow_ring_down_is_one_tap_and_a_clipped_tap_is_rejected():
    settings = TriggerSettings(sample_rate=FS, n_taps=5)
    slow = synthetic_taps([0.4], zeta=0.0005, seconds=1.7)  # rings ~0.3 s above the threshold
    trigger = TapTrigger(settings)
    feed_in_blocks(trigger, slow, 1000)
    assert len(trigger.taps) == 1
    loud = synthetic_taps([0.4], amplitude=1.5, seconds=1.2)
    trigger = TapTrigger(settings)
    events = feed_in_blocks(trigger, loud, 1000)
    rejected = [e for e in events if e.kind == "rejected"]
    assert len(rejected) == 1 and "clipped" in rejected[0].message
    assert trigger.taps == []


def test_threshold_follows_a_noisy_room():
    """In a -30 dBFS workshop the threshold rises to 10× the noise RMS, so noise never triggers."""
    settings = TriggerSettings(sample_rate=FS, n_taps=1)
    noisy = synthetic_taps([1.5], noise=0.03, amplitude=0.9, seconds=2.5)
    trigger = TapTrigger(settings)
    events = feed_in_blocks(trigger, noisy, 1024)
    taps = [e for e in events if e.kind == "tap"]
    assert len(taps) == 1
    assert trigger.threshold == pytest.approx(0.3, rel=0.1)
    # The captured segment is the tap (peak 0.9 right after the pre-trigger part).
    segment = trigger.taps[0][:, 0]
    assert np.argmax(np.abs(segment)) - settings.pre_samples < 0.001 * FS
    assert np.max(np.abs(segment[: settings.pre_samples - 50])) < 0.3


def test_nothing_triggers_while_the_noise_floor_is_being_learned():
    settings = TriggerSettings(sample_rate=FS, n_taps=1, settle_s=0.2)
    trigger = TapTrigger(settings)
    trigger.feed(synthetic_taps([0.05], seconds=0.15))
    assert not trigger.ready and trigger.taps == []
    trigger.feed(synthetic_taps([0.5], seconds=1.5))
    assert trigger.ready and len(trigger.taps) == 1


def test_recorder_writes_wav_and_sidecar_after_every_tap(tmp_path):
    x = synthetic_taps([0.3, 1.1, 1.9, 2.7])
    fake = FakeInputStream(x)
    out = tmp_path / "rec" / "tap.wav"
    settings = TriggerSettings(sample_rate=FS, n_taps=3)
    with Recorder(out, settings, assembly_toml="[holder]\nname = 'x'\n", stream_factory=fake.factory) as recorder:
        saved = []
        while not recorder.done:
            saved += [e for e in recorder.poll(timeout=1.0) if e.kind == "saved"]
    assert [e.index for e in saved] == [1, 2, 3]
    assert fake.closed
    data, fs = soundfile.read(out, always_2d=True)
    assert fs == FS and data.shape == (3 * (settings.pre_samples + settings.tap_samples), 1)
    assert soundfile.info(out).subtype == "PCM_24"
    assert out.with_suffix(".toml").read_text() == "[holder]\nname = 'x'\n"
    assert sorted(p.name for p in out.parent.iterdir()) == ["tap.toml", "tap.wav"]


def test_device_lost_mid_recording_raises_and_keeps_the_taps(tmp_path):
    x = synthetic_taps([0.3], seconds=1.5)
    fake = FakeInputStream(x, end="lost")
    out = tmp_path / "lost.wav"
    recorder = Recorder(out, TriggerSettings(sample_rate=FS, n_taps=3), stream_factory=fake.factory)
    recorder.start()
    with pytest.raises(DeviceError, match="unplugged") as info:
        for _ in range(1000):
            recorder.poll(timeout=0.5)
    recorder.close()
    assert "1 tap(s) recorded so far are saved" in str(info.value)
    assert soundfile.info(out).frames == recorder.settings.pre_samples + recorder.settings.tap_samples


def test_watchdog_reports_a_stream_that_stops_delivering(tmp_path):
    now = [0.0]
    fake = FakeInputStream(np.zeros(2048))  # two blocks, then silence without callbacks
    recorder = Recorder(tmp_path / "x.wav", TriggerSettings(sample_rate=FS), stream_factory=fake.factory,
                        stall_timeout_s=2.0, clock=lambda: now[0])
    recorder.start()
    recorder.poll(timeout=1.0)
    now[0] = 1.0
    recorder.poll(timeout=0.0)
    now[0] = 3.5
    with pytest.raises(DeviceError, match="no sound from the audio input for 2 s"):
        recorder.poll(timeout=0.0)
    recorder.close()
    recorder.close()


def test_missing_portaudio_is_a_clear_device_error(monkeypatch):
    real_import = builtins.__import__

    def no_portaudio(name, *args, **kwargs):
        if name == "sounddevice":
            raise OSError("PortAudio library not found")
        return real_import(name, *args, **kwargs)

    monkeypatch.setattr(builtins, "__import__", no_portaudio)
    with pytest.raises(DeviceError, match="PortAudio library was not found.*libportaudio2"):
        rec.input_devices()


def test_no_input_device_and_unknown_device_are_clear_errors(monkeypatch):
    fake_sd = types.SimpleNamespace(
        query_devices=lambda: [{"name": "HDMI out", "max_input_channels": 0, "default_samplerate": 48000.0}],
        PortAudioError=RuntimeError,
        default=types.SimpleNamespace(device=[-1, -1]),
    )
    monkeypatch.setattr(rec, "_sounddevice", lambda: fake_sd)
    with pytest.raises(DeviceError, match="no audio input device found"):
        find_input_device()
    devices = [InputDevice(0, "USB mic", 1, 48000.0), InputDevice(3, "Headset", 2, 44100.0)]
    assert find_input_device("headset", devices).index == 3
    assert find_input_device("3", devices).name == "Headset"
    assert find_input_device(None, devices).index == 0
    with pytest.raises(DeviceError, match="no audio input device number 7; inputs are: 0: USB mic"):
        find_input_device(7, devices)
    with pytest.raises(DeviceError, match="named like 'webcam'"):
        find_input_device("webcam", devices)
