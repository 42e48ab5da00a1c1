"""Recording in the window with a fake input stream: taps → WAV + assembly file → analysis.

The fake stream plays the generated tap sound of the reference assembly into the
recorder's callback from its own thread, as PortAudio would.
"""

from __future__ import annotations

import soundfile

from taptune.gui import messages
from taptune.io.recording import FakeInputStream, InputDevice
from tests.gui.conftest import FS, tap_sound

DEVICES = [InputDevice(2, "Fake USB microphone", 1, float(FS))]


def _taps(onsets, seconds):
    # Modes near those of the reference assembly, so the analysis finds bending peaks.
    return tap_sound((4686.0, 14937.0, 19897.0), (0.0039, 0.002, 0.0027), (1.0, 0.5, 0.35), onsets, seconds)


def _window(qtbot, library_path, stream, settings):
    from taptune.gui.main_window import MainWindow

    win = MainWindow(library_path, stream_factory=stream.factory, devices=lambda: DEVICES, settings=settings)
    qtbot.addWidget(win)
    win.resize(1366, 768)
    win.show()
    return win


def test_record_taps_saves_wav_and_assembly_then_analyses(qtbot, library_path, settings, tmp_path, reference_assembly):
    stream = FakeInputStream(_taps((0.4, 1.2, 2.0, 2.8), 3.6))
    win = _window(qtbot, library_path, stream, settings)
    panel = win.recorder
    assert panel.device_combo.currentText().startswith("2: Fake USB microphone")
    win.assembly_panel.set_assembly(reference_assembly)
    panel.folder.setText(str(tmp_path / "recordings"))
    panel.taps.setValue(3)
    levels = []
    panel.meter.valueChanged.connect(levels.append)
    with qtbot.waitSignal(win.analysis_ready, timeout=30000):
        with qtbot.waitSignal(panel.recorded, timeout=10000) as recorded:
            panel.arm_button.click()
            assert panel.recording and panel.stop_button.isEnabled()
    wav = recorded.args[0]
    assert wav.startswith(str(tmp_path / "recordings" / "ER32-collet-chuck-HSK-A63-x-100_53.5mm_"))
    assert soundfile.info(wav).frames == 3 * int(0.7 * FS)
    sidecar = tmp_path / "recordings" / (wav.rsplit("/", 1)[1][:-4] + ".toml")
    assert "ER32 collet chuck HSK-A63 x 100" in sidecar.read_text()
    assert levels and max(levels) > 700  # the taps peak near -6 dBFS on a -80…0 dB meter
    assert "Saved 3 taps" in panel.state.text()
    assert not panel.recording and panel.arm_button.isEnabled()
    assert win.analysis.n_taps == 3 and len(win.analysis.bending_hz) == 3
    assert messages.history == []
    win.close()


def test_device_lost_mid_recording_keeps_the_taps_and_says_so(qtbot, library_path, settings, tmp_path):
    stream = FakeInputStream(_taps((0.4,), 1.5), end="lost")
    win = _window(qtbot, library_path, stream, settings)
    panel = win.recorder
    panel.folder.setText(str(tmp_path))
    panel.taps.setValue(3)
    with qtbot.waitSignal(panel.recorded, timeout=10000) as recorded:
        panel.arm()
    assert soundfile.info(recorded.args[0]).frames == int(0.7 * FS)
    title, text = messages.history[0]
    assert title == "Recording stopped" and "unplugged" in text and "1 tap(s) recorded so far are saved" in text
    assert "unplugged" in panel.state.text()
    assert panel.arm_button.isEnabled()
    win.close()


def test_stop_before_any_tap_writes_nothing(qtbot, library_path, settings, tmp_path):
    stream = FakeInputStream(_taps((), 0.5) * 0)  # silence, then the stream stays open
    win = _window(qtbot, library_path, stream, settings)
    panel = win.recorder
    panel.folder.setText(str(tmp_path))
    panel.arm()
    qtbot.waitUntil(lambda: "Listening" in panel.state.text(), timeout=5000)
    panel.stop()
    qtbot.waitUntil(lambda: not panel.recording, timeout=5000)
    assert panel.state.text() == "Stopped before any tap was heard."
    assert list(tmp_path.glob("*.wav")) == []
    win.close()


def test_without_an_input_device_recording_is_disabled_with_a_reason(window):
    panel = window.recorder
    assert not panel.arm_button.isEnabled()
    assert "no audio input device found" in panel.state.text()
    assert window.open_button.isEnabled()


def test_without_portaudio_the_panel_says_so(qtbot, library_path):
    from taptune.errors import DeviceError
    from taptune.gui.main_window import MainWindow

    def no_library():
        raise DeviceError("no audio library: the PortAudio library was not found (on Debian/Ubuntu: "
                          "sudo apt install libportaudio2)")

    win = MainWindow(library_path, devices=no_library)
    qtbot.addWidget(win)
    assert not win.recorder.arm_button.isEnabled()
    assert "PortAudio library was not found" in win.recorder.state.text()
    win.recorder.arm()  # nothing happens, nothing breaks
    assert not win.recorder.recording
    win.close()


def test_record_the_second_stickout(qtbot, library_path, settings, tmp_path, generated_recording):
    # The same holder and tool at 63.5 mm (holder A: f1 3,748.6 Hz, converged value).
    stream = FakeInputStream(tap_sound((3748.6, 13125.9, 17768.6), (0.0037, 0.0023, 0.0019), (1.0, 0.5, 0.35),
                                       (0.4, 1.2, 2.0, 2.8), 3.6))
    win = _window(qtbot, library_path, stream, settings)
    with qtbot.waitSignal(win.analysis_ready, timeout=30000):
        win.load_recording(str(generated_recording[0]))
    win.assembly_panel.set_second_stickout_mm(63.5)
    win.record_second.setChecked(True)
    panel = win.recorder
    panel.folder.setText(str(tmp_path / "second"))
    panel.taps.setValue(3)
    with qtbot.waitSignal(win.analysis_ready, timeout=30000):
        with qtbot.waitSignal(panel.recorded, timeout=10000) as recorded:
            panel.arm_button.click()
    wav = recorded.args[0]
    assert "_63.5mm_" in wav  # named after the 2nd stick-out, and its assembly file says so
    assert "stickout = 63.5" in (tmp_path / "second" / (wav.rsplit("/", 1)[1][:-4] + ".toml")).read_text()
    assert win.second is not None and win.second.path == wav
    assert win.second.assembly.stickout == 0.0635 and win.recording_path == str(generated_recording[0])
    assert abs(win.second.analysis.bending_hz[0] / 3748.6 - 1) < 2e-3
    assert win.identify_button.text() == "Identify both together" and win.identify_button.isEnabled()
    assert messages.history == []
    win.close()


def test_recordings_go_to_a_user_folder_and_the_last_folder_is_remembered(qtbot, settings, tmp_path, monkeypatch):
    from PySide6.QtCore import QStandardPaths

    from taptune.gui.recorder_panel import FOLDER_KEY, RecorderPanel

    documents = tmp_path / "Documents"
    monkeypatch.setattr(QStandardPaths, "writableLocation", lambda _where: str(documents))
    panel = RecorderPanel(lambda: (None, None), devices=lambda: DEVICES, settings=settings)
    qtbot.addWidget(panel)
    # Not the program's folder: the user's documents.
    assert panel.folder.text() == str(documents / "taptune-recordings")
    chosen = tmp_path / "shop floor taps"
    monkeypatch.setattr("PySide6.QtWidgets.QFileDialog.getExistingDirectory", lambda *a, **k: str(chosen))
    panel._browse()
    assert settings.value(FOLDER_KEY) == str(chosen)
    again = RecorderPanel(lambda: (None, None), devices=lambda: DEVICES, settings=settings)
    qtbot.addWidget(again)
    assert again.folder.text() == str(chosen)
