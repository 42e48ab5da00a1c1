"""gui/messages.save_text: an atomic write, and a failure that ends in a dialog, not a traceback."""

from __future__ import annotations


def test_save_text_replaces_the_file_whole(qtbot, tmp_path):
    from taptune.gui import messages

    path = tmp_path / "assembly.toml"
    path.write_text("old\n")
    assert messages.save_text(None, path, "new ✓\n")
    assert path.read_text(encoding="utf-8") == "new ✓\n"
    assert [p.name for p in tmp_path.iterdir()] == ["assembly.toml"]  # no temporary left


def test_save_text_failure_is_a_dialog_and_keeps_the_old_file(qtbot, tmp_path):
    from taptune.gui import messages

    folder = tmp_path / "taken"
    folder.mkdir()  # a folder where the file should go: the rename must fail
    before = len(messages.history)
    assert not messages.save_text(None, folder, "text")
    assert folder.is_dir()
    assert messages.history[before][0] == "Cannot save"
    assert str(folder) in messages.history[before][1]
    assert [p.name for p in tmp_path.iterdir()] == ["taken"]
