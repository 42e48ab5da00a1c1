"""Assembly panel (assets, edits, validation, drawing), library view (the CLI's library calls), the screenshot."""

from __future__ import annotations

import json

import pytest
from PySide6.QtCore import Qt
from PySide6.QtGui import QImage

from taptune.gui import messages


def test_pick_holder_and_tool_from_assets_and_edit(qtbot, window):
    panel = window.assembly_panel
    labels = [panel.holder_combo.itemText(i) for i in range(panel.holder_combo.count())]
    er32 = labels.index("ER32 collet chuck HSK-A63 x 100")  # the name alone, its file in the tooltip
    assert panel.holder_combo.itemData(er32, Qt.ToolTipRole) == "from assets/er32_hsk63_d16.toml"
    tools = [panel.tool_combo.itemText(i) for i in range(panel.tool_combo.count())]
    d16 = next(i for i, t in enumerate(tools) if "D16" in t)
    # Headings group the entries and cannot be picked.
    heading = labels.index("— examples —")
    assert not panel.holder_combo.model().item(heading).isEnabled()
    with qtbot.waitSignal(panel.assembly_changed):
        panel.holder_combo.setCurrentIndex(er32)
        panel.holder_combo.activated.emit(er32)
    assert panel.assembly is None and "Still missing: a tool, the stick-out." in panel.message.text()
    panel.stickout.setValue(53.5)
    panel.tool_combo.setCurrentIndex(d16)
    panel.tool_combo.activated.emit(d16)
    asm = panel.assembly
    assert asm is not None and asm.contact_length == pytest.approx(0.040)
    # An impossible edit (a bore smaller than the tool) is reported and leaves no assembly.
    panel.segments.item(2, 2).setText("12")
    assert panel.assembly is None
    assert "cannot fit" in panel.message.text()
    panel.segments.item(2, 2).setText("16")
    assert panel.assembly == asm
    panel.stickout.setValue(63.5)
    assert panel.assembly.contact_length == pytest.approx(0.030)


def test_drawing_is_to_scale(qtbot, window, reference_assembly):
    panel = window.assembly_panel
    panel.set_assembly(reference_assembly)
    drawing = panel.drawing
    drawing.resize(600, 200)
    image = drawing.grab().toImage().convertToFormat(QImage.Format_RGB32)
    # Columns that contain holder grey span the holder; the tool reaches beyond it.
    grey = (0xA9, 0xB4, 0xBF)

    def has(colour, x):
        return any(image.pixelColor(x, y).getRgb()[:3] == colour for y in range(image.height()))

    xs = [x for x in range(image.width()) if has(grey, x)]
    holder_px = xs[-1] - xs[0] + 1
    tool_dark = (0x4F, 0x5B, 0x66)
    xt = [x for x in range(image.width()) if has(tool_dark, x)]
    # Holder 100 mm, tool tip 153.5 mm from the holder's back end: the same scale.
    flute = (0x6D, 0x7A, 0x87)
    xf = [x for x in range(image.width()) if has(flute, x)]
    tip_px = xf[-1] - xs[0] + 1
    assert tip_px / holder_px == pytest.approx(153.5 / 100.0, rel=0.03)
    assert xt[0] > xs[0]  # the tool starts inside the holder


def test_library_view_import_export_remove(qtbot, window, library_path, tmp_path, reference_assembly):
    from taptune.library import HolderEntry, HolderLibrary
    from taptune.model.params import NOMINAL

    other = tmp_path / "other.json"
    HolderLibrary(other).put(HolderEntry.create(reference_assembly.holder, NOMINAL))
    view = window.library_view
    assert view.table.rowCount() == 0
    report = view.import_from(other)
    assert report.added == ("ER32 collet chuck HSK-A63 x 100",)
    assert view.table.rowCount() == 1 and "ER32" in view.details.toPlainText()
    # The holder is offered in the assembly panel too.
    panel = window.assembly_panel
    labels = [panel.holder_combo.itemText(i) for i in range(panel.holder_combo.count())]
    assert labels[1:3] == ["— holder library —", "ER32 collet chuck HSK-A63 x 100"]
    assert panel.holder_combo.itemData(2, Qt.ToolTipRole) == "from the holder library"
    out = tmp_path / "export.json"
    assert view.export_to(out) == 1
    assert json.loads(out.read_text())["holders"]
    csv = tmp_path / "export.csv"
    assert view.export_to(csv) == 1 and "k_tt" in csv.read_text()
    assert view.remove("ER32 collet chuck HSK-A63 x 100")
    assert view.table.rowCount() == 0 and HolderLibrary(library_path).names() == []
    assert [t for t, _ in messages.history] == ["Library imported", "Library exported", "Library exported"]


def test_a_broken_library_file_is_reported_and_left_alone(qtbot, library_path, fast_identify_options):
    from taptune.gui.main_window import MainWindow

    library_path.parent.mkdir(parents=True)
    library_path.write_text("{not json")
    win = MainWindow(library_path, identify_options=fast_identify_options, devices=lambda: [])
    qtbot.addWidget(win)
    assert messages.history[0][0] == "Cannot read the holder library"
    assert library_path.read_text() == "{not json"
    win.close()


def test_screenshot_shows_the_analysed_recording(qtbot, generated_recording, library_path, tmp_path):
    from taptune.cli import main

    wav = generated_recording[0]
    png = tmp_path / "shot.png"
    assert main(["gui", str(wav), "--screenshot", str(png), "--size", "1366x768",
                 "--library", str(library_path)]) == 0
    image = QImage(str(png))
    assert (image.width(), image.height()) == (1366, 768)


def test_gui_bad_input_is_one_line_exit_2(tmp_path, capsys):
    from taptune.cli import main

    assert main(["gui", str(tmp_path / "missing.wav"), "--screenshot", str(tmp_path / "x.png")]) == 2
    assert "missing.wav: no such file" in capsys.readouterr().err
    assert main(["gui", "--size", "big", "--screenshot", str(tmp_path / "x.png")]) == 2
    assert main(["gui", "--holder", "ER99", "--library", str(tmp_path / "empty.json")]) == 2
    assert "no holder 'ER99' in the library; the library is empty" in capsys.readouterr().err
    bad_machine = tmp_path / "machine.toml"
    bad_machine.write_text("[machine]\nname = 1\n")
    assert main(["gui", "--machine", str(bad_machine), "--screenshot", str(tmp_path / "x.png")]) == 2
    assert "machine.toml" in capsys.readouterr().err
    assert main(["gui", "--second", str(tmp_path / "missing2.wav")]) == 2
    assert "missing2.wav: no such file" in capsys.readouterr().err
    assert main(["gui", "--check", "--screenshot", str(tmp_path / "x.png")]) == 2
    assert "--check needs a recording (WAV) and --holder NAME" in capsys.readouterr().err
    assert main(["gui", "--screenshot", str(tmp_path)]) == 2
    assert "is a folder; give a file name for the screenshot" in capsys.readouterr().err


def test_screenshot_of_the_predictor_for_a_library_holder(tmp_path, reference_toml, reference_assembly):
    from taptune.cli import main
    from taptune.library import HolderEntry, HolderLibrary
    from taptune.model.params import NOMINAL

    library = tmp_path / "lib.json"
    HolderLibrary(library).put(HolderEntry.create(reference_assembly.holder, NOMINAL))
    png = tmp_path / "predict.png"
    assert main(["gui", "--assembly", str(reference_toml), "--holder", reference_assembly.holder.name,
                 "--library", str(library), "--view", "predict", "--screenshot", str(png), "--size", "1920x1080"]) == 0
    assert QImage(str(png)).width() == 1920


def test_an_error_escaping_a_callback_becomes_a_message(window):
    import sys

    from taptune.gui.app import install_excepthook

    previous = sys.excepthook
    install_excepthook(window)
    try:
        sys.excepthook(ValueError, ValueError("bad value"), None)
    finally:
        sys.excepthook = previous
    title, text = messages.history[-1]
    assert title == "Something went wrong" and "ValueError: bad value" in text and "unchanged" in text


def test_without_a_display_the_window_is_not_opened_invisibly(monkeypatch, capsys):
    from taptune.cli import main

    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    monkeypatch.setenv("QT_QPA_PLATFORM", "offscreen")
    assert main(["gui"]) == 1
    assert "no display" in capsys.readouterr().err


def test_holder_and_tool_names_are_not_cut_off_on_a_laptop_screen(qtbot, window):
    from PySide6.QtWidgets import QStyle, QStyleOptionComboBox

    panel = window.assembly_panel  # the window is 1366x768
    qtbot.waitExposed(window)
    for combo in (panel.holder_combo, panel.tool_combo):
        option = QStyleOptionComboBox()
        combo.initStyleOption(option)
        room = combo.style().subControlRect(QStyle.CC_ComboBox, option, QStyle.SC_ComboBoxEditField, combo).width()
        names = [combo.itemText(i) for i in range(1, combo.count())]
        widest = max(combo.fontMetrics().horizontalAdvance(n) for n in names)
        assert widest <= room, f"{max(names, key=combo.fontMetrics().horizontalAdvance)!r} needs {widest} px of {room}"
        assert combo.view().minimumWidth() >= widest  # the open list too
