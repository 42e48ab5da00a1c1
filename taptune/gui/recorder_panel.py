"""Recording panel: input device, live level meter, arm → taps → WAV saved at once.

The audio path is the guitar_tap pattern: the sounddevice callback only queues blocks
(:class:`taptune.io.recording.Recorder`); :class:`RecorderWorker` drains the queue in
its own QThread, runs the trigger and the watchdog and writes the WAV after every tap;
Qt signals carry levels and taps to this panel. A missing audio library, no device or a
device lost mid-recording becomes a message; the taps recorded so far stay on disk.
"""

from __future__ import annotations

import re
import threading
import time
from pathlib import Path

from PySide6.QtCore import QObject, QThread, Signal, Slot
from PySide6.QtWidgets import (
    QComboBox,
    QFileDialog,
    QFormLayout,
    QGroupBox,
    QHBoxLayout,
    QLabel,
    QLineEdit,
    QProgressBar,
    QPushButton,
    QSpinBox,
    QVBoxLayout,
    QWidget,
)

from taptune.gui.signals import emit

METER_FLOOR_DB = -80.0
#: Where the folder last recorded into is remembered (QSettings).
FOLDER_KEY = "record/folder"


def default_recordings_folder() -> Path:
    """A folder of the user's for new recordings: ``taptune-recordings`` in their Documents (else home).

    Not the program's own folder: an installed taptune may not be writable, and a user's
    recordings belong with their files.
    """
    from PySide6.QtCore import QStandardPaths

    documents = QStandardPaths.writableLocation(QStandardPaths.DocumentsLocation)
    return Path(documents or Path.home()) / "taptune-recordings"


def recording_name(holder_name: str | None, stickout_mm: float | None, when: float | None = None) -> str:
    """A file name that says what was recorded and when, e.g. ``ER32-collet-chuck_53.5mm_20261122-134501.wav``."""
    stamp = time.strftime("%Y%m%d-%H%M%S", time.localtime(when))
    slug = re.sub(r"[^A-Za-z0-9]+", "-", holder_name or "tap").strip("-")[:40] or "tap"
    so = f"_{stickout_mm:g}mm" if stickout_mm else ""
    return f"{slug}{so}_{stamp}.wav"


class RecorderWorker(QObject):
    """Runs a :class:`~taptune.io.recording.Recorder` until done, stopped or failed.

    Signals
    -------
    level(float, float)
        Peak level of the latest blocks and the trigger threshold [dBFS].
    event(str, int, float, str)
        ``kind`` ("ready", "tap", "rejected", "saved"), tap number, level [dBFS], message.
    ended(str, int, str)
        The WAV path, the taps saved in it and an error message ("" if none).
    """

    level = Signal(float, float)
    event = Signal(str, int, float, str)
    ended = Signal(str, int, str)

    def __init__(self, recorder):
        super().__init__()
        self.recorder = recorder
        self._stop = threading.Event()

    def stop(self) -> None:
        """Ask the loop to end after the current block (thread-safe)."""
        self._stop.set()

    @Slot()
    def run(self) -> None:
        from taptune.gui.workers import describe_error

        error = ""
        ready = False
        try:
            self.recorder.start()
            while not self._stop.is_set() and not self.recorder.done:
                events = self.recorder.poll(timeout=0.05)
                levels = [e for e in events if e.kind == "level"]
                if levels:
                    emit(self.level, max(e.level_db for e in levels), levels[-1].threshold_db)
                if not ready and self.recorder.trigger.ready:
                    ready = True
                    emit(self.event, "ready", 0, 0.0, "")
                for e in events:
                    if e.kind in ("tap", "rejected", "saved"):
                        emit(self.event, e.kind, e.index, e.level_db, e.message)
        except Exception as err:  # noqa: BLE001 - a device error or anything else ends the recording with a message
            error = describe_error(err)
        finally:
            self.recorder.close()
        emit(self.ended, str(self.recorder.out_path), self.recorder.saved_taps, error)


class RecorderPanel(QWidget):
    """Live recording of taps.

    Parameters
    ----------
    assembly_source : callable
        Returns ``(assembly or None, assembly-file text or None)`` at arming time; the
        text is written beside the WAV.
    stream_factory : callable, optional
        Stream factory handed to the Recorder (tests pass a fake stream's factory).
    devices : callable, optional
        Returns the input devices (default :func:`taptune.io.recording.input_devices`).
    settings : QSettings, optional
        Where the folder last recorded into is remembered (default: the user's settings);
        without one remembered, :func:`default_recordings_folder`.

    Signals
    -------
    recorded(str)
        A WAV with at least one tap was written (the main window loads it).
    """

    recorded = Signal(str)
    status = Signal(str)

    def __init__(self, assembly_source, stream_factory=None, devices=None, settings=None, parent=None):
        super().__init__(parent)
        from PySide6.QtCore import QSettings

        self.settings = settings if settings is not None else QSettings()
        self._assembly_source = assembly_source
        self.stream_factory = stream_factory
        self._devices_fn = devices
        self._thread: QThread | None = None
        self._worker: RecorderWorker | None = None

        self.device_combo = QComboBox()
        self.device_combo.setMinimumContentsLength(24)
        self.device_combo.setSizeAdjustPolicy(QComboBox.AdjustToMinimumContentsLengthWithIcon)
        self.refresh_button = QPushButton("Refresh")
        self.refresh_button.clicked.connect(self.refresh_devices)
        self.taps = QSpinBox()
        self.taps.setRange(1, 50)
        self.taps.setValue(5)
        self.taps.setMaximumWidth(90)
        self.folder = QLineEdit(str(self.settings.value(FOLDER_KEY, "") or default_recordings_folder()))
        self.folder.setToolTip("Each recording (WAV) and its assembly file are saved here; "
                               "the folder is made when the first tap is saved")
        browse = QPushButton("Browse…")
        browse.clicked.connect(self._browse)

        device_row = QHBoxLayout()
        device_row.addWidget(self.device_combo, 1)
        device_row.addWidget(self.refresh_button)
        folder_row = QHBoxLayout()
        folder_row.addWidget(self.folder, 1)
        folder_row.addWidget(browse)
        form = QFormLayout()
        form.addRow("Input device", device_row)
        form.addRow("Taps to record", self.taps)
        form.addRow("Save into", folder_row)

        self.meter = QProgressBar()
        self.meter.setRange(0, 1000)
        self.meter.setTextVisible(True)
        self.meter.setFormat("—")
        self.threshold_label = QLabel("")
        meter_row = QHBoxLayout()
        meter_row.addWidget(QLabel("Level"))
        meter_row.addWidget(self.meter, 1)
        meter_row.addWidget(self.threshold_label)

        self.arm_button = QPushButton("Arm: wait for taps")
        self.arm_button.setDefault(True)
        self.stop_button = QPushButton("Stop")
        self.stop_button.setEnabled(False)
        self.arm_button.clicked.connect(self.arm)
        self.stop_button.clicked.connect(self.stop)
        buttons = QHBoxLayout()
        buttons.addWidget(self.arm_button)
        buttons.addWidget(self.stop_button)
        buttons.addStretch(1)

        self.state = QLabel()
        self.state.setWordWrap(True)
        self.help = QLabel(
            "Hang the holder with its tool on a soft support (foam, string). Arm, wait for “listening”, "
            "then tap the tool tip with a small hard object, about one tap per second. "
            "Each tap is saved at once."
        )
        self.help.setWordWrap(True)
        self.help.setStyleSheet("color: #555555;")

        box = QGroupBox("Record taps")
        layout = QVBoxLayout(box)
        layout.addLayout(form)
        layout.addLayout(meter_row)
        layout.addLayout(buttons)
        layout.addWidget(self.state)
        layout.addWidget(self.help)
        layout.addStretch(1)
        # A form stretched over a 1920 px window is hard to read: keep it laptop-wide.
        box.setMaximumWidth(760)
        outer = QVBoxLayout(self)
        outer.setContentsMargins(0, 0, 0, 0)
        outer.addWidget(box)
        self.refresh_devices()

    # ------------------------------------------------------------------ devices

    def refresh_devices(self) -> None:
        """List the input devices; without any, say why and disable arming."""
        from taptune.errors import DeviceError
        from taptune.io import recording

        self.device_combo.clear()
        try:
            devices = (self._devices_fn or recording.input_devices)()
            if not devices:
                raise DeviceError("no audio input device found: connect a microphone (or headset) and press Refresh")
        except DeviceError as err:
            self.device_combo.addItem("no input device")
            self.device_combo.setEnabled(False)
            self.arm_button.setEnabled(False)
            self._set_state(f"Recording is not available: {err}. You can still open recordings.", error=True)
            return
        default = recording.default_input_index() if self._devices_fn is None else -1
        for d in devices:
            self.device_combo.addItem(d.label(), d)
        index = next((i for i, d in enumerate(devices) if d.index == default), 0)
        self.device_combo.setCurrentIndex(index)
        self.device_combo.setEnabled(True)
        self.arm_button.setEnabled(self._thread is None)
        self._set_state("Ready to record.")

    def _browse(self) -> None:
        folder = QFileDialog.getExistingDirectory(self, "Save recordings into", self.folder.text())
        if folder:
            self.folder.setText(folder)
            self.settings.setValue(FOLDER_KEY, folder)

    # ------------------------------------------------------------------ recording

    @property
    def recording(self) -> bool:
        return self._thread is not None

    def arm(self) -> None:
        """Start listening; the WAV and its assembly file are written as taps arrive."""
        from taptune.errors import InputError
        from taptune.io.recording import Recorder, TriggerSettings

        if self._thread is not None:
            return
        device = self.device_combo.currentData()
        if device is None:
            return
        assembly, toml_text = self._assembly_source()
        holder = assembly.holder.name if assembly is not None else None
        stickout = assembly.stickout * 1e3 if assembly is not None else None
        folder = Path(self.folder.text().strip() or default_recordings_folder()).expanduser()
        self.settings.setValue(FOLDER_KEY, str(folder))  # typed in: remembered too
        out = folder / recording_name(holder, stickout)
        try:
            settings = TriggerSettings(sample_rate=int(device.default_samplerate) or 48000,
                                       channels=1, n_taps=self.taps.value())
        except InputError as err:
            self._set_state(str(err), error=True)
            return
        recorder = Recorder(out, settings, device=device.index, assembly_toml=toml_text,
                            stream_factory=self.stream_factory)
        self._worker = RecorderWorker(recorder)
        self._thread = QThread()
        self._worker.moveToThread(self._thread)
        self._thread.started.connect(self._worker.run)
        self._worker.level.connect(self._level)
        self._worker.event.connect(self._event)
        self._worker.ended.connect(self._ended)
        self.arm_button.setEnabled(False)
        self.stop_button.setEnabled(True)
        note = "" if toml_text else " (no valid assembly: no assembly file is saved with it)"
        self._set_state(f"Listening to the room… recording into {out.name}{note}")
        self._thread.start()

    def stop(self) -> None:
        """Stop listening; taps already captured stay in the WAV."""
        if self._worker is not None:
            self._worker.stop()

    def shutdown(self) -> None:
        """Stop and wait for the recording thread (window closing)."""
        if self._thread is not None:
            self._worker.stop()
            self._thread.quit()
            self._thread.wait(5000)

    @Slot(float, float)
    def _level(self, level_db: float, threshold_db: float) -> None:
        frac = (max(level_db, METER_FLOOR_DB) - METER_FLOOR_DB) / -METER_FLOOR_DB
        self.meter.setValue(int(round(1000 * frac)))
        self.meter.setFormat(f"{level_db:.0f} dBFS")
        # Red when a tap would clip: the user should tap more gently or lower the gain.
        self.meter.setStyleSheet("QProgressBar::chunk { background: #c0392b; }" if level_db > -1 else "")
        self.threshold_label.setText(f"trigger at {threshold_db:.0f} dBFS")

    @Slot(str, int, float, str)
    def _event(self, kind: str, index: int, level_db: float, message: str) -> None:
        n = self.taps.value()
        if kind == "ready":
            self._set_state(f"Listening: tap the tool tip now ({n} taps).")
        elif kind == "tap":
            self._set_state(f"Tap {index} of {n} recorded ({level_db:.0f} dBFS).")
        elif kind == "rejected":
            self._set_state(f"Tap not kept: {message}.", error=True)

    @Slot(str, int, str)
    def _ended(self, path: str, taps: int, error: str) -> None:
        self._thread.quit()
        self._thread.wait()
        self._thread = self._worker = None
        self.stop_button.setEnabled(False)
        self.arm_button.setEnabled(self.device_combo.currentData() is not None)
        self.meter.setValue(0)
        self.meter.setFormat("—")
        if error:
            from taptune.gui.messages import show_error

            self._set_state(f"Recording stopped: {error}", error=True)
            show_error(self, "Recording stopped", error)
        elif taps:
            self._set_state(f"Saved {taps} tap{'s' if taps != 1 else ''} in {path}.")
        else:
            self._set_state("Stopped before any tap was heard.")
        if taps:
            emit(self.status, f"Recording saved: {path}")
            emit(self.recorded, path)

    def _set_state(self, text: str, error: bool = False) -> None:
        self.state.setText(text)
        self.state.setStyleSheet("color: #b00020;" if error else "")
