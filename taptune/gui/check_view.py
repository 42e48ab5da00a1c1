"""Check view: the verdict of one tap against a library holder, big and clear, with the per-mode numbers.

What is shown comes from :func:`taptune.library.checks.check_holder` — the call behind
``taptune check`` — run by the main window in a worker: consistent (green), differs (red)
or inconclusive (amber), in words a machinist acts on, then each mode's measured and
predicted frequency with its band, and the reasons.
"""

from __future__ import annotations

import html

from PySide6.QtCore import Qt
from PySide6.QtGui import QColor
from PySide6.QtWidgets import QLabel, QTableWidgetItem, QVBoxLayout, QWidget

from taptune.gui.layout import read_only_table, set_rows

#: Verdict -> (colour, headline, what to do).
VERDICTS = {
    "consistent": ("#1e7b34", "✔  CONSISTENT",
                   "The tap agrees with the library's prediction for this holder: use its data as it is."),
    "differs": ("#b00020", "✘  DIFFERS",
                "The holder no longer behaves as identified: a worn, dirty or badly seated collet or taper, or "
                "the wrong tool or stick-out on the left. Clean and re-seat it and tap again, or identify it anew."),
    "inconclusive": ("#a86400", "?  INCONCLUSIVE",
                     "This tap cannot tell (see the reasons below): tap again, or at another stick-out."),
}
STATUS_COLOURS = {"inside": "#1e7b34", "beyond": "#a86400", "outside": "#b00020"}


def _cell(text: str, colour: str | None = None) -> QTableWidgetItem:
    item = QTableWidgetItem(text)
    item.setTextAlignment((Qt.AlignLeft if colour else Qt.AlignRight) | Qt.AlignVCenter)
    if colour:
        item.setForeground(QColor(colour))
    return item


class CheckView(QWidget):
    """The latest check: verdict banner, per-mode table, reasons and warnings."""

    def __init__(self, parent=None):
        super().__init__(parent)
        self.verdict = QLabel()
        self.verdict.setAlignment(Qt.AlignCenter)
        self.verdict.setMinimumHeight(64)
        self.advice = QLabel()
        self.advice.setWordWrap(True)
        self.advice.setAlignment(Qt.AlignCenter)
        self.context = QLabel()
        self.context.setWordWrap(True)
        self.context.setTextInteractionFlags(Qt.TextSelectableByMouse)
        self.table = read_only_table(3, ["mode", "measured Hz", "predicted Hz ± band", "deviation", "status"])
        self.reasons = QLabel()
        self.reasons.setWordWrap(True)
        self.reasons.setTextInteractionFlags(Qt.TextSelectableByMouse)
        self.reasons.setAlignment(Qt.AlignTop | Qt.AlignLeft)
        self.table.setMaximumWidth(640)
        self.history = QLabel()
        self.history.setWordWrap(True)
        self.history.setTextInteractionFlags(Qt.TextSelectableByMouse)
        self.history.setAlignment(Qt.AlignTop | Qt.AlignLeft)
        layout = QVBoxLayout(self)
        layout.addWidget(self.verdict)
        layout.addWidget(self.advice)
        layout.addWidget(self.context)
        layout.addWidget(self.table)
        layout.addWidget(self.reasons)
        layout.addWidget(self.history, 1)
        self.check = None
        self.clear()

    def clear(self, text: str = "") -> None:
        self.check = None
        self.verdict.setText("")
        self.verdict.setStyleSheet("")
        self.advice.setText(text or "Select a holder in the Library tab, open or record a tap of it (any tool and "
                                    "stick-out, described on the left), then press Check.")
        self.context.setText("")
        self.table.clearContents()
        self.reasons.setText("")
        self.history.setText("")

    def show_history(self, entry) -> None:
        """The checks of library ``entry`` so far (the one just made first)."""
        self.history.setText(f"<p><b>Checks of this holder</b> (newest first)</p><ul>{checks_html(entry)}</ul>")

    def show_check(self, check) -> None:
        """Show a :class:`~taptune.library.checks.HolderCheck`."""
        self.check = check
        colour, headline, advice = VERDICTS[check.verdict]
        self.verdict.setText(headline)
        self.verdict.setStyleSheet(f"color: white; background: {colour}; font-size: 26pt; font-weight: bold; "
                                   "border-radius: 6px; padding: 6px;")
        self.advice.setText(f"<b style='color:{colour}'>{html.escape(advice)}</b>")
        r = check.record
        saved = "kept in its history" if check.saved else "not saved"
        self.context.setText(f"Holder <b>{html.escape(check.holder)}</b> with {html.escape(r.tool)} at "
                             f"{r.stickout_mm:g} mm; tap {html.escape(r.recording)} ({check.analysis.n_taps} taps); "
                             f"{saved}.")
        modes = check.result.modes
        set_rows(self.table, len(modes))
        for row, m in enumerate(modes):
            colour = STATUS_COLOURS.get(m.status)
            self.table.setItem(row, 0, _cell(f"f{m.mode}"))
            self.table.setItem(row, 1, _cell("—" if m.measured_hz is None else f"{m.measured_hz:,.1f}"))
            self.table.setItem(row, 2, _cell(f"{m.predicted_hz:,.1f} ± {m.band_hz:,.1f}"))
            self.table.setItem(row, 3, _cell("—" if m.deviation_pct is None else f"{m.deviation_pct:+.2f} %"))
            self.table.setItem(row, 4, _cell(m.status, colour))
        lines = [f"• {html.escape(x)}" for x in check.result.reasons]
        lines += [f"⚠ {html.escape(w)}" for w in check.warnings]
        self.reasons.setText("<br>".join(lines))


def checks_html(entry) -> str:
    """The holder's check history as list items, newest first, each verdict in its colour."""
    from taptune.library.schema import date_label

    e = html.escape
    items = []
    for c in reversed(getattr(entry, "checks", ())):
        colour = VERDICTS.get(c.verdict, ("#555555",))[0]
        measured = ", ".join(f"{m['measured_hz']:,.0f}" if m.get("measured_hz") is not None else "—"
                             for m in c.modes)
        items.append(f"<li>{e(date_label(c.date))}: <b style='color:{colour}'>{e(c.verdict)}</b>"
                     f" — {e(c.recording)}, {e(c.tool)} at {c.stickout_mm:g} mm, f = {measured} Hz</li>")
    return "".join(items) or "<li>none yet: open a tap of this holder and press Check</li>"
