"""Stick-out predictor: move the stick-out, see f1–f3 with their spread and the tip receptance.

The holder's near-optimal parameter sets (from the identification just run or from the
library) go to :func:`taptune.identify.predict` with the assembly at the chosen
stick-out; the tip receptance of the best set comes from the model. Each update runs in
a worker thread; while one runs, only the latest request waits, so dragging the slider
never queues up work or blocks the window.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from matplotlib.ticker import FuncFormatter
from PySide6.QtCore import Qt, Signal
from PySide6.QtWidgets import QGridLayout, QLabel, QTableWidgetItem, QVBoxLayout, QWidget

from taptune.gui.latest import LatestOnly
from taptune.gui.layout import read_only_table
from taptune.gui.plotting import BENDING, MEASURED, PlotCanvas
from taptune.gui.signals import emit
from taptune.gui.stickout import StickoutSlider

MM = 1e-3
# Receptance plot grid [Hz]: up to 25 kHz covers f1–f3 of usual assemblies.
FREQ_HZ = np.linspace(20.0, 25000.0, 2500)
# The geometry tolerances of identify.bands, in words.
GEOMETRY_PARTS = {"stickout": "stick-out here", "stickout_identified": "stick-out when tapped",
                  "diameter": "holder diameters", "flute_ratio": "flute ratio"}


@dataclass(frozen=True)
class PredictorSource:
    """Where the holder parameters come from and the assembly they are used with."""

    label: str
    param_sets: tuple
    assembly: object
    model_options: object = None
    relative_floor: float = 5e-4  # see identify.predict
    identified: tuple = ()  # the assemblies the holder was identified on (the band's Δ stick-out)
    measured_modes: tuple | None = None  # which modes the taps measured (the band's evidence groups)


def compute_prediction(source: PredictorSource, stickout_mm: float, freq_hz=FREQ_HZ):
    """Prediction and best-set tip receptance [m/N] at ``stickout_mm`` (runs in a worker)."""
    from taptune.identify import predict
    from taptune.model import ModelOptions, build_model, tip_receptance

    options = source.model_options or ModelOptions()
    assembly = source.assembly.with_stickout(stickout_mm * MM)
    prediction = predict(source.param_sets, assembly, options, relative_floor=source.relative_floor,
                         identified=list(source.identified), measured_modes=source.measured_modes)
    h = tip_receptance(build_model(assembly, options), source.param_sets[0], freq_hz)
    return stickout_mm, prediction, np.asarray(h)


def plain_odds(coverage: float) -> str:
    """A coverage probability in a machinist's words: 0.9 → "9 times in 10"."""
    for n in (10, 20, 100):
        k = coverage * n
        if abs(k - round(k)) < 1e-6:
            return f"{round(k)} times in {n}"
    return f"{100 * coverage:.0f} times in 100"


class Predictor(QWidget):
    """Predicted bending frequencies and tip receptance at any stick-out.

    Signals
    -------
    predicted(object)
        The :class:`~taptune.identify.Prediction` just shown.
    """

    predicted = Signal(object)
    failed = Signal(str)

    def __init__(self, parent=None):
        super().__init__(parent)
        self.source: PredictorSource | None = None
        self.prediction = None
        self._updates = LatestOnly(self._done, self._failed, self)

        self.source_label = QLabel()
        self.source_label.setWordWrap(True)
        self.stickout = StickoutSlider()
        self.stickout.changed.connect(self.request)
        self.slider, self.spin = self.stickout.slider, self.stickout.spin

        self.table = read_only_table(3, ["mode", "predicted Hz ± band", "damping ζ % (± spread)"])
        self.table.setMinimumWidth(420)
        self.note = QLabel(
            "Values from the best fit. The ± band holds the near-optimal fits (the tap cannot tell them "
            "apart), the geometry tolerances and what the model leaves out: how, below. The damping "
            "spread is the near-optimal fits' alone."
        )
        self.note.setWordWrap(True)
        self.note.setStyleSheet("color: #555555;")
        self.canvas = PlotCanvas(self)
        # Numbers on top, the curve below: the table keeps its columns readable on a
        # 1366 px laptop and the plot gets the full width.
        # How each ± is made (identify.bands): the components per mode and the calibration.
        self.band_table = read_only_table(3, ["mode", "± total", "near-optimal fits", "geometry", "model form"])
        self.band_table.setMinimumWidth(420)
        self.band_note = QLabel()
        self.band_note.setWordWrap(True)
        self.band_note.setStyleSheet("color: #555555;")
        numbers = QGridLayout()
        numbers.addWidget(self.table, 0, 0)
        numbers.addWidget(self.note, 0, 1)
        numbers.addWidget(self.band_table, 1, 0)
        numbers.addWidget(self.band_note, 1, 1)
        numbers.setColumnStretch(1, 1)

        layout = QVBoxLayout(self)
        layout.setContentsMargins(0, 0, 0, 0)
        layout.addWidget(self.source_label)
        layout.addWidget(self.stickout)
        layout.addLayout(numbers)
        layout.addWidget(self.canvas, 1)
        self.set_source(None)

    def set_source(self, source: PredictorSource | None) -> None:
        """Use ``source`` (None: nothing to predict yet) and predict at its stick-out."""
        self.source = source
        enabled = source is not None
        self.stickout.setEnabled(enabled)
        if source is None:
            self.source_label.setText("Identify a holder, or pick one in the Library tab, to predict other stick-outs.")
            self.canvas.message("No holder parameters yet.")
            self.table.clearContents()
            self._show_band(None)
            return
        self.source_label.setText(f"Holder parameters: {source.label}. Tool: {source.assembly.tool.name}.")
        self.stickout.set_assembly(source.assembly)
        current = source.assembly.stickout / MM
        self.request(current)

    def set_stickout_mm(self, value: float) -> None:
        """Move the stick-out (as the user would with the field)."""
        self.stickout.set_value(value)

    def request(self, stickout_mm: float) -> None:
        """Predict at ``stickout_mm``; while a prediction runs, keep only the latest request."""
        if self.source is not None:
            self._updates.request(compute_prediction, self.source, stickout_mm)

    @property
    def busy(self) -> bool:
        return self._updates.busy

    def _failed(self, message: str) -> None:
        self.canvas.message(f"Cannot predict here:\n{message}")
        self.table.clearContents()
        self._show_band(None)
        emit(self.failed, message)

    def _done(self, result) -> None:
        self._show(*result)

    def _show(self, stickout_mm: float, prediction, h) -> None:
        self.prediction = prediction
        for r in range(3):
            f = prediction.bending_hz[r]
            s = prediction.bending_hz_spread[r]
            z = prediction.damping_ratio[r]
            zs = prediction.damping_ratio_spread[r]
            for c, text in enumerate((f"f{r + 1}", f"{f:,.0f} ± {s:,.0f}", f"{100 * z:.3f} ± {100 * zs:.3f}")):
                item = QTableWidgetItem(text)
                item.setTextAlignment(Qt.AlignCenter if c == 0 else Qt.AlignRight | Qt.AlignVCenter)
                self.table.setItem(r, c, item)
        self._show_band(prediction)
        fig = self.canvas.figure
        fig.clear()
        with self.canvas.styled():
            ax = fig.add_subplot(111)
            mag = np.abs(h) * 1e6  # µm/N, as the Machine view's tool-point FRF
            ax.semilogy(FREQ_HZ / 1e3, mag, color=MEASURED, lw=1.2)
            # Plain numbers on the log axis (0.01, 0.1, 1 …), not powers of ten.
            ax.yaxis.set_major_formatter(FuncFormatter(lambda v, _pos: f"{v:g}"))
            for n, (f, s) in enumerate(zip(prediction.bending_hz, prediction.bending_hz_spread)):
                ax.axvspan((f - s) / 1e3, (f + s) / 1e3, color=BENDING, alpha=0.25, lw=0)
                ax.axvline(f / 1e3, color=BENDING, lw=0.8, ls=":")
                ax.annotate(f"f{n + 1}", (f / 1e3, 1.0), xycoords=("data", "axes fraction"), xytext=(3, -12),
                            textcoords="offset points", color=BENDING, fontsize=9, fontweight="bold")
            ax.set_xlim(0, FREQ_HZ[-1] / 1e3)
            # Scale to the elastic modes, not to the rigid-body mass line near 0 Hz.
            elastic = mag[FREQ_HZ > 0.5 * prediction.bending_hz[0]]
            ax.set_ylim(0.5 * elastic.min(), 4 * elastic.max())
            ax.set_xlabel("frequency [kHz]")
            ax.set_ylabel("|H| at the tool tip, hanging free [µm/N]")
            ax.set_title(f"Tip receptance hanging free (as tapped) at stick-out {stickout_mm:.1f} mm; "
                         "shaded: f1–f3 ± band", loc="left")
        self.canvas.draw_idle()
        emit(self.predicted, prediction)

    def _show_band(self, prediction) -> None:
        """The make-up of each ± (near-optimal fits, geometry tolerances, model form) and how it was calibrated."""
        band = getattr(prediction, "band", None)
        self.band_table.setVisible(band is not None)
        self.band_note.setVisible(band is not None)
        if band is None:
            return
        for r, f in enumerate(prediction.bending_hz[: len(band.half_width_hz)]):
            texts = (f"f{r + 1}", f"{band.half_width_hz[r]:,.0f} Hz", f"{band.set_hz[r]:,.0f}",
                     f"{band.geometry_hz[r]:,.0f}", f"{band.model_form_hz[r]:,.0f}")
            for c, text in enumerate(texts):
                item = QTableWidgetItem(text)
                item.setTextAlignment(Qt.AlignCenter if c == 0 else Qt.AlignRight | Qt.AlignVCenter)
                self.band_table.setItem(r, c, item)
        parts = ", ".join(f"{GEOMETRY_PARTS.get(name, name)} ±{max(v):,.0f}"
                          for name, v in band.geometry_parts_hz.items())
        rel = 100 * band.relative(prediction.bending_hz)
        source = ("from 1 recording" if band.recordings == 1 else
                  "from no recorded identification" if band.recordings == 0 else f"from {band.recordings} recordings")
        # For the machinist: what the ± promises, in words; how it is made and calibrated on hover.
        self.band_note.setText(
            f"The ± holds the true frequency {plain_odds(band.coverage)} on holders that differ from the "
            f"model as real ones do. Here it is ±{rel.min():.1f}–{rel.max():.1f} % (holder {source}). "
            "Hover for how it is made.")
        details = (f"{band.text(prediction.bending_hz)}\nEach ± = √(fits² + geometry² + model form²)"
                   + (f"; geometry, largest over f1–f3 [Hz]: {parts}" if parts else "")
                   + f".\nCalibration: {band.calibration}.")
        self.band_note.setToolTip(details)
        self.band_table.setToolTip(details)

    def shutdown(self) -> None:
        self._updates.shutdown()
