"""Library view: search, list, inspect, export, import and remove holders — the same calls as ``taptune library``.

The table shows one page of holders (:data:`PAGE_SIZE`) whose name contains the search
text, read from the library a page at a time, so a shop's library of thousands of
holders opens as fast as a small one.
"""

from __future__ import annotations

import html
from pathlib import Path

from PySide6.QtCore import Qt, QTimer, Signal
from PySide6.QtWidgets import (
    QAbstractItemView,
    QFileDialog,
    QHBoxLayout,
    QHeaderView,
    QLabel,
    QLineEdit,
    QMessageBox,
    QPushButton,
    QTableWidget,
    QTableWidgetItem,
    QTextBrowser,
    QVBoxLayout,
    QWidget,
)

from taptune.gui.check_view import checks_html
from taptune.gui.fit_view import PARAM_ROWS
from taptune.gui.layout import hsplit
from taptune.gui.messages import show_error, show_info
from taptune.gui.numbers import NOT_DETERMINED, determined, number
from taptune.gui.signals import emit
from taptune.library.schema import date_label

COLUMNS = ("holder", "interface", "identified", "last identified", "last check")
#: Holders per page of the table (each read whole: parameters and history for the details).
PAGE_SIZE = 100
#: Milliseconds of quiet typing before the search runs.
SEARCH_DELAY_MS = 250


def _param_row(label: str, value: float, spread: float, unit: str, fmt: str) -> str:
    """One parameter as a table row; a spread wider than the value reads 'not determined' (as in the Fit view)."""
    e = html.escape
    # Labels keep their words whole: the details pane is narrow at 1366×768.
    whole = "style='white-space:nowrap'"
    name, unit_cell = f"<td {whole}>{e(label)}</td>", f"<td>{e(unit)}</td>"  # a long unit may wrap
    if determined(value, spread):
        return (f"<tr>{name}<td align=right {whole}>{e(number(value, fmt))}</td>"
                f"<td align=right {whole}>± {e(number(spread, fmt))}</td>{unit_cell}</tr>")
    return (f"<tr>{name}<td colspan=2 align=center style='color:#666666; white-space:nowrap'>{NOT_DETERMINED}</td>"
            f"{unit_cell}</tr>")


def entry_html(entry) -> str:
    """A readable description of a library entry: geometry, parameters with spread, history."""
    e = html.escape
    h = entry.holder
    spread = entry.spread()
    rows = "".join(_param_row(label, getattr(entry.params, key), spread[key], unit, fmt)
                   for key, label, unit, fmt in PARAM_ROWS)
    segments = ", ".join(f"{s['length']:g}×Ø{s['od']:g}/{s['id']:g}" for s in h.get("segments", []))
    history = "".join(
        f"<li>{e(date_label(r.date))}: {e(r.recording)}, {e(r.tool_name)} at {r.stickout_mm:g} mm, "
        f"f = {', '.join(f'{f:,.0f}' for f in r.bending_measured_hz)} Hz, objective {r.objective:.3g}</li>"
        for r in entry.identifications
    )
    # What reading found implausible but kept (geometry an older taptune saved).
    warnings = "".join(f"<p style='color:#b00020'>⚠ {e(w)}</p>" for w in getattr(entry, "warnings", ()))
    return (
        f"<h3>{e(entry.name)}</h3>{warnings}"
        f"<p>Interface {e(entry.interface)}; clamp length {h.get('clamp_length', 0):g} mm; "
        f"segments (length×Ø outer/inner, mm): {e(segments)}</p>"
        f"<p><b>Parameters</b> ({len(entry.param_sets)} near-optimal sets)</p>"
        f"<table cellspacing=4>{rows}</table>"
        f"<p><b>Identifications</b></p><ul>{history or '<li>none recorded</li>'}</ul>"
        f"<p><b>Checks by one tap</b> (newest first)</p><ul>{checks_html(entry)}</ul>"
    )


class LibraryView(QWidget):
    """The holder library file and its holders.

    Signals
    -------
    changed(dict)
        The entries after any change (also after opening another library); empty, with
        :attr:`error` set, when the file cannot be read.
    use_for_prediction(object)
        The chosen :class:`~taptune.library.HolderEntry`.
    use_on_machine(object)
        The chosen entry, for the Machine view (lobes with the panel's tool and stick-out).
    """

    changed = Signal(dict)
    use_for_prediction = Signal(object)
    use_on_machine = Signal(object)

    def __init__(self, library_path, parent=None):
        super().__init__(parent)
        self.path_label = QLabel()
        self.path_label.setTextInteractionFlags(Qt.TextSelectableByMouse)
        self.path_label.setWordWrap(True)
        self.search = QLineEdit()
        self.search.setPlaceholderText("Search holders by name…")
        self.search.setClearButtonEnabled(True)
        self._search_timer = QTimer(self)
        self._search_timer.setSingleShot(True)
        self._search_timer.setInterval(SEARCH_DELAY_MS)
        self._search_timer.timeout.connect(self._new_search)
        self.search.textChanged.connect(lambda _text: self._search_timer.start())
        self.search.returnPressed.connect(self._new_search)
        self.page_label = QLabel()
        self.previous_button = QPushButton("◀ Previous")
        self.next_button = QPushButton("Next ▶")
        self.previous_button.clicked.connect(lambda: self._turn(-1))
        self.next_button.clicked.connect(lambda: self._turn(+1))
        self.table = QTableWidget(0, len(COLUMNS))
        self.table.setHorizontalHeaderLabels([c.capitalize() for c in COLUMNS])
        header = self.table.horizontalHeader()
        header.setSectionResizeMode(QHeaderView.ResizeToContents)
        header.setSectionResizeMode(0, QHeaderView.Stretch)
        header.setMinimumSectionSize(40)
        self.table.verticalHeader().setVisible(False)
        self.table.verticalHeader().setDefaultSectionSize(self.table.fontMetrics().height() + 8)  # more rows per page
        self.table.setWordWrap(False)
        self.table.setTextElideMode(Qt.ElideMiddle)  # a long name keeps its start and its end
        self.table.setSelectionBehavior(QAbstractItemView.SelectRows)
        self.table.setSelectionMode(QAbstractItemView.SingleSelection)
        self.table.setEditTriggers(QAbstractItemView.NoEditTriggers)
        self.table.itemSelectionChanged.connect(self._selected)
        self.details = QTextBrowser()
        self.details.setOpenLinks(False)

        self.buttons = {}
        row = QHBoxLayout()
        for key, text, slot in (
            ("predict", "Use for prediction", self._use),
            ("machine", "Lobes on the machine", self._use_on_machine),
            ("import", "Import…", self._import_dialog),
            ("export", "Export…", self._export_dialog),
            ("remove", "Remove…", self._remove_dialog),
            ("open", "Open other library…", self._open_dialog),
        ):
            button = QPushButton(text)
            button.clicked.connect(slot)
            self.buttons[key] = button
            row.addWidget(button)
        row.addStretch(1)
        paging = QHBoxLayout()
        paging.addWidget(self.search, 1)
        paging.addWidget(self.page_label)
        paging.addWidget(self.previous_button)
        paging.addWidget(self.next_button)
        left = QWidget()
        left_layout = QVBoxLayout(left)
        left_layout.setContentsMargins(0, 0, 0, 0)
        left_layout.addLayout(paging)
        left_layout.addWidget(self.table, 1)

        # The table gets the larger share: names of 40 characters and five columns at 1366 px.
        split = hsplit(left, self.details, stretch=(4, 3))
        layout = QVBoxLayout(self)
        layout.setContentsMargins(0, 0, 0, 0)
        layout.addWidget(self.path_label)
        layout.addLayout(row)
        layout.addWidget(split, 1)
        #: The holders of the page shown, by name (whole entries: the pickers and the details use them).
        self.entries: dict = {}
        #: How many holders match the search; the first shown is number ``offset + 1``.
        self.total = 0
        self.offset = 0
        # Why the library cannot be read (one line naming it), or None.
        self.error: str | None = None
        self._library = None
        self.set_library(library_path)

    # ------------------------------------------------------------------ state

    @property
    def library(self):
        """The open library (one store, its connection kept while the view shows it)."""
        from taptune.library import HolderLibrary

        if self._library is None:
            self._library = HolderLibrary(self.library_path)
        return self._library

    @property
    def location(self) -> str:
        """The library as shown to the user (a server address without its password)."""
        from taptune.library.sql_store import redacted

        return redacted(str(self.library_path))

    def set_library(self, path) -> None:
        from taptune.library.store import default_library_path

        if self._library is not None:
            self._library.close()
            self._library = None
        self.library_path = default_library_path(str(path))
        self.offset = 0
        self.refresh()

    @property
    def match(self) -> str:
        """The search text (holders whose name contains it, in any case)."""
        return self.search.text().strip()

    def _new_search(self) -> None:
        self._search_timer.stop()
        self.offset = 0
        self.refresh()

    def _turn(self, pages: int) -> None:
        self.offset = max(0, min(self.offset + pages * PAGE_SIZE, max(self.total - 1, 0) // PAGE_SIZE * PAGE_SIZE))
        self.refresh()

    def refresh(self) -> None:
        """Re-read the page shown (a broken library is reported, never overwritten).

        A library that cannot be read leaves :attr:`error` set, and the view and a dialog say why.
        """
        from taptune.errors import TaptuneError

        selected = self.selected()
        try:
            self.total = self.library.count(self.match)
            if self.offset >= self.total:
                self.offset = max(self.total - 1, 0) // PAGE_SIZE * PAGE_SIZE
            self.entries = self.library.page(self.match, limit=PAGE_SIZE, offset=self.offset)
            self.error = None
        except TaptuneError as err:
            self.entries, self.total = {}, 0
            self.error = str(err)
            show_error(self, "Cannot read the holder library", self.error)
        broken = " (cannot be read)" if self.error is not None else ""
        self.path_label.setText(f"Holder library: {self.location}{broken}")
        self._show_page()
        self.table.blockSignals(True)
        self.table.setRowCount(len(self.entries))
        for r, entry in enumerate(self.entries.values()):
            checks = getattr(entry, "checks", ())
            values = (entry.name, entry.interface, str(len(entry.identifications)),
                      date_label(entry.last_identified) or "–", checks[-1].verdict if checks else "–")
            for c, text in enumerate(values):
                item = QTableWidgetItem(text)
                if c == 0:
                    item.setToolTip(entry.name)
                if c == 4 and checks:
                    item.setToolTip(f"{date_label(checks[-1].date)} UTC: {checks[-1].verdict}")
                if entry.warnings:
                    item.setToolTip("\n".join(entry.warnings))
                    if c == 0:
                        item.setText(f"⚠ {text}")
                self.table.setItem(r, c, item)
        self.table.blockSignals(False)
        if self.error is not None:
            # Not "empty": the holders may all be in the file, which a repair brings back.
            self.details.setHtml(
                f"<p style='color:#b00020'>{html.escape(self.error)}</p>"
                "<p>Nothing is saved into this library while it cannot be read. Repair it (or restore "
                "a copy) and open it again, or open another library.</p>")
        elif not self.entries and self.match:
            self.details.setHtml(f"<p>No holder name contains “{html.escape(self.match)}”.</p>")
        elif not self.entries:
            self.details.setHtml("<p>The library is empty: identify a holder and save it, or import a library file.</p>")
        elif selected is not None and selected.name in self.entries:
            self.select(selected.name)  # the same holder may hold newer data (a check, a new identification)
            self._selected()
        else:
            self.table.selectRow(0)
        self._update_buttons()
        emit(self.changed, self.entries)

    def _show_page(self) -> None:
        shown = len(self.entries)
        if self.total == 0:
            self.page_label.setText("no holders" if not self.match else "no match")
        else:
            self.page_label.setText(f"{self.offset + 1:,}–{self.offset + shown:,} of {self.total:,}")
        self.previous_button.setEnabled(self.offset > 0)
        self.next_button.setEnabled(self.offset + shown < self.total)

    def selected(self):
        """The selected entry, or None."""
        row = self.table.currentRow()
        names = list(self.entries)
        return self.entries[names[row]] if 0 <= row < len(names) else None

    def select(self, name: str) -> None:
        """Select holder ``name``; if it is not on the page shown, search for it first."""
        names = list(self.entries)
        if name not in names and name:
            self.search.blockSignals(True)
            self.search.setText(name)
            self.search.blockSignals(False)
            self._new_search()
            names = list(self.entries)
        if name in names:
            self.table.selectRow(names.index(name))

    def _selected(self) -> None:
        entry = self.selected()
        if entry is not None:
            self.details.setHtml(entry_html(entry))
        self._update_buttons()

    def _update_buttons(self) -> None:
        has = self.selected() is not None
        for key in ("predict", "machine", "remove"):
            self.buttons[key].setEnabled(has)
        self.buttons["export"].setEnabled(self.total > 0)

    # ------------------------------------------------------------------ actions

    def _use(self) -> None:
        entry = self.selected()
        if entry is not None:
            emit(self.use_for_prediction, entry)

    def _use_on_machine(self) -> None:
        entry = self.selected()
        if entry is not None:
            emit(self.use_on_machine, entry)

    def export_to(self, path, format: str | None = None) -> int | None:
        """Export the library (JSON or CSV from the suffix); a dialog reports the outcome."""
        from taptune.errors import TaptuneError

        from taptune.library.store import default_library_path

        format = format or ("csv" if str(path).lower().endswith(".csv") else "json")
        default = default_library_path()
        if (isinstance(default, Path) and Path(path).expanduser().resolve() == default.expanduser().resolve()
                and default != self.library_path):
            # Exporting another library over the default one would replace the user's holders.
            show_error(self, "Export failed", f"{path}: is the holder library; exporting there would destroy it")
            return None
        try:
            count = self.library.export(path, format=format)
        except TaptuneError as err:
            show_error(self, "Export failed", str(err))
            return None
        show_info(self, "Library exported", f"{count} holder(s) written to {path}")
        return count

    def import_from(self, path, replace: bool = False):
        """Validate and merge a library file; a dialog shows what happened."""
        from taptune.errors import TaptuneError

        try:
            report = self.library.import_file(path, replace=replace)
        except TaptuneError as err:
            show_error(self, "Import failed", str(err))
            return None
        self.refresh()
        show_info(self, "Library imported", "\n".join(report.lines()))
        return report

    def remove(self, name: str) -> bool:
        """Remove the holder ``name`` from the library file."""
        from taptune.errors import TaptuneError

        try:
            self.library.remove(name)
        except TaptuneError as err:
            show_error(self, "Cannot remove", str(err))
            return False
        self.refresh()
        return True

    def _export_dialog(self) -> None:
        path, _ = QFileDialog.getSaveFileName(self, "Export library", "holders.json", "JSON (*.json);;CSV (*.csv)")
        if path:
            self.export_to(path)

    def _import_dialog(self) -> None:
        path, _ = QFileDialog.getOpenFileName(self, "Import holders", "", "Holder library (*.json)")
        if path:
            self.import_from(path)

    def _remove_dialog(self) -> None:
        entry = self.selected()
        if entry is None:
            return
        box = QMessageBox(QMessageBox.Question, "Remove holder",
                          f"Remove {entry.name!r} and its {len(entry.identifications)} identification(s) "
                          "from the library?", QMessageBox.Yes | QMessageBox.Cancel, self)
        box.setDefaultButton(QMessageBox.Cancel)
        box.setAttribute(Qt.WA_DeleteOnClose)
        box.finished.connect(lambda result, name=entry.name: result == QMessageBox.Yes and self.remove(name))
        box.open()

    def _open_dialog(self) -> None:
        start = str(self.library_path) if isinstance(self.library_path, Path) else ""
        path, _ = QFileDialog.getSaveFileName(self, "Open or create a holder library", start,
                                              "Holder library (*.db *.json)", options=QFileDialog.DontConfirmOverwrite)
        if path:
            self.set_library(path)
