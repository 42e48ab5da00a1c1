"""The Check button: a new tap of a library holder → verdict, per-mode table, history in the library.

Holder A (CIRP J. Manuf. Sci. Technol. 37 (2022)) is put in the library with its published parameters; the taps
are generated from the model: the same holder at another stick-out, and the same holder
with both contact stiffnesses at 40 % (a worn, badly seated collet).
"""

from __future__ import annotations

import pytest

from taptune.gui import messages


@pytest.fixture
def holder_a(library_path, reference_assembly):
    from taptune.library import HolderEntry, HolderLibrary
    from taptune.model.params import HolderParams

    from tests.gui.conftest import HOLDER_A

    from tests.library.entries import make_record

    # Identified at the reference stick-out, as a library holder is: its bands know Δ.
    identified = make_record(stickout_mm=reference_assembly.stickout * 1e3)
    HolderLibrary(library_path).put(HolderEntry.create(reference_assembly.holder, HolderParams(**HOLDER_A),
                                                       identifications=(identified,)))
    return reference_assembly.holder.name


def _check(qtbot, window, wav):
    with qtbot.waitSignal(window.analysis_ready, timeout=30000):
        window.load_recording(str(wav))
    assert window.check_button.isEnabled(), window.check_button.toolTip()
    with qtbot.waitSignal(window.check_ended, timeout=60000) as blocker:
        window.check_button.click()
    assert blocker.args[0] is not None, messages.history
    return blocker.args[0]


def test_check_shows_the_verdict_and_the_history_grows(qtbot, window, holder_a, library_path, tmp_path):
    from taptune.library import HolderLibrary

    from tests.gui.conftest import write_recording

    window.library_view.refresh()
    window.library_view.select(holder_a)
    assert not window.check_button.isEnabled()  # no tap yet

    # The same holder at another stick-out than any identification: consistent.
    same, _toml, _hz = write_recording(tmp_path, 63.5, seed=3)
    check = _check(qtbot, window, same)
    assert check.verdict == "consistent"
    view = window.check_view
    assert window.tabs.currentWidget() is view
    assert "CONSISTENT" in view.verdict.text() and "#1e7b34" in view.verdict.styleSheet()
    assert view.table.rowCount() == 3 and view.table.item(0, 4).text() == "inside"
    assert view.table.item(0, 1).text() == f"{check.result.modes[0].measured_hz:,.1f}"
    assert [c.verdict for c in HolderLibrary(library_path).get(holder_a).checks] == ["consistent"]

    # The collet worn: both contact stiffnesses at 40 % → differs, in red; the history has both.
    worn_dir = tmp_path / "worn"
    worn_dir.mkdir()
    worn, _toml, _hz = write_recording(worn_dir, 53.5, seed=4, contact_factor=0.4)
    check = _check(qtbot, window, worn)
    assert check.verdict == "differs"
    assert "DIFFERS" in view.verdict.text() and "#b00020" in view.verdict.styleSheet()
    assert "outside" in [view.table.item(r, 4).text() for r in range(view.table.rowCount())]
    assert [c.verdict for c in HolderLibrary(library_path).get(holder_a).checks] == ["consistent", "differs"]
    # The library view lists the checks, newest first, and the last verdict in the table.
    details = window.library_view.details.toPlainText()
    assert details.index("differs") < details.index("consistent")
    assert window.library_view.table.item(0, 4).text() == "differs"
    assert messages.history == []


def test_check_with_a_broken_library_changes_nothing(qtbot, window, holder_a, library_path, generated_recording):
    window.library_view.refresh()
    window.library_view.select(holder_a)
    before = library_path.read_bytes()
    with qtbot.waitSignal(window.analysis_ready, timeout=30000):
        window.load_recording(str(generated_recording[0]))
    library_path.write_text("{ not json")  # another program broke the file meanwhile
    with qtbot.waitSignal(window.check_ended, timeout=60000) as blocker:
        window.check_button.click()
    assert blocker.args[0] is None
    assert messages.history[-1][0] == "Check failed"
    assert library_path.read_text() == "{ not json"  # reported, never overwritten
    assert before  # the library had the holder before
    assert window.check_button.isEnabled()
