"""Advice after an identification: when one recording leaves the predicted bands wide, ask for a second tap.

One tap at one stick-out pins down the holder only as far as that stick-out needs: other
near-optimal parameter sets fit it as well and part ways at other stick-outs (MODEL.md
§8.6). A second recording of the same holder and tool at another stick-out, identified
jointly, separates them. The rule and the prediction are ``taptune identify``'s.
"""

from __future__ import annotations

from PySide6.QtCore import Qt, Signal
from PySide6.QtWidgets import QFrame, QHBoxLayout, QLabel, QPushButton

from taptune.gui.signals import emit


def second_tap_advice(result, assembly) -> str | None:
    """A paragraph asking for a second tap when one recording leaves a wide band, else None.

    The rule is ``taptune identify``'s: the prediction at the recorded stick-out + 20 mm
    (:func:`taptune.identify.pipeline.transfer_outlook`) has a band wider than
    :data:`taptune.identify.bands.WIDE_BAND` (:func:`taptune.identify.bands.second_tap_advice`).
    """
    from taptune.identify.bands import second_tap_advice as advice_in_words
    from taptune.identify.pipeline import transfer_outlook

    outlook = transfer_outlook(result, [assembly])
    if outlook is None or advice_in_words([outlook]) is None:
        return None
    return (f"One recording leaves the prediction loose at other stick-outs. At {outlook.stickout_mm:g} mm: "
            f"{outlook.band.text(outlook.bending_hz)} Tap the same holder and tool again at about "
            f"{outlook.stickout_mm:g} mm, add it as the 2nd stick-out and identify both together: that "
            "narrows what one tap cannot tell apart.")


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
