"""Assembly panel: pick holder and tool (assets, holder library, files), edit dimensions, see them to scale.

The panel keeps the holder and tool as the tables of an assembly file (mm, GPa) and
turns them into a validated :class:`~taptune.io.assembly.Assembly` with
:func:`~taptune.io.assembly.parse_assembly` after every edit: the GUI checks geometry
with exactly the rules the CLI uses. An invalid edit shows the message and keeps the
last valid assembly.
"""

from __future__ import annotations

import copy
import tomllib
from pathlib import Path

from PySide6.QtCore import Qt, Signal
from PySide6.QtWidgets import (
    QComboBox,
    QDoubleSpinBox,
    QFileDialog,
    QFormLayout,
    QGroupBox,
    QHBoxLayout,
    QHeaderView,
    QLabel,
    QLineEdit,
    QPushButton,
    QTableWidget,
    QTableWidgetItem,
    QTabWidget,
    QVBoxLayout,
    QWidget,
)

from taptune.gui.assembly_drawing import AssemblyDrawing
from taptune.gui.signals import emit

MM = 1e-3
NOT_SET = "not set"
INTERFACES = ("HSK-A63", "HSK-A100", "HSK-E40", "SK40", "BT40", "CAT40", "unknown")


def assets_dir() -> Path:
    """The holder and tool geometries shipped with taptune (the clone's ``assets/``; package data when installed)."""
    from taptune.examples import assets_dir as shipped

    return shipped()


def read_asset_tables(folder: Path) -> tuple[list[tuple[str, Path, dict]], list[tuple[str, Path, dict]]]:
    """Holder and tool tables of every TOML file under ``folder``: ``([(name, file, table)], [...])``.

    A file may hold a ``[holder]``, a ``[tool]`` or both (a whole assembly); files that
    are not valid TOML are skipped (they are reported when opened directly). A valid
    whole assembly gives its tables in the normal form of :func:`normal_tables`, so that
    a loaded assembly is recognised in the lists.
    """
    from taptune.errors import InputError
    from taptune.io.assembly import parse_assembly

    holders, tools = [], []
    if not folder.is_dir():
        return holders, tools
    for path in sorted(folder.rglob("*.toml")):
        try:
            data = tomllib.loads(path.read_text(encoding="utf-8"))
        except (OSError, UnicodeDecodeError, tomllib.TOMLDecodeError):
            continue
        try:
            data = dict(zip(("holder", "tool"), normal_tables(parse_assembly(data, str(path)))))
        except InputError:
            pass  # a holder-only or tool-only file: its tables are used as written
        if isinstance(data.get("holder"), dict) and "name" in data["holder"]:
            holders.append((str(data["holder"]["name"]), path, data["holder"]))
        if isinstance(data.get("tool"), dict):
            tools.append((str(data["tool"].get("name", path.stem)), path, data["tool"]))
    return holders, tools


def normal_tables(assembly) -> tuple[dict, dict]:
    """The ``[holder]`` and ``[tool]`` tables of an assembly, written out the same way every time."""
    from taptune.io.assembly import holder_to_dict

    return holder_to_dict(assembly.holder), tool_table(assembly.tool)


def tool_table(tool) -> dict:
    """An io Tool as an assembly-file ``[tool]`` table (shank/flute keys where the tool has them)."""
    from taptune.library.schema import tool_to_dict

    table = tool_to_dict(tool)
    if tool.shank_diameter is not None:
        table.pop("segments")
    return table


def _named(choices, folder: Path) -> list[tuple[str, dict, str]]:
    """``[(name, file, table)]`` of :func:`read_asset_tables` as list entries ``[(label, table, where)]``.

    The name alone is the label; a name found in several files gets its file's name to tell them apart.
    """
    names = [name for name, _, _ in choices]
    out = []
    for name, path, table in choices:
        label = f"{name}  [{path.stem}]" if names.count(name) > 1 else name
        where = f"from {folder.name}/{path.relative_to(folder).as_posix()}"
        out.append((label, table, where))
    return out


def _with_headings(sections) -> list[tuple[str, dict | None, str]]:
    """The choices of a list: the prompt, then per non-empty section a heading (no table) and its entries."""
    out = [("", None, "")]
    for heading, entries in sections:
        if entries:
            out.append((f"— {heading} —", None, ""))
            out.extend(entries)
    return out


def _fill_combo(combo: QComboBox, choices, prompt: str) -> None:
    """Fill ``combo`` with ``prompt`` and ``choices``; headings cannot be picked; the list opens wide enough."""
    from PySide6.QtGui import QFontMetrics

    combo.blockSignals(True)
    combo.clear()
    combo.addItem(prompt)
    for label, table, where in choices[1:]:
        combo.addItem(label)
        i = combo.count() - 1
        if table is None:
            item = combo.model().item(i)
            item.setEnabled(False)
            item.setSelectable(False)
        else:
            combo.setItemData(i, where, Qt.ToolTipRole)
    metrics = QFontMetrics(combo.font())
    widest = max((metrics.horizontalAdvance(combo.itemText(i)) for i in range(combo.count())), default=0)
    combo.view().setMinimumWidth(widest + 40)  # the open list shows whole names, however narrow the panel
    combo.setToolTip("")
    combo.blockSignals(False)


def _spin(lo: float, hi: float, decimals: int = 2, suffix: str = " mm", unset: bool = False) -> QDoubleSpinBox:
    """A number field; ``unset``: it starts empty ("not set", the value 0) instead of at ``lo``."""
    box = QDoubleSpinBox()
    box.setRange(0.0 if unset else lo, hi)
    if unset:
        box.setSpecialValueText(NOT_SET)
    box.setDecimals(decimals)
    box.setSuffix(suffix)
    box.setKeyboardTracking(False)  # validate the number once it is typed, not every keystroke
    return box


class SegmentsTable(QTableWidget):
    """Editable list of cylinders: length, outer and inner diameter [mm]."""

    edited = Signal()

    def __init__(self, parent=None):
        super().__init__(0, 3, parent)
        self.setHorizontalHeaderLabels(["length mm", "OD mm", "ID mm"])
        self.horizontalHeader().setSectionResizeMode(QHeaderView.Stretch)
        self.verticalHeader().setDefaultSectionSize(22)
        self.setMinimumHeight(90)
        self.itemChanged.connect(lambda _item: emit(self.edited))

    def set_segments(self, segments: list[dict]) -> None:
        self.blockSignals(True)
        self.setRowCount(len(segments))
        for r, s in enumerate(segments):
            for c, key in enumerate(("length", "od", "id")):
                self.setItem(r, c, QTableWidgetItem(f"{float(s.get(key, 0.0)):g}"))
        self.blockSignals(False)

    def segments(self) -> list[dict]:
        """The rows as segment tables; a cell that is not a number is passed on as text (parse reports it)."""
        out = []
        for r in range(self.rowCount()):
            row = {}
            for c, key in enumerate(("length", "od", "id")):
                item = self.item(r, c)
                text = item.text().strip() if item is not None else ""
                try:
                    row[key] = float(text) if text else 0.0
                except ValueError:
                    row[key] = text
            out.append(row)
        return out

    def add_row(self) -> None:
        last = self.segments()[-1] if self.rowCount() else {"length": 10.0, "od": 40.0, "id": 0.0}
        self.set_segments(self.segments() + [dict(last)])
        emit(self.edited)

    def remove_row(self) -> None:
        if self.rowCount() > 1:
            row = self.currentRow() if self.currentRow() >= 0 else self.rowCount() - 1
            rows = self.segments()
            del rows[row]
            self.set_segments(rows)
            emit(self.edited)


class AssemblyPanel(QWidget):
    """Holder, tool and stick-out of the assembly under test.

    Signals
    -------
    assembly_changed(object)
        The new valid :class:`~taptune.io.assembly.Assembly` (None while invalid).
    """

    assembly_changed = Signal(object)
    second_stickout_changed = Signal(float)

    def __init__(self, parent=None):
        super().__init__(parent)
        self._holder: dict | None = None
        self._tool: dict | None = None
        self._assembly = None
        self._filling = False
        self.library_holders: dict[str, dict] = {}
        self.drawing = AssemblyDrawing()

        self.holder_combo = QComboBox()
        self.tool_combo = QComboBox()
        for combo in (self.holder_combo, self.tool_combo):
            combo.setSizeAdjustPolicy(QComboBox.AdjustToMinimumContentsLengthWithIcon)
            combo.setMinimumContentsLength(18)
        self.stickout = _spin(1.0, 500.0, 1, unset=True)
        self.stickout.setToolTip("Length of tool outside the holder front face")
        # A second tap of the same holder and tool at another stick-out, fitted jointly:
        # 0 shows "none" (one recording only).
        self.second_stickout = _spin(0.0, 500.0, 1)
        self.second_stickout.setSpecialValueText("none")
        self.second_stickout.setToolTip("Stick-out of a second recording of the same holder and tool "
                                        "(identified together with the first): 'none' for one recording")
        pick = QFormLayout()
        pick.addRow("Holder", self.holder_combo)
        pick.addRow("Tool", self.tool_combo)
        pick.addRow("Stick-out", self.stickout)
        pick.addRow("2nd stick-out", self.second_stickout)

        # Holder dimensions.
        self.holder_name = QLineEdit()
        self.interface = QComboBox()
        self.interface.setEditable(True)
        self.interface.addItems(INTERFACES)
        self.clamp = _spin(0.1, 500.0, 1, unset=True)
        self.segments = SegmentsTable()
        add, remove = QPushButton("Add segment"), QPushButton("Remove")
        add.clicked.connect(self.segments.add_row)
        remove.clicked.connect(self.segments.remove_row)
        holder_tab = QWidget()
        hf = QFormLayout(holder_tab)
        hf.addRow("Name", self.holder_name)
        hf.addRow("Interface", self.interface)
        hf.addRow("Clamp length", self.clamp)
        hf.addRow(QLabel("Segments from the spindle end to the front face:"))
        hf.addRow(self.segments)
        buttons = QHBoxLayout()
        buttons.addWidget(add)
        buttons.addWidget(remove)
        buttons.addStretch(1)
        hf.addRow(buttons)

        # Tool dimensions.
        self.tool_name = QLineEdit()
        self.total_length = _spin(1.0, 1000.0, 2, unset=True)
        self.shank = _spin(0.1, 200.0, 2, unset=True)
        self.flute_length = _spin(0.1, 1000.0, 2, unset=True)
        self.flute_diameter = _spin(0.1, 200.0, 2, unset=True)
        self.flute_ratio = _spin(0.05, 1.5, 2, "")
        self.flute_ratio.setValue(0.8)
        self.flute_ratio.setToolTip("The fluted part is modelled as a cylinder of ratio × flute diameter")
        self.stepped_note = QLabel()
        self.stepped_note.setWordWrap(True)
        tool_tab = QWidget()
        tf = QFormLayout(tool_tab)
        tf.addRow("Name", self.tool_name)
        tf.addRow("Total length", self.total_length)
        tf.addRow("Shank Ø", self.shank)
        tf.addRow("Flute length", self.flute_length)
        tf.addRow("Flute Ø", self.flute_diameter)
        tf.addRow("Flute ratio", self.flute_ratio)
        tf.addRow(self.stepped_note)

        self.tabs = QTabWidget()
        self.tabs.addTab(holder_tab, "Holder dimensions")
        self.tabs.addTab(tool_tab, "Tool dimensions")

        self.open_button = QPushButton("Open assembly…")
        self.save_button = QPushButton("Save assembly…")
        self.open_button.clicked.connect(self._open_dialog)
        self.save_button.clicked.connect(self._save_dialog)
        files = QHBoxLayout()
        files.addWidget(self.open_button)
        files.addWidget(self.save_button)

        self.message = QLabel()
        self.message.setWordWrap(True)
        self.message.setTextInteractionFlags(Qt.TextSelectableByMouse)

        box = QGroupBox("Assembly")
        layout = QVBoxLayout(box)
        layout.addWidget(self.drawing, 2)
        layout.addLayout(pick)
        layout.addWidget(self.tabs, 3)
        layout.addLayout(files)
        layout.addWidget(self.message)
        outer = QVBoxLayout(self)
        outer.setContentsMargins(0, 0, 0, 0)
        outer.addWidget(box)

        for widget in (self.stickout, self.clamp, self.total_length, self.shank, self.flute_length,
                       self.flute_diameter, self.flute_ratio):
            widget.valueChanged.connect(self._edited)
        self.second_stickout.valueChanged.connect(lambda v: emit(self.second_stickout_changed, float(v)))
        self.holder_name.editingFinished.connect(self._edited)
        self.tool_name.editingFinished.connect(self._edited)
        self.interface.currentTextChanged.connect(self._edited)
        self.segments.edited.connect(self._edited)
        self.holder_combo.activated.connect(self._holder_picked)
        self.tool_combo.activated.connect(self._tool_picked)
        self.reload_choices()
        self._edited()  # an empty form says what it needs

    # ------------------------------------------------------------------ choices

    @property
    def assembly(self):
        """The current valid assembly, or None."""
        return self._assembly

    def reload_choices(self, library_entries: dict | None = None) -> None:
        """Refill the holder and tool lists from ``assets/`` and the library entries given.

        Each list shows plain names (the file a name comes from is its tooltip) under a
        heading per source, so that a name is not cut off on a laptop screen.
        """
        if library_entries is not None:
            self.library_holders = {name: entry.holder for name, entry in library_entries.items()}
        folder = assets_dir()
        holders, tools = read_asset_tables(folder)
        library = [(n, h, "from the holder library") for n, h in self.library_holders.items()]
        self._holder_choices = _with_headings((("holder library", library), ("examples", _named(holders, folder))))
        self._tool_choices = _with_headings((("examples", _named(tools, folder)),))
        for combo, choices, what in ((self.holder_combo, self._holder_choices, "holder"),
                                     (self.tool_combo, self._tool_choices, "tool")):
            _fill_combo(combo, choices, f"choose a {what}…" if len(choices) > 1 else f"no {what} in assets or library")
        for combo, choices, table in ((self.holder_combo, self._holder_choices, self._holder),
                                      (self.tool_combo, self._tool_choices, self._tool)):
            if table is not None:
                self._show_current(combo, choices, table)

    def _holder_picked(self, index: int) -> None:
        table = self._holder_choices[index][1] if 0 <= index < len(self._holder_choices) else None
        if table is not None:
            self.holder_combo.setToolTip(f"{self.holder_combo.itemText(index)}: {self._holder_choices[index][2]}")
            self._holder = copy.deepcopy(table)
            self._fill_holder()
            self._edited()

    def _tool_picked(self, index: int) -> None:
        table = self._tool_choices[index][1] if 0 <= index < len(self._tool_choices) else None
        if table is not None:
            self.tool_combo.setToolTip(f"{self.tool_combo.itemText(index)}: {self._tool_choices[index][2]}")
            self._tool = copy.deepcopy(table)
            self._fill_tool()
            self._edited()

    # ------------------------------------------------------------------ loading

    def load_file(self, path) -> None:
        """Load an assembly file (raises InputError with the file's problem; nothing changes then)."""
        from taptune.io.assembly import load_assembly

        self.set_assembly(load_assembly(path))

    def set_assembly(self, assembly) -> None:
        """Show ``assembly`` in the form and make it current."""
        self._holder, self._tool = normal_tables(assembly)
        self._filling = True
        try:
            self.stickout.setValue(assembly.stickout / MM)
        finally:
            self._filling = False
        self._fill_holder()
        self._fill_tool()
        self._edited()

    def set_holder_table(self, table: dict) -> None:
        """Use the holder geometry ``table`` (mm; e.g. a library entry's) with the current tool."""
        self._holder = copy.deepcopy(table)
        self._fill_holder()
        self._edited()

    def set_stickout_mm(self, value: float) -> None:
        self.stickout.setValue(value)

    def set_second_stickout_mm(self, value: float | None) -> None:
        """The stick-out of the second recording [mm]; None or 0: no second recording."""
        self.second_stickout.setValue(value or 0.0)

    def second_assembly(self):
        """``(assembly, problem)``: the holder and tool at the 2nd stick-out, or None and why not."""
        from taptune.errors import InputError

        value = self.second_stickout.value()
        if self._assembly is None:
            return None, "describe the assembly first"
        if value <= 0.0:
            return None, "set the 2nd stick-out (left, under Stick-out)"
        if abs(value - self.stickout.value()) < 0.05:
            return None, "the 2nd stick-out must differ from the first"
        try:
            return self._assembly.with_stickout(value * MM), ""
        except InputError as err:
            return None, f"2nd stick-out {value:g} mm: {err}"

    def _fill_holder(self) -> None:
        h = self._holder
        self._filling = True
        try:
            self._show_current(self.holder_combo, self._holder_choices, h)
            self.holder_name.setText(str(h.get("name", "")))
            self.interface.setCurrentText(str(h.get("interface", "unknown")))
            self.clamp.setValue(float(h.get("clamp_length", 0.0)))
            self.segments.set_segments(list(h.get("segments", [])))
        finally:
            self._filling = False

    def _fill_tool(self) -> None:
        t = self._tool
        stepped = "segments" in t
        self._filling = True
        try:
            self._show_current(self.tool_combo, self._tool_choices, t)
            self.tool_name.setText(str(t.get("name", "")))
            self.total_length.setValue(float(t.get("total_length", 0.0)))
            for box, key, default in ((self.shank, "shank_diameter", 0.0), (self.flute_length, "flute_length", 0.0),
                                      (self.flute_diameter, "flute_diameter", 0.0), (self.flute_ratio, "flute_ratio", 0.8)):
                box.setValue(float(t.get(key, default)))
                box.setEnabled(not stepped)
            self.total_length.setEnabled(not stepped)
            self.stepped_note.setText(
                f"Stepped tool of {len(t['segments'])} segments from its file: edit the file to change them."
                if stepped else ""
            )
        finally:
            self._filling = False

    @staticmethod
    def _show_current(combo: QComboBox, choices, table: dict) -> None:
        """Select the list entry with this geometry, or name it in the first entry."""
        for i, (_, candidate, where) in enumerate(choices):
            if candidate is not None and candidate == table:
                combo.setCurrentIndex(i)
                combo.setToolTip(f"{combo.itemText(i)}: {where}")
                return
        combo.setItemText(0, f"{table.get('name', '?')} (from file or edited)")
        combo.setCurrentIndex(0)
        combo.setToolTip(combo.itemText(0))

    # ------------------------------------------------------------------ editing

    def _edited(self, *_args) -> None:
        if self._filling:
            return
        missing = self._missing()
        if missing:
            self._show(None, f"Still missing: {', '.join(missing)}. Choose or enter them above, "
                             "or open an assembly file.", hint=True)
            return
        self._holder.update(
            name=self.holder_name.text().strip(),
            interface=self.interface.currentText().strip() or "unknown",
            clamp_length=self.clamp.value(),
            segments=self.segments.segments(),
        )
        self._tool["name"] = self.tool_name.text().strip() or "tool"
        if "segments" not in self._tool:
            self._tool.update(
                total_length=self.total_length.value(),
                shank_diameter=self.shank.value(),
                flute_length=self.flute_length.value(),
                flute_diameter=self.flute_diameter.value(),
                flute_ratio=self.flute_ratio.value(),
            )
        from taptune.errors import InputError
        from taptune.io.assembly import parse_assembly

        data = {"holder": self._holder, "tool": self._tool, "setup": {"stickout": self.stickout.value()}}
        try:
            assembly = parse_assembly(data, "assembly")
        except InputError as err:
            # Keep the last valid assembly for the drawing's context; tell what is wrong.
            self._show(None, str(err))
            return
        self._show(assembly, "\n".join(assembly.warnings))

    def _missing(self) -> list[str]:
        """What the form still needs before it describes an assembly, in the order of the form."""
        missing = []
        if self._holder is None:
            missing.append("a holder")
        elif self.clamp.value() <= 0.0:
            missing.append("the holder's clamp length")
        if self._tool is None:
            missing.append("a tool")
        elif "segments" not in self._tool:
            for box, what in ((self.total_length, "total length"), (self.shank, "shank Ø"),
                              (self.flute_length, "flute length"), (self.flute_diameter, "flute Ø")):
                if box.value() <= 0.0:
                    missing.append(f"the tool's {what}")
        if self.stickout.value() <= 0.0:
            missing.append("the stick-out")
        return missing

    def _show(self, assembly, message: str, hint: bool = False) -> None:
        """Make ``assembly`` current (None: none yet); ``message`` in red, or grey for a ``hint`` of what is missing."""
        self._assembly = assembly
        self.drawing.set_assembly(assembly, "no assembly yet" if hint else message)
        self.message.setText(message)
        colour = "#555555" if hint else "#b00020" if assembly is None else "#8a6d00"
        self.message.setStyleSheet(f"color: {colour};")
        for box in (self.stickout, self.clamp):  # the fields still to fill, marked
            box.setStyleSheet("QDoubleSpinBox { background: #fff4c2; }" if box.value() <= 0.0 else "")
        emit(self.assembly_changed, assembly)

    # ------------------------------------------------------------------ files

    def assembly_toml(self) -> str | None:
        """The current assembly as assembly-file text (None while invalid)."""
        from taptune.io.assembly import assembly_to_toml

        return assembly_to_toml(self._assembly) if self._assembly is not None else None

    def _open_dialog(self) -> None:
        from taptune.errors import InputError
        from taptune.gui.messages import show_error

        path, _ = QFileDialog.getOpenFileName(self, "Open assembly", str(assets_dir()), "Assembly files (*.toml)")
        if path:
            try:
                self.load_file(path)
            except InputError as err:
                show_error(self, "Cannot open the assembly", str(err))

    def _save_dialog(self) -> None:
        from taptune.gui.messages import save_text, show_error

        text = self.assembly_toml()
        if text is None:
            show_error(self, "Nothing to save", "The assembly is not valid yet: " + self.message.text())
            return
        path, _ = QFileDialog.getSaveFileName(self, "Save assembly", "assembly.toml", "Assembly files (*.toml)")
        if path:
            save_text(self, path, text)
