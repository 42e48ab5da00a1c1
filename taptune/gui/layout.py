"""Small layout helpers shared by the views (side-by-side panes, read-only tables)."""

from __future__ import annotations

from PySide6.QtCore import Qt
from PySide6.QtWidgets import QAbstractItemView, QHeaderView, QSplitter, QTableWidget, QVBoxLayout, QWidget


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
