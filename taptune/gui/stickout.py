"""The stick-out control of the predictor and the machine view: a slider and a field that move together."""

from __future__ import annotations

from PySide6.QtCore import Qt, Signal
from PySide6.QtWidgets import QDoubleSpinBox, QHBoxLayout, QLabel, QSlider, QWidget

from taptune.gui.signals import emit

MM = 1e-3
SLIDER_STEPS_PER_MM = 10


def stickout_range_mm(assembly) -> tuple[float, float]:
    """Stick-outs the slider offers [mm]: from the holder's depth to 5 mm of grip left."""
    import numpy as np

    total = assembly.tool.total_length / MM
    lo = max(1.0, total - assembly.holder.length / MM + 0.1)
    hi = max(lo + 1.0, total - 5.0)
    return float(np.ceil(lo)), float(np.floor(hi))


class StickoutSlider(QWidget):
    """"Stick-out" label, slider (0.1 mm steps) and field [mm].

    Signals
    -------
    changed(float)
        The stick-out the user chose [mm] (not emitted by :meth:`set_assembly`).
    """

    changed = Signal(float)

    def __init__(self, parent=None):
        super().__init__(parent)
        self.slider = QSlider(Qt.Horizontal)
        self.spin = QDoubleSpinBox()
        self.spin.setDecimals(1)
        self.spin.setSuffix(" mm")
        self.spin.setSingleStep(0.5)
        self.spin.setKeyboardTracking(False)
        self.slider.valueChanged.connect(lambda v: self.spin.setValue(v / SLIDER_STEPS_PER_MM))
        self.spin.valueChanged.connect(self._spin_changed)
        row = QHBoxLayout(self)
        row.setContentsMargins(0, 0, 0, 0)
        row.addWidget(QLabel("Stick-out"))
        row.addWidget(self.slider, 1)
        row.addWidget(self.spin)

    def value(self) -> float:
        return self.spin.value()

    def set_value(self, value: float) -> None:
        """Move the stick-out [mm] as the user would (emits ``changed``)."""
        self.spin.setValue(value)

    def set_assembly(self, assembly) -> None:
        """Offer the stick-outs of ``assembly``'s tool and holder, at its own stick-out (no signal)."""
        lo, hi = stickout_range_mm(assembly)
        current = assembly.stickout / MM
        for w in (self.slider, self.spin):
            w.blockSignals(True)
        self.slider.setRange(int(lo * SLIDER_STEPS_PER_MM), int(hi * SLIDER_STEPS_PER_MM))
        self.spin.setRange(lo, hi)
        self.spin.setValue(current)
        self.slider.setValue(int(round(current * SLIDER_STEPS_PER_MM)))
        for w in (self.slider, self.spin):
            w.blockSignals(False)

    def _spin_changed(self, value: float) -> None:
        self.slider.blockSignals(True)
        self.slider.setValue(int(round(value * SLIDER_STEPS_PER_MM)))
        self.slider.blockSignals(False)
        emit(self.changed, float(value))
