"""Matplotlib inside Qt: one canvas class with the house style of every plot in the app."""

from __future__ import annotations

from matplotlib.backends.backend_qtagg import FigureCanvasQTAgg
from matplotlib.figure import Figure
from PySide6.QtWidgets import QSizePolicy

# One look for every plot: readable on a 1366×768 laptop, not crowded on 1920×1080.
STYLE = {
    "font.size": 9,
    "axes.titlesize": 10,
    "axes.labelsize": 9,
    "xtick.labelsize": 8,
    "ytick.labelsize": 8,
    "legend.fontsize": 8,
    "axes.grid": True,
    "grid.alpha": 0.3,
    "axes.spines.top": False,
    "axes.spines.right": False,
}

MEASURED = "#1f4e79"
MODEL = "#c0392b"
TAPS = "#b8c2cc"
BENDING = "#c0392b"
LOCAL = "#e67e22"
OTHER = "#7f8c8d"
BAND = "#f5cba7"


class PlotCanvas(FigureCanvasQTAgg):
    """A figure in a widget (no pyplot: no global state shared between views)."""

    def __init__(self, parent=None, height_in: float = 3.0, layout: str | None = "constrained"):
        import matplotlib

        with matplotlib.rc_context(STYLE):
            self.figure = Figure(figsize=(6.0, height_in), layout=layout)
        super().__init__(self.figure)
        self.setParent(parent)
        self.setSizePolicy(QSizePolicy.Expanding, QSizePolicy.Expanding)
        self.setMinimumSize(300, 200)

    def styled(self):
        """Context in which to create axes and artists with the house style."""
        import matplotlib

        return matplotlib.rc_context(STYLE)

    def message(self, text: str) -> None:
        """Replace the plot by a centred grey message."""
        self.figure.clear()
        self.figure.text(0.5, 0.5, text, ha="center", va="center", color="#888888", fontsize=10, wrap=True)
        self.draw_idle()
