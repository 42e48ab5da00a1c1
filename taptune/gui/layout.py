"""Small layout helpers shared by the views (side-by-side panes, read-only tables, a label that gives way)."""

from __future__ import annotations

from PySide6.QtCore import Qt
from PySide6.QtGui import QPainter
from PySide6.QtWidgets import (
    QAbstractItemView,
    QHeaderView,
    QLabel,
    QSizePolicy,
    QSplitter,
    QTableWidget,
    QVBoxLayout,
    QWidget,
)


class ElidedLabel(QLabel):
    """A one-line label that shortens its text in the middle ("er32_d16_tap.wav + er32…63.5mm_tap.wav")
    when it has too little room, instead of cutting off the end; it never widens the window."""

    def __init__(self, text: str = "", parent=None):
        super().__init__(text, parent)
        self.setSizePolicy(QSizePolicy.Ignored, QSizePolicy.Preferred)

    def paintEvent(self, event) -> None:
        painter = QPainter(self)
        rect = self.contentsRect()
        shown = self.fontMetrics().elidedText(self.text(), Qt.ElideMiddle, rect.width())
        painter.drawText(rect, int(self.alignment()), shown)


def hsplit(left: QWidget, right: QWidget, stretch: tuple[int, int] = (1, 1)) -> QSplitter:
    """Two panes side by side that the user can resize but never collapse."""
    split = QSplitter(Qt.Horizontal)
    split.addWidget(left)
    split.addWidget(right)
    split.setStretchFactor(0, stretch[0])
    split.setStretchFactor(1, stretch[1])
    split.setChildrenCollapsible(False)
    return split


def read_only_table(rows: int, headers: list[str]) -> QTableWidget:
    """A compact table for results: no editing, no selection, columns sized to their contents."""
    table = QTableWidget(rows, len(headers))
    table.setHorizontalHeaderLabels(headers)
    table.verticalHeader().setVisible(False)
    table.horizontalHeader().setSectionResizeMode(QHeaderView.ResizeToContents)
    table.horizontalHeader().setStretchLastSection(True)
    table.setEditTriggers(QAbstractItemView.NoEditTriggers)
    table.setSelectionMode(QAbstractItemView.NoSelection)
    table.verticalHeader().setDefaultSectionSize(22)
    table.setVerticalScrollBarPolicy(Qt.ScrollBarAlwaysOff)
    set_rows(table, rows)
    return table


def set_rows(table: QTableWidget, rows: int) -> None:
    """Give a :func:`read_only_table` ``rows`` rows, exactly as tall as them: no empty grid below the numbers."""
    table.setRowCount(rows)
    table.setFixedHeight(table.horizontalHeader().sizeHint().height() + rows * 22 + 2 * table.frameWidth() + 2)


def column(*items, margins: int = 0) -> QWidget:
    """Widgets stacked vertically in a plain container; an int item is a stretch factor."""
    box = QWidget()
    layout = QVBoxLayout(box)
    layout.setContentsMargins(margins, margins, margins, margins)
    for item in items:
        if isinstance(item, int):
            layout.addStretch(item)
        else:
            layout.addWidget(item)
    return box
