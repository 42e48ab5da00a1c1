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
