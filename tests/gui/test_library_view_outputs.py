"""The library view never exports another library over the default holder library."""

from taptune.gui import messages
from taptune.gui.library_view import LibraryView
from taptune.library import HolderLibrary
from tests.library.entries import make_entry


def test_exporting_another_library_onto_the_default_one_is_refused(qtbot, tmp_path, library_path):
    HolderLibrary(library_path).put(make_entry("mine"))  # the user's library ($TAPTUNE_LIBRARY)
    before = library_path.read_bytes()
    other = tmp_path / "other.json"
    HolderLibrary(other).put(make_entry("theirs"))
    view = LibraryView(other)
    qtbot.addWidget(view)
    assert view.export_to(library_path) is None
    assert messages.history[-1][1].endswith("is the holder library; exporting there would destroy it")
    assert library_path.read_bytes() == before
    assert view.export_to(tmp_path / "copy.json") == 1  # anywhere else is fine


def test_a_holder_read_with_a_range_warning_is_marked_and_explained(qtbot, tmp_path):
    import json

    from taptune.library.schema import encode

    path = tmp_path / "holders.json"
    doc = json.loads(encode({"A": make_entry("A"), "B": make_entry("B")}, str(path)))
    doc["holders"]["B"]["holder"]["segments"][0]["length"] = 1e9  # an older taptune's µm-for-mm slip
    path.write_text(json.dumps(doc))
    view = LibraryView(path)
    qtbot.addWidget(view)
    assert [view.table.item(r, 0).text() for r in range(2)] == ["A", "⚠ B"]
    assert "implausible" in view.table.item(1, 0).toolTip()
    view.select("B")
    assert view.selected().name == "B"
    assert "⚠" in view.details.toPlainText() and "implausible" in view.details.toPlainText()
    view.resize(1000, 600)
    view.grab().save(str(tmp_path / "library_view_warning.png"))
    view.select("A")
    assert "⚠" not in view.details.toPlainText()
