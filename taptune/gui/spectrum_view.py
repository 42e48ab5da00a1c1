"""Spectrum view: the averaged tap spectrum in dB, the per-tap spectra, labelled peaks, interface bands.

Click near a peak to relabel it (bending mode 1–3, interface local mode, other): the
labels are what identification fits, and the user who knows the holder may know better
than the automatic labelling.
"""

from __future__ import annotations

import dataclasses

import numpy as np
from PySide6.QtCore import Signal
from PySide6.QtGui import QCursor
from PySide6.QtWidgets import QLabel, QMenu, QVBoxLayout, QWidget

from taptune.gui.plotting import BAND, BENDING, LOCAL, MEASURED, OTHER, TAPS, PlotCanvas
from taptune.gui.signals import emit

# A click selects the nearest peak within this many pixels.
PICK_RADIUS_PX = 12
LABELS = (
    ("Bending mode 1", "bending", 1),
    ("Bending mode 2", "bending", 2),
    ("Bending mode 3", "bending", 3),
    ("Interface local mode (not fitted)", "local", None),
    ("Other (not fitted)", "other", None),
)


def relabel(analysis, index: int, kind: str, mode: int | None):
    """A copy of ``analysis`` with peak ``index`` labelled ``kind`` (and bending ``mode``).

    A bending mode number belongs to one peak: the peak that had it becomes "other".
    (``bending_hz`` and the identification read the bending peaks from ``peaks``.)
    """
    if kind not in ("bending", "local", "other") or (kind == "bending") != (mode in (1, 2, 3)):
        raise ValueError(f"bad label {kind!r} mode {mode!r}")
    peaks = []
    for i, p in enumerate(analysis.peaks):
        if i == index:
            peaks.append(dataclasses.replace(p, kind=kind, mode=mode, note="labelled by the user"))
        elif kind == "bending" and p.kind == "bending" and p.mode == mode:
            peaks.append(dataclasses.replace(p, kind="other", mode=None, note="label given to another peak"))
        else:
            peaks.append(p)
    return dataclasses.replace(analysis, peaks=peaks)


# Points drawn per curve: about one per screen pixel column of a wide window.
DISPLAY_POINTS = 2500


def peak_hold(freq, values, points: int = DISPLAY_POINTS):
    """Thin a long spectrum for drawing, keeping the maximum of each group of bins.

    A 1 Hz grid up to 24 kHz has 24 000 bins; drawn as is, the noise between peaks
    becomes a solid band. The group maxima keep every peak at its true height.
    Returns (freq, values) of the group maxima.
    """
    freq, values = np.asarray(freq), np.asarray(values)
    k = int(np.ceil(values.size / points))
    if k <= 1:
        return freq, values
    n = (values.size // k) * k
    groups = values[:n].reshape(-1, k)
    idx = np.argmax(groups, axis=1) + np.arange(groups.shape[0]) * k
    return freq[idx], values[idx]


def _db(magnitude, reference) -> np.ndarray:
    return 20.0 * np.log10(np.maximum(np.asarray(magnitude, dtype=float), 1e-300) / reference)


class SpectrumView(QWidget):
    """The labelled spectrum of the current recording.

    Signals
    -------
    relabel_requested(int, str, object)
        Peak index, new kind and mode (the main window makes the new analysis).
    """

    relabel_requested = Signal(int, str, object)

    def __init__(self, parent=None):
        super().__init__(parent)
        self.canvas = PlotCanvas(self)
        self.info = QLabel()
        self.info.setWordWrap(True)
        layout = QVBoxLayout(self)
        layout.setContentsMargins(0, 0, 0, 0)
        layout.addWidget(self.canvas, 1)
        layout.addWidget(self.info)
        self.analysis = None
        self.expected_hz = None
        self._ax = None
        self._peak_xy = np.zeros((0, 2))
        self.canvas.mpl_connect("button_press_event", self._clicked)
        self.clear("Record taps or open a recording (button, or drop an audio file here: "
                   "WAV, FLAC, MP3, a phone's M4A…).")

    def clear(self, text: str) -> None:
        self.analysis = None
        self._ax = None
        self.canvas.message(text)
        self.info.setText("")

    def show_analysis(self, analysis, title: str = "", expected_hz=None) -> None:
        """Draw ``analysis`` (a SpectrumAnalysis); ``expected_hz`` marks the model's guess."""
        self.analysis = analysis
        self.expected_hz = expected_hz
        fig = self.canvas.figure
        fig.clear()
        with self.canvas.styled():
            ax = fig.add_subplot(111)
            self._draw(ax, analysis, title, expected_hz)
        self._ax = ax
        self.canvas.draw_idle()
        self.info.setText(self._summary(analysis))

    def _draw(self, ax, a, title, expected_hz) -> None:
        f_khz = np.asarray(a.freq_hz) / 1e3
        ref = float(np.max(a.magnitude)) if np.size(a.magnitude) else 1.0
        for k, mag in enumerate(np.atleast_2d(a.tap_magnitudes) if np.size(a.tap_magnitudes) else ()):
            ax.plot(*peak_hold(f_khz, _db(mag, ref)), color=TAPS, lw=0.6, label="single taps" if k == 0 else None,
                    zorder=1)
        f_shown, db_shown = peak_hold(f_khz, _db(a.magnitude, ref))
        ax.plot(f_shown, db_shown, color=MEASURED, lw=1.0, label="average of taps", zorder=2)
        for k, (lo, hi) in enumerate(a.excluded_bands_hz or ()):
            ax.axvspan(lo / 1e3, hi / 1e3, color=BAND, alpha=0.6, lw=0, zorder=0,
                       label="interface local-mode band" if k == 0 else None)
        if expected_hz is not None:
            for k, f in enumerate(expected_hz):
                ax.axvline(f / 1e3, color=BENDING, lw=0.8, ls=":", zorder=1,
                           label="model guess (nominal holder)" if k == 0 else None)
        y_top = 6.0
        xy = []
        for p in a.peaks:
            y = float(p.level_db)
            x = p.hz / 1e3
            if p.kind == "bending":
                ax.plot(x, y, "v", color=BENDING, ms=8, zorder=4)
                ax.annotate(f"f{p.mode}  {p.hz:,.0f} Hz", (x, y), xytext=(0, 8), textcoords="offset points",
                            ha="center", va="bottom", color=BENDING, fontsize=9, fontweight="bold", zorder=5,
                            bbox=dict(boxstyle="round,pad=0.15", fc="white", ec="none", alpha=0.8))
            elif p.kind == "local":
                ax.plot(x, y, "D", color=LOCAL, ms=5, zorder=3)
                ax.annotate("local", (x, y), xytext=(0, 6), textcoords="offset points", ha="center",
                            va="bottom", color=LOCAL, fontsize=8, zorder=5)
            else:
                ax.plot(x, y, "o", color=OTHER, ms=3.5, mfc="none", zorder=3)
            xy.append((x, y))
            y_top = max(y_top, y + 12)
        self._peak_xy = np.array(xy) if xy else np.zeros((0, 2))
        ax.set_xlim(0, f_khz[-1] if f_khz.size else 1)
        lowest = float(np.percentile(db_shown, 5)) if db_shown.size else -80
        ax.set_ylim(max(lowest - 5, -120), y_top)
        ax.set_xlabel("frequency [kHz]")
        ax.set_ylabel("level [dB re loudest peak]")
        if title:
            ax.set_title(title, loc="left")
        ax.legend(loc="upper right", framealpha=0.9)

    @staticmethod
    def _summary(a) -> str:
        taps = a.n_taps
        bending = ", ".join(f"f{p.mode} = {p.hz:,.0f} Hz" for p in a.bending_peaks)
        text = f"{taps} tap{'s' if taps != 1 else ''}; bending peaks: {bending or 'none'}. Click a peak to relabel it."
        if a.warnings:
            text += "\n⚠ " + "\n⚠ ".join(a.warnings)
        return text

    # ------------------------------------------------------------------ picking

    def peak_at(self, x_px: float, y_px: float) -> int | None:
        """Index of the peak drawn nearest to the display point (pixels), if within reach."""
        if self._ax is None or not len(self._peak_xy):
            return None
        pts = self._ax.transData.transform(self._peak_xy)
        d = np.hypot(pts[:, 0] - x_px, pts[:, 1] - y_px)
        i = int(np.argmin(d))
        return i if d[i] <= PICK_RADIUS_PX * self.canvas.device_pixel_ratio else None

    def _clicked(self, event) -> None:
        if event.inaxes is not self._ax or event.button != 1:
            return
        index = self.peak_at(event.x, event.y)
        if index is None:
            return
        peak = self.analysis.peaks[index]
        menu = QMenu(self)
        menu.addSection(f"Peak at {peak.hz:,.0f} Hz")
        for text, kind, mode in LABELS:
            action = menu.addAction(text)
            action.setCheckable(True)
            action.setChecked(peak.kind == kind and peak.mode == mode)
            action.triggered.connect(lambda _=False, k=kind, m=mode: emit(self.relabel_requested, index, k, m))
        menu.popup(QCursor.pos())
        self._menu = menu  # keep it alive while shown
