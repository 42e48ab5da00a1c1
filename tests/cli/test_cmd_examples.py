"""The example data that ships with taptune: found through the package, copied out whole.

And what a user without an optional extra sees: one line naming it, no traceback.
"""

from __future__ import annotations

import filecmp
import sys

import pytest

from taptune.cli import main
from taptune.examples import assets_dir, copy_examples, example_files, machine_file, recordings_dir
from tests.conftest import REPO


def test_the_package_data_is_the_clones_assets_and_recordings():
    # The package links to the folders the documentation names: one copy of each file.
    assert recordings_dir().resolve() == (REPO / "recordings").resolve()
    assert assets_dir().resolve() == (REPO / "assets").resolve()
    assert machine_file().is_file() and (recordings_dir() / "demo.json").is_file()
    names = {rel.as_posix() for _, rel in example_files()}
    tracked = {p.relative_to(REPO).as_posix() for d in ("assets", "recordings") for p in (REPO / d).rglob("*") if p.is_file()}
    assert names == tracked


def test_examples_copies_every_file_and_refuses_to_overwrite(tmp_path, capsys):
    code = main(["examples", str(tmp_path / "ex")])
    out, err = capsys.readouterr()
    assert code == 0, err
    for src, rel in example_files():
        assert filecmp.cmp(src, tmp_path / "ex" / rel, shallow=False), rel
    assert (tmp_path / "ex" / "recordings" / "machine" / "machine.toml").is_file()
    assert "taptune identify recordings/er32_d16_tap.wav --assembly recordings/er32_d16.toml" in out
    mine = tmp_path / "ex" / "assets" / "er32_hsk63_d16.toml"
    mine.write_text("# my own edits\n")
    code = main(["examples", str(tmp_path / "ex")])
    _, err = capsys.readouterr()
    assert code == 2 and err.count("\n") == 1 and "er32_hsk63_d16.toml: already there" in err
    assert mine.read_text() == "# my own edits\n"


def test_copy_examples_into_a_file_is_one_error(tmp_path):
    from taptune.errors import InputError

    (tmp_path / "f").write_text("x")
    with pytest.raises(InputError, match="not a folder"):
        copy_examples(tmp_path / "f")


def test_demo_help_names_no_folder_an_installed_taptune_lacks(capsys):
    assert main(["demo", "--help"]) == 0
    out = capsys.readouterr().out
    assert "bundled recordings/" not in out and "taptune examples" in " ".join(out.split())


def test_gui_without_pyside6_names_the_extra_in_one_line(monkeypatch, capsys):
    monkeypatch.setitem(sys.modules, "PySide6", None)  # an import of it now fails
    code = main(["gui"])
    err = capsys.readouterr().err
    assert code == 1 and err.count("\n") == 1
    assert "pip install 'taptune[gui]'" in err


def _suggested(out: str) -> list[list[str]]:
    """The commands 'taptune examples' suggests, as argument lists, in its order."""
    import shlex

    tail = out.split("Try, from", 1)[1].splitlines()[1:]
    return [shlex.split(line)[1:] for line in tail if line.strip().startswith("taptune ")]


def test_the_suggested_commands_name_one_holder_and_files_that_are_copied(tmp_path, capsys):
    # Cheap: what each suggested command reads is in the folder, and predict asks for the
    # holder identify stores, with an assembly of that same holder (no borrowed contact).
    from taptune.cli import _build_parser
    from taptune.io.assembly import load_assembly

    assert main(["examples", str(tmp_path)]) == 0
    commands = _suggested(capsys.readouterr().out)
    assert [c[0] for c in commands] == ["identify", "predict"]
    identify, predict = (_build_parser(c[0]).parse_args(c) for c in commands)
    tapped = load_assembly(tmp_path / identify.assembly[0])
    assert (tmp_path / identify.wav[0]).is_file()
    assert load_assembly(tmp_path / predict.assembly).holder == tapped.holder
    assert predict.holder == tapped.holder.name


@pytest.mark.slow
def test_the_suggested_commands_run_in_order_in_the_copied_folder(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("TAPTUNE_LIBRARY", str(tmp_path / "holders.json"))
    monkeypatch.setenv("TAPTUNE_CACHE_DIR", "off")
    assert main(["examples", "ex"]) == 0
    commands = _suggested(capsys.readouterr().out)
    monkeypatch.chdir(tmp_path / "ex")
    for argv in commands:
        code = main(argv)
        err = capsys.readouterr().err
        assert code == 0, f"taptune {' '.join(argv)}: {err}"
        assert "its holder is" not in err, err  # no holder borrowed from another assembly
