"""``taptune gui --screenshot`` of several views: one window, one picture per view."""

from __future__ import annotations

from PySide6.QtGui import QImage

from taptune.cli import main


def test_several_views_give_one_picture_each(tmp_path, capsys):
    shot = str(tmp_path / "shot_{view}.png")
    assert main(["gui", "--view", "record,library", "--view", "check", "--screenshot", shot,
                 "--library", str(tmp_path / "lib.json"), "--size", "1366x768"]) == 0
    for view in ("record", "library", "check"):
        assert QImage(str(tmp_path / f"shot_{view}.png")).size().toTuple() == (1366, 768), view
    assert sorted(p.name for p in tmp_path.glob("*.png")) == ["shot_check.png", "shot_library.png", "shot_record.png"]


def test_several_views_need_a_view_in_the_file_name_and_known_names(tmp_path, capsys):
    assert main(["gui", "--view", "fit,predict", "--screenshot", str(tmp_path / "x.png")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "with several views the file name must hold {view}" in err
    assert main(["gui", "--view", "fit,plot", "--screenshot", str(tmp_path / "x_{view}.png")]) == 2
    assert "no such view 'plot' (views: record, spectrum, fit, predict, machine, library, check)" in capsys.readouterr().err
    assert main(["gui", "--view", "fit", "--view", "fit", "--screenshot", str(tmp_path / "x.png")]) == 0  # one view
    assert not list(tmp_path.glob("x_*"))
