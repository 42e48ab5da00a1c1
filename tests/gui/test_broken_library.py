"""A holder library file that cannot be read is said so, never shown as empty, never written over."""

from __future__ import annotations

from taptune.gui import messages
from taptune.gui.library_view import LibraryView
from taptune.library import HolderLibrary
from tests.library.entries import make_entry


def _truncated_library(path):
    """A library with one holder, cut after 200 bytes (a copy that stopped half-way)."""
    HolderLibrary(path).put(make_entry("ER32 collet chuck"))
    path.write_bytes(path.read_bytes()[:200])
    return path.read_bytes()


def test_a_truncated_library_shows_its_read_error_not_empty(qtbot, tmp_path):
    path = tmp_path / "holders.json"
    before = _truncated_library(path)
    view = LibraryView(path)
    qtbot.addWidget(view)
    text = view.details.toPlainText()
    assert "empty" not in text
    assert str(path) in text and "not valid JSON" in text
    assert view.error is not None and str(path) in view.error
    assert view.entries == {} and view.table.rowCount() == 0
    assert not view.buttons["export"].isEnabled()
    view.resize(1000, 400)
    view.grab().save(str(tmp_path / "library_view_broken.png"))
    view.refresh()  # reading again changes nothing and writes nothing
    assert "empty" not in view.details.toPlainText()
    assert path.read_bytes() == before
    # Opening a good library clears the error.
    good = tmp_path / "good.json"
    HolderLibrary(good).put(make_entry("A"))
    view.set_library(good)
    assert view.error is None and list(view.entries) == ["A"]


def test_a_missing_library_is_empty_not_broken(qtbot, tmp_path):
    view = LibraryView(tmp_path / "none" / "holders.json")
    qtbot.addWidget(view)
    assert view.error is None
    assert "The library is empty" in view.details.toPlainText()


def test_save_into_an_unreadable_library_is_disabled_and_explained(qtbot, window, generated_recording,
                                                                   library_path):
    wav, _toml, _hz = generated_recording
    library_path.parent.mkdir(parents=True, exist_ok=True)
    before = _truncated_library(library_path)
    window.library_view.refresh()
    with qtbot.waitSignal(window.analysis_ready, timeout=30000):
        window.load_recording(str(wav))
    with qtbot.waitSignal(window.identification_ended, timeout=120000) as ended:
        window.start_identification()
    assert ended.args == ["finished"], messages.history
    assert window.identification is not None
    assert not window.save_button.isEnabled()
    tip = window.save_button.toolTip()
    assert "cannot be read" in tip and str(library_path) in tip
    assert "cannot be read" in window.statusBar().currentMessage()
    # Saving anyway (the file broke after the view last read it) fails with the reason
    # and leaves the file as it was.
    messages.history.clear()
    assert window.save_to_library() is None
    title, text = messages.history[-1]
    assert title == "Cannot save to the library" and str(library_path) in text and "not valid JSON" in text
    assert "try again" not in text
    assert library_path.read_bytes() == before
    # Repairing the file (here: removing it) and reading it again enables saving.
    library_path.unlink()
    window.library_view.refresh()
    assert window.save_button.isEnabled() and window.save_button.toolTip() == ""
    assert window.save_to_library() == "ER32 collet chuck HSK-A63 x 100"
