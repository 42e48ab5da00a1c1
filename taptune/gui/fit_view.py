"""Fit view: measured vs model spectrum shape around mode 1, the f1–f3 table, the parameters.

Everything shown comes from the :class:`~taptune.identify.Identification` (its window,
normalised measured and model shapes, frequencies); the view computes nothing.
"""

from __future__ import annotations

import numpy as np
from PySide6.QtCore import Qt
from PySide6.QtGui import QColor
from PySide6.QtWidgets import QLabel, QTableWidgetItem, QVBoxLayout, QWidget

from taptune.gui.layout import column, hsplit, read_only_table, set_rows
from taptune.gui.numbers import NOT_DETERMINED, determined, number
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
        set_rows(self.freq_table, 3)
        self.freq_table.clearContents()
        self.param_table.clearContents()
        self.summary.setText("")

    def show_identification(self, result, title: str = "", names=None) -> None:
        """Show ``result`` (an Identification): one plot and three table rows per recording.

        ``names`` label the recordings of a joint fit (e.g. file and stick-out).
        """
        self.identification = result
        n = len(result.bending_measured_hz)
        names = list(names) if names else [f"recording {i + 1}" for i in range(n)]
        fig = self.canvas.figure
        fig.clear()
        with self.canvas.styled():
            for i in range(n):
                ax = fig.add_subplot(n, 1, i + 1)
                f = np.asarray(result.window_hz[i])
                ax.plot(f, np.asarray(result.measured_shape[i]), color=MEASURED, lw=1.6,
                        label="measured (average of taps)")
                ax.plot(f, np.asarray(result.model_shape[i]), color=MODEL, lw=1.3, ls="--", label="identified model")
                ax.set_ylabel("level / peak")
                if n == 1:
                    ax.set_title(title or "Around bending mode 1", loc="left")
                else:  # one line per plot: the recording (the holder is in the window's other views)
                    ax.set_title(f"{names[i]}" + (f" — joint fit of {n} recordings" if i == 0 else ""), loc="left")
                if i == 0:
                    ax.text(0.01, 0.98, "the window the fit compares:\nf1 ± 100 Hz", transform=ax.transAxes,
                            va="top", ha="left", fontsize=8, color="#555555")
                    ax.legend(loc="upper right", framealpha=0.9)
            ax.set_xlabel("frequency [Hz]")
        self.canvas.draw_idle()

        set_rows(self.freq_table, 3 * n)
        for i in range(n):
            measured = result.bending_measured_hz[i]
            model = result.bending_model_hz[i]
            zeta = result.damping_model[i]
            for k in range(3):
                r = 3 * i + k
                m = measured[k] if k < len(measured) else None
                f_model = model[k] if k < len(model) else float("nan")
                self.freq_table.setItem(r, 0, _cell(f"f{k + 1}" + (f" · {i + 1}" if n > 1 else ""), Qt.AlignCenter))
                self.freq_table.setItem(r, 1, _cell(f"{m:,.1f}" if m is not None else "not found"))
                self.freq_table.setItem(r, 2, _cell(f"{f_model:,.1f}"))
                self.freq_table.setItem(r, 3, _cell(f"{number(100 * (f_model / m - 1), '+.2f')} %" if m else "–"))
                self.freq_table.setItem(r, 4, _cell(f"{100 * zeta[k]:.3f}" if k < len(zeta) else "–"))
        spread = result.param_spread
        self.param_table.clearSpans()
        undetermined = []
        taps = "this tap" if n == 1 else "these taps"
        for r, (key, label, unit, fmt) in enumerate(PARAM_ROWS):
            value = getattr(result.params, key)
            self.param_table.setItem(r, 0, _cell(label, Qt.AlignLeft | Qt.AlignVCenter))
            self.param_table.setItem(r, 3, _cell(unit, Qt.AlignLeft | Qt.AlignVCenter))
            if determined(value, spread[key]):
                self.param_table.setItem(r, 1, _cell(number(value, fmt)))
                self.param_table.setItem(r, 2, _cell(number(spread[key], fmt)))
                continue
            # A ± wider than the value would read as a measurement: say it in words.
            item = _cell(NOT_DETERMINED, Qt.AlignCenter)
            item.setForeground(QColor("#666666"))
            item.setToolTip(f"Not determined by {taps}: best fit {number(value, fmt)} {unit}, but the "
                            f"near-optimal fits spread ±{number(spread[key], fmt)}."
                            + (" A second tap at another stick-out may pin it." if n == 1 else ""))
            undetermined.append(label)
            self.param_table.setItem(r, 1, item)
            self.param_table.setItem(r, 2, None)
            self.param_table.setSpan(r, 1, 1, 2)
        joint = "Joint fit of " + " and ".join(f"{i + 1}: {name}" for i, name in enumerate(names)) + ". "
        text = (joint if n > 1 else "") + (
            f"Objective {result.objective:.3g} after {result.evaluations:,} model evaluations "
            f"in {result.seconds:.1f} s; {len(result.param_sets)} near-optimal parameter sets.")
        if undetermined:
            text += (f" Not determined by {taps} (their fits spread more than their value): "
                     f"{', '.join(undetermined)}.")
        if result.warnings:
            text += "\n⚠ " + "\n⚠ ".join(result.warnings)
        self.summary.setText(text)
