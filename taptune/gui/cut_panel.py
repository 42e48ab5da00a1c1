"""Listen to a cut, in the Machine view: open or record the sound of a cut, the verdict, the next speed, ✓/✗ on the lobes.

The same calls as ``taptune cut``: :func:`taptune.signal.cut.analyse_cut` for the
verdict, :func:`taptune.machine.next_speed.advise` with the view's lobes and tool-point
modes for the next speed. A cut listened to with a library holder is kept in its history
(:meth:`taptune.library.store.HolderLibrary.update`), and every observed cut of the
holder is drawn on the lobes (green ✓ stable, red ✗ chatter, ? unclear).
"""

from __future__ import annotations

import html
import re
from dataclasses import replace
from pathlib import Path

import numpy as np
from PySide6.QtCore import Qt, QTimer
from PySide6.QtWidgets import QDoubleSpinBox, QFileDialog, QHBoxLayout, QLabel, QPushButton, QWidget

from taptune.gui.messages import show_error

#: Seconds recorded by "Record cut".
RECORD_S = 8.0
RECORD_RATE = 44100
COLOURS = {"stable": "#1e8449", "chatter": "#c0392b", "unclear": "#b9770e"}
MARKS = {"stable": "$\u2713$", "chatter": "$\u2717$", "unclear": "$?$"}


def library_holder_name(source) -> str | None:
    """The library holder a Machine view source came from ("library (NAME)"), or None."""
    m = re.fullmatch(r"library \((.*)\)", getattr(source, "label", "") or "")
    return m.group(1) if m else None


class CutPanel(QWidget):
    """One row under the Machine view's summary: commanded speed, depth, *Listen to cut…*, *Record cut*, the verdict.

    Parameters
    ----------
    view : MachineView
        Gives the cut (teeth, ae, milling, coefficients), the holder source and the lobes.
    stream_factory : callable, optional
        Opens an input stream (:func:`taptune.io.recording.sounddevice_stream` by default;
        tests pass :meth:`taptune.io.recording.FakeInputStream.factory`).
    """

    def __init__(self, view, stream_factory=None, parent=None):
        super().__init__(parent)
        self.view = view
        self.stream_factory = stream_factory
        self.analysis = None
        self.advice = None
        self.session = []  # cuts observed here without a library holder
        self._marks = []
        self._seen = None
        self._blocks = []
        self._stream = None
        self.rpm = QDoubleSpinBox()
        self.rpm.setRange(100.0, 200000.0)
        self.rpm.setDecimals(0)
        self.rpm.setSuffix(" rpm")
        self.rpm.setValue(10000.0)
        self.rpm.setToolTip("The commanded spindle speed of the cut")
        self.depth = QDoubleSpinBox()
        self.depth.setRange(0.01, 500.0)
        self.depth.setDecimals(2)
        self.depth.setSuffix(" mm")
        self.depth.setValue(2.0)
        self.depth.setToolTip("The axial depth of the cut")
        self.open_button = QPushButton("Listen to cut…")
        self.open_button.setToolTip("Open a recording of a cut (WAV, M4A, phone video …): stable or chatter, "
                                    "and the next speed")
        self.open_button.clicked.connect(self._open_dialog)
        self.record_button = QPushButton(f"Record cut ({RECORD_S:g} s)")
        self.record_button.clicked.connect(self.record)
        self.result = QLabel("Record or open the sound of a cut at this speed and depth (docs/cut.md).")
        self.result.setWordWrap(True)
        self.result.setTextInteractionFlags(Qt.TextSelectableByMouse)
        row = QHBoxLayout(self)
        row.setContentsMargins(0, 0, 0, 0)
        for label, widget in (("Cut at", self.rpm), ("depth", self.depth)):
            row.addWidget(QLabel(label))
            row.addWidget(widget)
        row.addWidget(self.open_button)
        row.addWidget(self.record_button)
        row.addWidget(self.result, 1)

    # ------------------------------------------------------------------ input

    def _open_dialog(self) -> None:
        path, _ = QFileDialog.getOpenFileName(self, "Open the recording of a cut", str(Path.cwd()),
                                              "Audio (*.wav *.flac *.mp3 *.ogg *.m4a *.aac *.mp4 *.mov);;All files (*)")
        if path:
            self.listen_file(path)

    def listen_file(self, path: str) -> bool:
        """Analyse the cut recorded in ``path``; a bad file or a wrong speed says why in a dialog."""
        from taptune.errors import InputError
        from taptune.io.audio import read_audio

        try:
            recording = read_audio(path)
        except InputError as err:
            show_error(self, "Cannot read this recording", str(err))
            return False
        return self.listen(recording)

    def record(self) -> None:
        """Record :data:`RECORD_S` seconds from the default input, then listen to them."""
        from taptune.errors import DeviceError
        from taptune.io.recording import sounddevice_stream

        factory = self.stream_factory or sounddevice_stream
        self._blocks = []

        def callback(block, frames, time_info, status):
            self._blocks.append(np.array(block, dtype=float))

        try:
            self._stream = factory(device=None, samplerate=RECORD_RATE, channels=1, blocksize=2048, callback=callback)
            self._stream.start()
        except DeviceError as err:
            show_error(self, "Cannot record", str(err))
            return
        self.record_button.setEnabled(False)
        self.result.setText(f"Recording {RECORD_S:g} s: start the cut now…")
        QTimer.singleShot(int(RECORD_S * 1000), self._recorded)

    def _recorded(self) -> None:
        from taptune.io.audio import make_recording

        stream, self._stream = self._stream, None
        if stream is not None:
            stream.stop()
            stream.close()
        self.record_button.setEnabled(True)
        if not self._blocks:
            show_error(self, "Nothing recorded", "The input gave no sound; check the microphone.")
            return
        samples = np.concatenate(self._blocks).reshape(-1, 1)
        self.listen(make_recording(np.clip(samples, -1, 1), RECORD_RATE, "recorded cut"))

    # ------------------------------------------------------------------ analysis

    def listen(self, recording) -> bool:
        """The verdict and the next speed of ``recording`` at the panel's speed and the view's cut."""
        from taptune.errors import TaptuneError
        from taptune.machine.next_speed import advise
        from taptune.signal.cut import analyse_cut

        cut = self.view.cut()
        try:
            analysis = analyse_cut(recording, self.rpm.value(), cut.teeth)
        except TaptuneError as err:
            show_error(self, "Cannot hear a cut here", str(err))
            return False
        result = self.view.result
        refined = getattr(self.view, "refined_result", None)
        min_rpm, max_rpm = cut.rpm_min, cut.rpm_max
        if result is not None:
            rpm, a_lim = result[2].rpm, result[2].a_lim
            if refined is not None:  # the semi-discretization, and its safe limit when there is a band
                _, _, lobes, band = refined
                rpm, a_lim = (band.rpm, band.a_safe) if getattr(band, "samples", 0) > 1 else (lobes.rpm, lobes.a_lim)
            advice = advise(analysis, min_rpm=min_rpm, max_rpm=max_rpm, depth=self.depth.value() * 1e-3,
                            rpm=rpm, a_lim=a_lim, modes=result[1].modes, holder=self.view.source.assembly.holder.name)
        else:
            advice = advise(analysis, min_rpm=min_rpm, max_rpm=max_rpm)
        self.analysis, self.advice = analysis, advice
        self._keep(recording, analysis, cut)
        self._seen = None
        self.result.setText(verdict_html(analysis, advice))
        if result is not None and len(self.view.canvas.figure.axes) > 1:
            self.mark(self.view.canvas.figure.axes[1])
            self.view.canvas.draw_idle()
        return True

    def _keep(self, recording, analysis, cut) -> None:
        """The cut into the library holder's history, or this session's when there is none."""
        from taptune.library.observations import CutObservation
        from taptune.library.schema import sha256_file

        sha = sha256_file(recording.path) if recording.path and Path(recording.path).is_file() else None
        obs = CutObservation.from_analysis(analysis, depth_mm=self.depth.value(), ae_mm=cut.ae_mm,
                                           milling=cut.milling, ktc_mpa=cut.ktc_mpa, krc_mpa=cut.krc_mpa,
                                           recording=recording.path, sha256=sha)
        name = library_holder_name(self.view.source)
        if name is None:
            self.session.append(obs)
            return
        from taptune.errors import TaptuneError
        from taptune.library.store import HolderLibrary, default_library_path

        path = getattr(getattr(self.window(), "library_view", None), "library_path", None) or default_library_path()
        try:
            HolderLibrary(path).update(name, lambda e: replace(e, observations=e.observations + (obs,)))
        except TaptuneError as err:
            self.session.append(obs)
            show_error(self, "The cut was not saved to the library", str(err))

    def observations(self) -> list:
        """The cuts to draw: the library holder's history (same teeth and milling) and this session's."""
        out = list(self.session)
        name = library_holder_name(self.view.source)
        if name is not None:
            from taptune.errors import TaptuneError
            from taptune.library.store import HolderLibrary, default_library_path

            path = getattr(getattr(self.window(), "library_view", None), "library_path", None) or default_library_path()
            try:
                out = list(HolderLibrary(path).get(name).observations) + out
            except TaptuneError:
                pass
        cut = self.view.cut()
        return [o for o in out if o.teeth == cut.teeth and o.milling == cut.milling]

    def observed_cuts(self) -> list:
        """(rpm, depth [m], verdict) of the observed cuts made with the view's cut: they weigh its band."""
        from taptune.machine.observed import comparable

        c = self.view.cut()
        same = comparable(self.observations(), teeth=c.teeth, ae_mm=c.ae_mm, milling=c.milling, ktc_mpa=c.ktc_mpa,
                          krc_mpa=c.krc_mpa)
        return [(o.rpm, o.depth_mm * 1e-3, o.verdict) for o in same]

    def mark(self, ax) -> None:
        """Draw the observed cuts on the lobes' axes ``ax`` (replacing the previous marks)."""
        for artist in self._marks:
            if artist.axes is not None:  # clearing the axes already took it off (and detached it)
                artist.remove()
        self._marks = []
        key = (getattr(self.view.source, "label", None), self.view.cut().teeth, self.view.cut().milling)
        if self._seen is None or self._seen[0] != key:
            self._seen = (key, self.observations())  # the library is read once per holder and cut, not per redraw
        seen = self._seen[1]
        for i, o in enumerate(seen):
            big = i == len(seen) - 1
            self._marks += ax.plot([o.rpm], [o.depth_mm], ls="none", marker=MARKS.get(o.verdict, "$?$"),
                                   color=COLOURS.get(o.verdict, "#555555"), ms=13 if big else 9, zorder=5)
        if self.advice is not None and self.advice.basis == "lobes" and self.advice.suggested_rpm:
            self._marks += ax.plot([self.advice.suggested_rpm[0]], [self.depth.value()], ls="none", marker="^",
                                   color="#1f618d", ms=10, zorder=5, label="next speed")


def verdict_html(analysis, advice) -> str:
    """The verdict and the next speed in one line of rich text."""
    a = analysis
    colour = COLOURS[a.verdict]
    text = f"<b style='color:{colour}'>{a.verdict.upper()}</b> at {a.spindle_rpm:,.0f} rpm heard"
    if a.chatter_hz is not None and a.verdict != "stable":
        text += f": {a.chatter_hz:,.0f} Hz, {a.chatter_level_db:+.0f} dB over the tooth passing"
    if advice.suggested_rpm:
        basis = "the lobes at this depth" if advice.basis == "lobes" else "tooth passing on the chatter"
        text += (f". <b>Try {advice.suggested_rpm[0]:,.0f} rpm</b>"
                 + (f" (then {', '.join(f'{n:,.0f}' for n in advice.suggested_rpm[1:3])})"
                    if len(advice.suggested_rpm) > 1 else "") + f", by {basis}")
    for w in list(a.warnings[:1]) + list(advice.warnings):
        text += f"<br><span style='color:#b35900'>⚠ {html.escape(w, quote=False)}</span>"
    return text
