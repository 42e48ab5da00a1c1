"""Fit view: measured vs model spectrum shape around mode 1, the f1–f3 table, the parameters.

Everything shown comes from the :class:`~taptune.identify.Identification` (its window,
normalised measured and model shapes, frequencies); the view computes nothing.
"""

from __future__ import annotations

import numpy as np
from PySide6.QtCore import Qt
from PySide6.QtWidgets import QLabel, QTableWidgetItem, QVBoxLayout, QWidget

from taptune.gui.layout import column, hsplit, read_only_table
from taptune.gui.plotting import MEASURED, MODEL, PlotCanvas

PARAM_ROWS = (
    ("k_tt", "translational stiffness", "N/m per mm", "{:.3g}"),
    ("k_rr", "rotational stiffness", "N·m/rad per mm", "{:.3g}"),
    ("eta_tt", "translational loss", "1/mm", "{:.2g}"),
    ("eta_rr", "rotational loss", "1/mm", "{:.2g}"),
    ("alpha", "intensity slope", "%", "{:.1f}"),
    ("density_factor", "holder density factor", "–", "{:.3f}"),
    ("modulus_factor", "holder modulus factor", "–", "{:.3f}"),
)


def _cell(text: str, align=Qt.AlignRight | Qt.AlignVCenter) -> QTableWidgetItem:
    item = QTableWidgetItem(text)
    item.setTextAlignment(align)
    return item


class FitView(QWidget):
    """How well the identified holder model matches the recording."""

    def __init__(self, parent=None):
        super().__init__(parent)
        self.canvas = PlotCanvas(self)
        self.freq_table = read_only_table(3, ["mode", "measured Hz", "model Hz", "difference", "model ζ %"])
        self.param_table = read_only_table(len(PARAM_ROWS), ["parameter", "value", "± spread", "unit"])
        self.summary = QLabel()
        self.summary.setWordWrap(True)
        self.summary.setTextInteractionFlags(Qt.TextSelectableByMouse)
        tables = column(QLabel("Bending frequencies"), self.freq_table,
                        QLabel("Identified holder parameters (spread over the near-optimal fits)"),
                        self.param_table, self.summary, 1)
        layout = QVBoxLayout(self)
        layout.setContentsMargins(0, 0, 0, 0)
        layout.addWidget(hsplit(self.canvas, tables, (3, 2)))
        self.identification = None
        self.clear()

    def clear(self, text: str = "Identify the holder to see the fit.") -> None:
        self.identification = None
        self.canvas.message(text)
        self.freq_table.clearContents()
        self.param_table.clearContents()
        self.summary.setText("")

    def show_identification(self, result, title: str = "") -> None:
        """Show ``result`` (an Identification); the first recording where it is a joint fit."""
        self.identification = result
        fig = self.canvas.figure
        fig.clear()
        with self.canvas.styled():
            ax = fig.add_subplot(111)
            f = np.asarray(result.window_hz[0])
            ax.plot(f, np.asarray(result.measured_shape[0]), color=MEASURED, lw=1.6, label="measured (average of taps)")
            ax.plot(f, np.asarray(result.model_shape[0]), color=MODEL, lw=1.3, ls="--", label="identified model")
            ax.set_xlabel("frequency [Hz]")
            ax.set_ylabel("level, normalised to the peak")
            ax.set_title(title or "Around bending mode 1", loc="left")
            ax.text(0.01, 0.98, "the window the fit compares:\nf1 ± 100 Hz", transform=ax.transAxes,
                    va="top", ha="left", fontsize=8, color="#555555")
            ax.legend(loc="upper right", framealpha=0.9)
        self.canvas.draw_idle()

        measured = result.bending_measured_hz[0]
        model = result.bending_model_hz[0]
        zeta = result.damping_model[0]
        for r in range(3):
            m = measured[r] if r < len(measured) else None
            f_model = model[r] if r < len(model) else float("nan")
            self.freq_table.setItem(r, 0, _cell(f"f{r + 1}", Qt.AlignCenter))
            self.freq_table.setItem(r, 1, _cell(f"{m:,.1f}" if m is not None else "not found"))
            self.freq_table.setItem(r, 2, _cell(f"{f_model:,.1f}"))
            self.freq_table.setItem(r, 3, _cell(f"{100 * (f_model / m - 1):+.2f} %" if m else "–"))
            self.freq_table.setItem(r, 4, _cell(f"{100 * zeta[r]:.3f}" if r < len(zeta) else "–"))
        spread = result.param_spread
        for r, (key, label, unit, fmt) in enumerate(PARAM_ROWS):
            self.param_table.setItem(r, 0, _cell(label, Qt.AlignLeft | Qt.AlignVCenter))
            self.param_table.setItem(r, 1, _cell(fmt.format(getattr(result.params, key))))
            self.param_table.setItem(r, 2, _cell(fmt.format(spread[key])))
            self.param_table.setItem(r, 3, _cell(unit, Qt.AlignLeft | Qt.AlignVCenter))
        text = (f"Objective {result.objective:.3g} after {result.evaluations:,} model evaluations "
                f"in {result.seconds:.1f} s; {len(result.param_sets)} near-optimal parameter sets.")
        if result.warnings:
            text += "\n⚠ " + "\n⚠ ".join(result.warnings)
        self.summary.setText(text)
