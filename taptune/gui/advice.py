"""Advice after an identification: when one recording leaves the predicted bands wide, ask for a second tap.

One tap at one stick-out pins down the holder only as far as that stick-out needs: other
near-optimal parameter sets fit it as well and part ways at other stick-outs (docs/physics.md,
§5). A second recording of the same holder and tool at another stick-out, identified
jointly, separates them. The rule and the prediction are ``taptune identify``'s.
"""

from __future__ import annotations

from PySide6.QtCore import Qt, Signal
from PySide6.QtWidgets import QFrame, QHBoxLayout, QLabel, QPushButton, QSizePolicy, QVBoxLayout

from taptune.gui.signals import emit


def second_tap_advice(result, assembly) -> tuple[str, str] | None:
    """``(one line, details)`` asking for a second tap when one recording leaves a wide band, else None.

    The rule is ``taptune identify``'s: the prediction at the recorded stick-out + 20 mm
    (:func:`taptune.identify.pipeline.transfer_outlook`) has a band wider than
    :data:`taptune.identify.bands.WIDE_BAND` (:func:`taptune.identify.bands.second_tap_advice`).
    The line fits the banner over the views; the details say why (shown on demand).
    """
    from taptune.identify.bands import second_tap_advice as advice_in_words
    from taptune.identify.pipeline import transfer_outlook

    outlook = transfer_outlook(result, [assembly])
    if outlook is None or advice_in_words([outlook]) is None:
        return None
    at = f"{outlook.stickout_mm:g} mm"
    widest = 100 * float(max(outlook.band.relative(outlook.bending_hz)))
    line = (f"One tap leaves other stick-outs loose (±{widest:.1f} % at {at}): tap again at about {at} "
            "and identify both together.")
    details = (f"One recording leaves the prediction loose at other stick-outs. At {at}: "
               f"{outlook.band.text(outlook.bending_hz)} Tap the same holder and tool again at about {at}, "
               "add it as the 2nd stick-out and identify both together: that narrows what one tap cannot tell apart.")
    return line, details


class Banner(QFrame):
    """A one-line yellow strip with advice, details on demand, one action button and a close button.

    Hidden until shown. The details open below the line (button "Details") and are the
    line's tooltip too: the strip never takes more than one line of the views' height
    unless asked.

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
        self.text.setTextInteractionFlags(Qt.TextSelectableByMouse)
        # One line that never widens the window; the full text is in the tooltip and the details.
        self.text.setSizePolicy(QSizePolicy.Ignored, QSizePolicy.Preferred)
        self.details = QLabel()
        self.details.setWordWrap(True)
        self.details.setTextInteractionFlags(Qt.TextSelectableByMouse)
        self.details.hide()
        self.details_button = QPushButton("Details")
        self.details_button.setFlat(True)
        self.details_button.setCheckable(True)
        self.details_button.toggled.connect(self.details.setVisible)
        self.button = QPushButton(action_text)
        close = QPushButton("×")
        close.setFlat(True)
        close.setFixedWidth(24)
        close.setToolTip("Hide this advice")
        self.button.clicked.connect(lambda: emit(self.action))
        close.clicked.connect(self.hide)
        row = QHBoxLayout()
        row.addWidget(self.text, 1)
        row.addWidget(self.details_button)
        row.addWidget(self.button)
        row.addWidget(close)
        column = QVBoxLayout(self)
        column.setContentsMargins(8, 2, 4, 2)
        column.setSpacing(2)
        column.addLayout(row)
        column.addWidget(self.details)
        self.hide()

    def show_text(self, text: str, details: str = "") -> None:
        """Show the one-line ``text``; ``details`` (optional) on demand."""
        self.text.setText(text)
        self.text.setToolTip(details or text)
        self.details.setText(details)
        self.details_button.setChecked(False)
        self.details_button.setVisible(bool(details))
        self.show()
