"""Advice after an identification: when one recording leaves the predicted bands wide, ask for a second tap.

One tap at one stick-out pins down the holder only as far as that stick-out needs: other
near-optimal parameter sets fit it as well and part ways at other stick-outs (MODEL.md
§8.6). A second recording of the same holder and tool at another stick-out, identified
jointly, separates them. The check uses :func:`taptune.identify.predict`, the same call
as the predictor view and ``taptune predict``.
"""

from __future__ import annotations

from PySide6.QtCore import Qt, Signal
from PySide6.QtWidgets import QFrame, QHBoxLayout, QLabel, QPushButton

from taptune.gui.signals import emit

MM = 1e-3
# How far from the recorded stick-out the bands are looked at (and the second tap advised) [mm].
STEP_MM = 10.0


def widest_band(result, assembly, model_options=None, step_mm: float = STEP_MM):
    """Where the near-optimal fits of one recording part ways most, ``step_mm`` either side of its stick-out.

    The bands are :func:`~taptune.identify.predict`'s honest ones for a holder identified
    on ``assembly`` alone. Only their near-optimal-fits part (``band.set_hz``) is what a
    second recording narrows; the geometry tolerances at the new stick-out stay.
    Returns ``(fits part, whole band, mode 1–3, stick-out [mm])`` with the parts relative
    to the frequency, or None where no neighbouring stick-out fits the tool and holder.
    """
    from taptune.errors import InputError
    from taptune.gui.stickout import stickout_range_mm
    from taptune.identify import predict

    here = assembly.stickout / MM
    lo, hi = stickout_range_mm(assembly)
    widest = None
    for stickout_mm in (here + step_mm, here - step_mm):
        if not lo <= stickout_mm <= hi:
            continue
        try:
            p = predict(result.param_sets, assembly.with_stickout(stickout_mm * MM), model_options,
                        relative_floor=result.relative_floor, identified=[assembly])
        except InputError:
            continue
        for mode, (f, fits, whole) in enumerate(zip(p.bending_hz, p.band.set_hz, p.band.half_width_hz), start=1):
            if widest is None or fits / f > widest[0]:
                widest = (fits / f, whole / f, mode, stickout_mm)
    return widest


def second_tap_advice(result, assembly, model_options=None) -> str | None:
    """A sentence asking for a second tap when one recording leaves the fits wide apart, else None.

    "Wide" is :data:`taptune.identify.bands.WIDE_BAND` (±1 %, the rule of ``taptune
    predict``), applied to the part of the band a second recording narrows.
    """
    from taptune.identify.bands import WIDE_BAND

    widest = widest_band(result, assembly, model_options)
    if widest is None or widest[0] <= WIDE_BAND:
        return None
    fits, whole, mode, stickout_mm = widest
    return (f"One recording leaves the prediction loose: at {stickout_mm:g} mm the fits that explain this tap "
            f"equally well differ by ±{100 * fits:.1f} % on f{mode} (the whole band ±{100 * whole:.1f} %). "
            f"Tap the same holder and tool again at about {stickout_mm:g} mm, add it as the 2nd stick-out and "
            "identify both together.")


class Banner(QFrame):
    """A yellow strip with advice, one action button and a close button; hidden until shown.

    Signals
    -------
    action()
        The action button was pressed.
    """

    action = Signal()

    def __init__(self, action_text: str, parent=None):
        super().__init__(parent)
        self.setObjectName("banner")
        self.setStyleSheet("#banner { background: #fff4c2; border: 1px solid #e0c050; border-radius: 3px; }")
        self.text = QLabel()
        self.text.setWordWrap(True)
        self.text.setTextInteractionFlags(Qt.TextSelectableByMouse)
        self.button = QPushButton(action_text)
        close = QPushButton("×")
        close.setFlat(True)
        close.setFixedWidth(24)
        close.setToolTip("Hide this advice")
        self.button.clicked.connect(lambda: emit(self.action))
        close.clicked.connect(self.hide)
        row = QHBoxLayout(self)
        row.setContentsMargins(8, 4, 4, 4)
        row.addWidget(self.text, 1)
        row.addWidget(self.button)
        row.addWidget(close)
        self.hide()

    def show_text(self, text: str) -> None:
        self.text.setText(text)
        self.show()
