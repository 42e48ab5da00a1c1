"""Live tap recording: a pure trigger with pre-trigger buffer and a thin sounddevice wrapper.

The real-time path follows the guitar_tap pattern (STYLE.md): the PortAudio callback
only copies each block into a queue; :meth:`Recorder.poll`, called from a worker
thread, drains the queue, runs the :class:`TapTrigger` and writes the WAV after every
captured tap, so that nothing recorded is lost if the program later fails; a watchdog
in :meth:`Recorder.poll` turns a stream that stopped delivering audio (a device
unplugged mid-recording) into a :class:`~taptune.errors.DeviceError`.

The WAV holds the captured taps one after another, each with ``pre_trigger_s`` of the
sound before its onset (the noise floor the tap detector of the signal layer needs)
and ``tap_s`` after it, so consecutive taps are ``pre_trigger_s + tap_s`` apart.

``sounddevice`` is imported only when a stream is opened or devices are listed; a
missing PortAudio library, no input device or a device error become DeviceError with
a message a non-specialist can act on. :class:`FakeInputStream` stands in for a
sounddevice stream in tests (and anywhere without a sound card).
"""

from __future__ import annotations

import queue
import threading
import time
from collections import deque
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

import numpy as np

from taptune.errors import DeviceError, InputError
from taptune.io.atomic import atomic_write, check_writable

# Levels are reported in dB relative to full scale; silence is shown as this floor.
FLOOR_DBFS = -120.0
#: What a recording may be saved as, by suffix (lossless 24-bit; lossy formats would low-pass the taps).
RECORD_FORMATS = {".wav": "WAV", ".flac": "FLAC"}


def record_format(path) -> str:
    """The soundfile format of a recording file by its suffix; InputError for any other suffix.

    Before, every name got WAV data: ``taps.mp3`` or ``taps.flac`` held a WAV under a
    misleading name.
    """
    suffix = Path(path).suffix.lower()
    if suffix not in RECORD_FORMATS:
        raise InputError(f"{path}: recordings are saved as .wav or .flac; name the file so "
                         f"(got {suffix or 'no suffix'})")
    return RECORD_FORMATS[suffix]


def dbfs(amplitude: float) -> float:
    """Peak amplitude (full scale = 1) in dBFS, clipped to :data:`FLOOR_DBFS`."""
    if amplitude <= 0:
        return FLOOR_DBFS
    return max(FLOOR_DBFS, 20.0 * float(np.log10(amplitude)))


@dataclass(frozen=True)
class TriggerSettings:
    """How taps are detected and cut out of the live stream.

    Parameters
    ----------
    sample_rate : int
        Samples per second [Hz].
    channels : int
        Input channels recorded (all are kept; detection uses their mean).
    n_taps : int
        Taps to capture before the recording is complete.
    pre_trigger_s : float
        Sound kept before each onset [s] (the noise floor for the tap detector).
    tap_s : float
        Sound kept after each onset [s]; it also acts as the hold-off, so the ring-down
        of one tap never triggers the next.
    threshold_factor : float
        A tap starts where a sample exceeds this multiple of the running noise RMS.
    min_threshold : float
        Absolute floor of the trigger threshold (full scale = 1), so that a very quiet
        input (a muted microphone) does not trigger on its own noise.
    clip_level : float
        A tap whose peak reaches this level is clipped and rejected (the spectrum of a
        clipped tap has false harmonics).
    noise_window_s : float
        The noise RMS is the median over 10 ms frames of this much recent sound [s]
        (a median, so that a tap while listening does not raise the threshold).
    settle_s : float
        The trigger listens this long to the room before the first tap can trigger [s].
    """

    sample_rate: int = 48000
    channels: int = 1
    n_taps: int = 5
    pre_trigger_s: float = 0.1
    tap_s: float = 0.6
    threshold_factor: float = 10.0
    min_threshold: float = 0.01
    clip_level: float = 0.999
    noise_window_s: float = 0.5
    settle_s: float = 0.2

    def __post_init__(self):
        if self.sample_rate <= 0 or self.channels <= 0 or self.n_taps <= 0:
            raise InputError(
                f"recording: sample rate, channels and taps must be > 0, got "
                f"{self.sample_rate}, {self.channels}, {self.n_taps}"
            )
        if self.pre_trigger_s < 0 or self.tap_s <= 0:
            raise InputError(f"recording: pre-trigger ({self.pre_trigger_s} s) and tap length ({self.tap_s} s) are invalid")

    @property
    def pre_samples(self) -> int:
        return int(round(self.pre_trigger_s * self.sample_rate))

    @property
    def tap_samples(self) -> int:
        return int(round(self.tap_s * self.sample_rate))


@dataclass(frozen=True)
class CaptureEvent:
    """Something the trigger or the recorder reports.

    ``kind`` is ``"level"`` (a block arrived: ``level_db`` is its peak, ``threshold_db``
    the trigger threshold), ``"tap"`` (tap number ``index`` captured, peak
    ``level_db``), ``"rejected"`` (a tap was not kept, ``message`` says why),
    ``"saved"`` (the file ``path`` now holds ``index`` taps) or ``"done"`` (all taps
    captured).
    """

    kind: str
    index: int = 0
    level_db: float = FLOOR_DBFS
    threshold_db: float = FLOOR_DBFS
    message: str = ""
    path: str = ""


class TapTrigger:
    """Pure tap capture: feed blocks of samples, get events and the captured taps.

    No audio library, no threads, no clock: the same object runs in the live recorder
    and in the tests with synthetic blocks.

    Parameters
    ----------
    settings : TriggerSettings
    """

    def __init__(self, settings: TriggerSettings):
        self.settings = settings
        ch = settings.channels
        self._ring = np.zeros((0, ch))
        self._current: list[np.ndarray] | None = None
        self._current_len = 0
        # Noise floor: mean squares of 10 ms frames of the (mono) sound between taps.
        self._frame = max(1, int(round(0.01 * settings.sample_rate)))
        self._carry = np.zeros(0)
        self._frames: deque[float] = deque(maxlen=max(1, int(round(settings.noise_window_s / 0.01))))
        self._heard = 0
        self._settle_samples = max(self._frame, int(round(settings.settle_s * settings.sample_rate)))
        self.taps: list[np.ndarray] = []
        self.rejected = 0

    @property
    def done(self) -> bool:
        """True once ``n_taps`` taps are captured."""
        return len(self.taps) >= self.settings.n_taps

    @property
    def capturing(self) -> bool:
        """True between a tap's onset and the end of its segment."""
        return self._current is not None

    @property
    def ready(self) -> bool:
        """True once the noise floor is known and a tap can trigger.

        Without this wait the noise of a loud room would trigger at once, before its
        level is known.
        """
        return self._heard >= self._settle_samples

    @property
    def noise_rms(self) -> float:
        """Current estimate of the noise RMS (full scale = 1)."""
        return float(np.sqrt(np.median(self._frames))) if self._frames else 0.0

    @property
    def threshold(self) -> float:
        """Current trigger threshold (full scale = 1)."""
        return max(self.settings.min_threshold, self.settings.threshold_factor * self.noise_rms)

    def samples(self) -> np.ndarray:
        """The captured taps one after another, shape (n, channels), float64."""
        if not self.taps:
            return np.zeros((0, self.settings.channels))
        return np.concatenate(self.taps, axis=0)

    def feed(self, block: np.ndarray) -> list[CaptureEvent]:
        """Process one block of shape (frames, channels) or (frames,); return the events."""
        block = np.asarray(block, dtype=float)
        if block.ndim == 1:
            block = block[:, None]
        if block.shape[1] != self.settings.channels:
            raise InputError(f"recording: expected {self.settings.channels} channel(s), got a block with {block.shape[1]}")
        events = [
            CaptureEvent(
                "level",
                level_db=dbfs(float(np.max(np.abs(block)))) if block.size else FLOOR_DBFS,
                threshold_db=dbfs(self.threshold),
            )
        ]
        while block.shape[0] and not self.done:
            if self._current is None:
                block = self._armed(block)
            else:
                block, event = self._capture(block)
                if event is not None:
                    events.append(event)
                    if self.done:
                        events.append(CaptureEvent("done", index=len(self.taps)))
        return events

    def _armed(self, block: np.ndarray) -> np.ndarray:
        """Look for an onset; return what is left of the block after it (or nothing)."""
        if not self.ready:
            # Listen to the room only until the noise floor is known, then look for
            # taps in the rest of the block.
            need = self._settle_samples - self._heard
            self._update_noise(block[:need].mean(axis=1))
            self._push_ring(block[:need])
            return block[need:]
        mono = np.abs(block.mean(axis=1))
        above = np.flatnonzero(mono > self.threshold)
        if above.size == 0:
            self._update_noise(block.mean(axis=1))
            self._push_ring(block)
            return block[:0]
        onset = int(above[0])
        self._update_noise(block[:onset].mean(axis=1))
        self._push_ring(block[:onset])
        self._current = [self._ring.copy()]
        self._current_len = self._ring.shape[0]
        self._ring = self._ring[:0]
        return block[onset:]

    def _capture(self, block: np.ndarray) -> tuple[np.ndarray, CaptureEvent | None]:
        """Add to the tap being captured; return the rest of the block and an event when it is complete."""
        # A tap right after arming may have less pre-trigger sound than asked for; its
        # segment is still tap_s long after the onset.
        length = self._current[0].shape[0] + self.settings.tap_samples
        take = block[: length - self._current_len]
        self._current.append(take)
        self._current_len += take.shape[0]
        rest = block[take.shape[0]:]
        if self._current_len < length:
            return rest, None
        segment = np.concatenate(self._current, axis=0)
        self._current, self._current_len = None, 0
        peak = float(np.max(np.abs(segment)))
        if peak >= self.settings.clip_level:
            self.rejected += 1
            return rest, CaptureEvent(
                "rejected",
                index=len(self.taps) + 1,
                level_db=dbfs(peak),
                message="the tap was clipped (too loud): tap more gently or lower the input gain",
            )
        self.taps.append(segment)
        return rest, CaptureEvent("tap", index=len(self.taps), level_db=dbfs(peak))

    def _push_ring(self, block: np.ndarray) -> None:
        keep = self.settings.pre_samples
        if keep == 0:
            return
        self._ring = np.concatenate([self._ring, block], axis=0)[-keep:]

    def _update_noise(self, mono: np.ndarray) -> None:
        """Add sound heard between taps to the noise-floor frames."""
        self._heard += mono.size
        x = np.concatenate([self._carry, mono])
        n_full = x.size // self._frame
        if n_full:
            frames = x[: n_full * self._frame].reshape(n_full, self._frame)
            self._frames.extend(np.mean(frames**2, axis=1).tolist())
        self._carry = x[n_full * self._frame:]

# --------------------------------------------------------------------------- devices


@dataclass(frozen=True)
class InputDevice:
    """An audio input: PortAudio index, name, input channels, default sample rate [Hz]."""

    index: int
    name: str
    channels: int
    default_samplerate: float

    def label(self) -> str:
        return f"{self.index}: {self.name} ({self.channels} ch, {self.default_samplerate:g} Hz)"


def _sounddevice():
    """Import sounddevice, turning a missing PortAudio or package into DeviceError."""
    try:
        import sounddevice
    except OSError:
        raise DeviceError(
            "no audio library: the PortAudio library was not found "
            "(on Debian/Ubuntu: sudo apt install libportaudio2)"
        ) from None
    except ImportError:
        raise DeviceError(
            "no audio library: the Python package sounddevice is not installed (pip install 'taptune[audio]')"
        ) from None
    return sounddevice


def input_devices() -> list[InputDevice]:
    """Every audio device with at least one input channel (DeviceError without PortAudio)."""
    sd = _sounddevice()
    try:
        devices = sd.query_devices()
    except sd.PortAudioError as err:
        raise DeviceError(f"cannot list audio devices: {err}") from None
    return [
        InputDevice(i, str(d["name"]), int(d["max_input_channels"]), float(d["default_samplerate"]))
        for i, d in enumerate(devices)
        if int(d["max_input_channels"]) > 0
    ]


def find_input_device(device: int | str | None = None, devices: list[InputDevice] | None = None) -> InputDevice:
    """The input device by index, by (part of its) name, or the default one.

    Raises
    ------
    DeviceError
        No input device at all, or none matching ``device``.
    """
    devices = input_devices() if devices is None else devices
    if not devices:
        raise DeviceError("no audio input device found: connect a microphone (or headset) and try again")
    if device is None or device == "":
        default = default_input_index()
        return next((d for d in devices if d.index == default), devices[0])
    if isinstance(device, int) or str(device).strip().isdigit():
        index = int(device)
        for d in devices:
            if d.index == index:
                return d
        raise DeviceError(f"no audio input device number {index}; inputs are: {_names(devices)}")
    matches = [d for d in devices if str(device).lower() in d.name.lower()]
    if not matches:
        raise DeviceError(f"no audio input device named like {device!r}; inputs are: {_names(devices)}")
    return matches[0]


def _names(devices: list[InputDevice]) -> str:
    return "; ".join(d.label() for d in devices)


def default_input_index() -> int:
    """PortAudio index of the default input device (-1 when there is none)."""
    try:
        default = _sounddevice().default.device[0]
    except DeviceError:
        return -1
    return int(default) if default is not None else -1


def sounddevice_stream(*, device, samplerate, channels, blocksize, callback):
    """Open (not start) a ``sounddevice.InputStream``; DeviceError on PortAudio errors."""
    sd = _sounddevice()
    try:
        return sd.InputStream(
            device=device,
            samplerate=samplerate,
            channels=channels,
            blocksize=blocksize,
            dtype="float32",
            callback=callback,
        )
    except (sd.PortAudioError, ValueError) as err:
        raise DeviceError(f"cannot open audio input {device}: {err}") from None


class FakeInputStream:
    """A stand-in for ``sounddevice.InputStream`` that plays given samples into the callback.

    A feeder thread calls ``callback(block, frames, time_info, status)`` for each block
    of ``samples``, as fast as it can (tests stay fast) or, with ``realtime_rate``
    [Hz], at the pace of a real device (demonstrations). After the last block it either stays open and silent (``end="idle"``, like a
    quiet room) or goes inactive (``end="lost"``, like an unplugged device).

    Parameters
    ----------
    samples : ndarray, shape (n,) or (n, channels)
    blocksize : int
    end : {"idle", "lost"}
    callback : callable
        The sounddevice-style callback.
    realtime_rate : float, optional
        Deliver the blocks at this sample rate [Hz] instead of at once.
    """

    def __init__(self, samples, *, blocksize: int = 1024, end: str = "idle", callback=None,
                 realtime_rate: float | None = None, **_ignored):
        samples = np.asarray(samples, dtype=np.float32)
        self.samples = samples[:, None] if samples.ndim == 1 else samples
        self.blocksize = int(blocksize)
        self.end = end
        self.callback = callback
        self.realtime_rate = realtime_rate
        self.active = False
        self.closed = False
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None

    def factory(self, *, device, samplerate, channels, blocksize, callback):
        """Use as ``stream_factory`` of :class:`Recorder`: adopt its callback, return self."""
        self.callback = callback
        self.blocksize = int(blocksize)
        return self

    def start(self):
        self.active = True
        self._thread = threading.Thread(target=self._feed, name="fake-input-stream", daemon=True)
        self._thread.start()

    def _feed(self):
        n = self.samples.shape[0]
        for start in range(0, n, self.blocksize):
            if self._stop.is_set():
                return
            block = self.samples[start:start + self.blocksize]
            self.callback(block, block.shape[0], None, _NoStatus())
            if self.realtime_rate:
                self._stop.wait(block.shape[0] / self.realtime_rate)
        if self.end == "lost":
            self.active = False

    def stop(self):
        self._stop.set()
        if self._thread is not None:
            self._thread.join()
        self.active = False

    def close(self):
        self.stop()
        self.closed = True


class _NoStatus:
    """sounddevice's CallbackFlags with no flag set (falsy)."""

    def __bool__(self):
        return False


# --------------------------------------------------------------------------- recorder


@dataclass
class _Watchdog:
    """Notices a stream that stopped delivering blocks."""

    timeout_s: float
    clock: Callable[[], float]
    last: float = field(default=0.0)

    def kick(self):
        self.last = self.clock()

    def stalled(self) -> bool:
        return self.clock() - self.last > self.timeout_s


class Recorder:
    """Record taps from an input device into a WAV file (with a sidecar assembly file).

    Use from one worker thread: :meth:`start`, then :meth:`poll` until :attr:`done`,
    then :meth:`close` (or use it as a context manager). The WAV is rewritten after
    every captured tap (atomically), so an interrupted session keeps the taps so far.

    Parameters
    ----------
    out_path : path
        The WAV to write (its folder is created).
    settings : TriggerSettings
    device : int, str or None
        PortAudio device index or name; None = the default input.
    assembly_toml : str, optional
        Text of the assembly file, written beside the WAV with the same stem.
    stream_factory : callable, optional
        ``factory(device=, samplerate=, channels=, blocksize=, callback=)`` returning an
        unstarted stream; default :func:`sounddevice_stream` (tests pass
        :meth:`FakeInputStream.factory`).
    blocksize : int
        Frames per callback block.
    stall_timeout_s : float
        The watchdog reports a lost device after this long without a block [s].
    clock : callable
        Monotonic clock [s] (injected by tests).
    """

    def __init__(
        self,
        out_path,
        settings: TriggerSettings = TriggerSettings(),
        device: int | str | None = None,
        assembly_toml: str | None = None,
        stream_factory=None,
        blocksize: int = 1024,
        stall_timeout_s: float = 2.0,
        clock: Callable[[], float] = time.monotonic,
    ):
        self.out_path = Path(out_path)
        self.settings = settings
        self.device = device
        self.assembly_toml = assembly_toml
        self.blocksize = blocksize
        self.trigger = TapTrigger(settings)
        self._factory = stream_factory
        self._queue: queue.Queue = queue.Queue()
        self._stream = None
        self._watchdog = _Watchdog(stall_timeout_s, clock)
        self.overflows = 0
        self.saved_taps = 0

    @property
    def done(self) -> bool:
        return self.trigger.done

    @property
    def sidecar_path(self) -> Path:
        """The assembly file written beside the WAV."""
        return self.out_path.with_suffix(".toml")

    def _callback(self, indata, frames, time_info, status):
        # Real-time thread: copy and hand over, nothing else (no allocation-heavy work,
        # no locks held, no analysis).
        self._queue.put((np.array(indata, dtype=np.float64, copy=True), bool(status)))

    def start(self) -> None:
        """Open and start the input stream.

        Nothing is written here, not even the WAV's folder: the WAV and its sidecar
        assembly file appear with the first tap, so a missing microphone (or a session
        with no tap) leaves no files behind. A folder that could never be written is
        refused now, before the user taps.
        """
        record_format(self.out_path)
        check_writable(self.out_path)
        if self.assembly_toml is not None:
            check_writable(self.sidecar_path)
        factory = self._factory or sounddevice_stream
        if self._factory is None:
            resolved = find_input_device(self.device)
            device = resolved.index
        else:
            device = self.device
        self._stream = factory(
            device=device,
            samplerate=self.settings.sample_rate,
            channels=self.settings.channels,
            blocksize=self.blocksize,
            callback=self._callback,
        )
        try:
            self._stream.start()
        except Exception as err:  # PortAudio raises its own error type; any failure here is the device's
            self._stream = None
            raise DeviceError(f"cannot start audio input {device}: {err}") from None
        self._watchdog.kick()

    def poll(self, timeout: float = 0.05) -> list[CaptureEvent]:
        """Process the blocks that arrived (waiting up to ``timeout`` s for the first).

        Raises
        ------
        DeviceError
            The stream stopped or delivered nothing for ``stall_timeout_s`` (device lost);
            the taps captured so far are already in the WAV.
        """
        events: list[CaptureEvent] = []
        try:
            item = self._queue.get(timeout=timeout)
        except queue.Empty:
            item = None
        while item is not None:
            block, flagged = item
            self._watchdog.kick()
            self.overflows += int(flagged)
            for event in self.trigger.feed(block):
                events.append(event)
                if event.kind == "tap":
                    self._save()
                    events.append(CaptureEvent("saved", index=self.saved_taps, path=str(self.out_path)))
            if self.done:
                break
            try:
                item = self._queue.get_nowait()
            except queue.Empty:
                item = None
        if not self.done and self._stream is not None:
            if not getattr(self._stream, "active", True) and self._queue.empty():
                raise DeviceError(f"the audio input stopped (device unplugged?); {self._kept()}")
            if self._watchdog.stalled():
                raise DeviceError(
                    f"no sound from the audio input for {self._watchdog.timeout_s:g} s "
                    f"(device unplugged or used by another program?); {self._kept()}"
                )
        return events

    def _kept(self) -> str:
        if self.saved_taps:
            return f"the {self.saved_taps} tap(s) recorded so far are saved in {self.out_path}"
        return "no tap was recorded"

    def _save(self) -> None:
        # The taps first: a sidecar that cannot be written must not cost the recording.
        try:
            _atomic_write_wav(self.out_path, self.trigger.samples(), self.settings.sample_rate,
                              record_format(self.out_path))
        except OSError as err:
            raise DeviceError(f"cannot save {self.out_path}: {err.strerror or err}; {self._kept()}") from None
        first = self.saved_taps == 0
        self.saved_taps = len(self.trigger.taps)
        if first and self.assembly_toml is not None:
            # With the first tap: the sidecar goes beside the WAV only once there is a WAV.
            try:
                _atomic_write_text(self.sidecar_path, self.assembly_toml)
            except OSError as err:
                raise DeviceError(f"cannot save {self.sidecar_path}: {err.strerror or err}; {self._kept()}") from None

    def close(self) -> None:
        """Stop and close the stream (safe to call twice, and after a device error)."""
        stream, self._stream = self._stream, None
        if stream is None:
            return
        for method in ("stop", "close"):
            try:
                getattr(stream, method)()
            except Exception:  # noqa: BLE001 - a lost device may refuse to stop; it is closed anyway
                pass

    def __enter__(self):
        self.start()
        return self

    def __exit__(self, *exc):
        self.close()
        return False


def _atomic_write_text(path: Path, text: str) -> None:
    atomic_write(path, lambda tmp: tmp.write_text(text, encoding="utf-8"))


def _atomic_write_wav(path: Path, samples: np.ndarray, sample_rate: int, format: str = "WAV") -> None:
    """Write a 24-bit WAV (or FLAC) through a temporary file so a crash never leaves half a file."""
    import soundfile

    def write(tmp: Path) -> None:
        soundfile.write(str(tmp), np.clip(samples, -1.0, 1.0), int(sample_rate), subtype="PCM_24", format=format)

    atomic_write(path, write)
