"""The user documentation stays true: the CLI reference matches the parsers, links stay inside the project."""

import importlib.util
import re
import sys
from pathlib import Path

import pytest

from tests.conftest import REPO

DOCS = sorted((REPO / "docs").glob("*.md"))
PAGES = [REPO / "README.md", *DOCS]
# The design notes taptune was built from; users do not have them.
DESIGN_NOTES = ("MODEL.md", "ASSEMBLY-FORMAT.md", "CLI-CONTRACT.md", "MACHINE.md", "STYLE.md", "ENV-NOTES.md")
# [text](target) and <img src="target">; a target ends at whitespace or ")".
LINK = re.compile(r"\]\(\s*<?([^)\s>]+)>?(?:\s+\"[^\"]*\")?\s*\)|src=\"([^\"]+)\"")


def _gen_cli_docs():
    spec = importlib.util.spec_from_file_location("gen_cli_docs", REPO / "scripts" / "gen_cli_docs.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_cli_reference_is_what_the_parsers_print_now():
    gen = _gen_cli_docs()
    current = gen.OUT.read_text(encoding="utf-8")
    made_with = re.search(r"generated with Python (\d+)\.(\d+)", current)
    if made_with and tuple(map(int, made_with.groups())) != sys.version_info[:2]:
        pytest.skip(f"docs/cli.md was generated with Python {made_with.group(1)}.{made_with.group(2)}; "
                    "argparse lays help out differently here")
    assert current == gen.render(), "docs/cli.md is out of date: run python scripts/gen_cli_docs.py"


def test_cli_reference_has_every_command():
    text = (REPO / "docs" / "cli.md").read_text(encoding="utf-8")
    from taptune.cli import COMMANDS

    for name in COMMANDS:
        assert f"\n## taptune {name}\n" in text


def links(page: Path):
    for match in LINK.finditer(page.read_text(encoding="utf-8")):
        yield match.group(1) or match.group(2)


@pytest.mark.parametrize("page", PAGES, ids=lambda p: p.name)
def test_pages_refer_to_nothing_outside_the_project(page):
    text = page.read_text(encoding="utf-8")
    assert "../shared" not in text and "shared/design" not in text, f"{page.name} points to the design folder"
    assert "/work/" not in text, f"{page.name} names a path on the development machine"
    named = [note for note in DESIGN_NOTES if note in text]
    assert not named, f"{page.name} refers to design notes users do not have: {', '.join(named)}"
    for target in links(page):
        if re.match(r"[a-z]+:", target):
            continue  # a web address or mailto:
        if target.startswith("#"):
            assert target[1:] in anchors(page), f"{page.name}: link {target}: no such heading"
            continue
        file, _, anchor = target.partition("#")
        path = (page.parent / file).resolve()
        assert path.is_relative_to(REPO.resolve()), f"{page.name}: link {target} leaves the project"
        assert path.exists(), f"{page.name}: link {target} points to a file that does not exist"
        if anchor and path.suffix == ".md":
            assert anchor in anchors(path), f"{page.name}: link {target}: no such heading in {path.name}"


def anchors(page: Path) -> set[str]:
    """The anchors GitHub gives the headings of a Markdown page."""
    text = re.sub(r"```.*?```", "", page.read_text(encoding="utf-8"), flags=re.S)
    titles = re.findall(r"^#+\s+(.*?)\s*$", text, flags=re.M)
    return {"".join(c for c in t.lower().replace(" ", "-") if c.isalnum() or c in "-_") for t in titles}


def test_the_link_checker_reads_both_link_forms(tmp_path):
    page = tmp_path / "p.md"
    page.write_text('see [format](docs/a.md#keys) and <img src="figures/x.png"> and [w](https://example.org)\n')
    assert list(links(page)) == ["docs/a.md#keys", "figures/x.png", "https://example.org"]


def test_docs_has_the_user_pages():
    names = {p.name for p in DOCS}
    assert {"assembly-format.md", "library.md", "tap-test.md", "physics.md", "cli.md", "ARCHITECTURE.md"} <= names


def test_every_toml_example_in_the_assembly_page_is_a_valid_assembly():
    from taptune.io.assembly import assembly_from_toml

    text = (REPO / "docs" / "assembly-format.md").read_text(encoding="utf-8")
    blocks = re.findall(r"```toml\n(.*?)```", text, flags=re.S)  # "```toml fragment" blocks are parts
    assert len(blocks) >= 5
    for k, block in enumerate(blocks, 1):
        assembly = assembly_from_toml(block, f"assembly-format.md, example {k}")
        assert assembly.stickout > 0


def test_the_assets_examples_in_the_assembly_page_are_the_files():
    from taptune.io.assembly import assembly_from_toml, load_assembly

    text = (REPO / "docs" / "assembly-format.md").read_text(encoding="utf-8")
    for section in re.split(r"\n### ", text)[1:]:
        files = re.findall(r"`(assets/[\w.]+\.toml)`", section.splitlines()[0])
        blocks = re.findall(r"```toml\n(.*?)```", section, flags=re.S)
        if files and blocks:
            shown = assembly_from_toml(blocks[-1], "example")
            geometry = (shown.holder, shown.tool, shown.stickout)
            assert any((a.holder, a.tool, a.stickout) == geometry for a in map(load_assembly, [REPO / f for f in files])), (
                f"{files}: the page shows another geometry")


# --------------------------------------------------------------------------- the documented commands

# Options and positionals that name a file or folder taptune reads, and those it writes.
READS = {"wav", "assembly", "params", "machine", "frf", "dummy", "aa", "ab", "bb", "paths", "interface_tap",
         "bands", "recordings", "file", "second"}
WRITES = {"out", "json", "plot", "csv", "uff", "report", "screenshot", "dir", "library"}
# Files a page's commands read that the user makes first; the page's prose must say so
# (name each one outside its code blocks).
USER_FILES = {
    "tap-test.md": {"tap.wav", "my.toml", "other-tool.toml"},
    "library.md": {"colleague.json", "team.json"},
    "cut.md": {"cut.m4a"},
    "machine.md": {"dummy.toml", "G_aa.csv", "G_ab.csv", "G_bb.csv", "tool_tip.csv", "X.frf", "Y.frf"},
}
# Cheap enough to run for real (a second or less each, no library holder needed).
RUN = {"model", "toolpoint", "lobes", "spectrum", "examples"}
FENCE = re.compile(r"^```[^\n]*\n(.*?)^```", flags=re.S | re.M)


def documented_commands(page: Path) -> list[list[str]]:
    """The ``taptune …`` command lines of the page's code blocks, as argument lists
    (continuation lines joined, comments dropped); output lines such as
    ``taptune model: my.toml: …`` are not commands."""
    import shlex

    from taptune.cli import COMMANDS

    commands = []
    for block in FENCE.findall(page.read_text(encoding="utf-8")):
        for line in block.replace("\\\n", " ").splitlines():
            words = shlex.split(line.strip().removeprefix("$ "), comments=True) if line.strip().startswith(("taptune ", "$ taptune ")) else []
            if len(words) > 1 and words[1] in COMMANDS:
                commands.append(words[1:])
    return commands


def _parse(argv: list[str]):
    import contextlib
    import io

    from taptune.cli import _build_parser

    err = io.StringIO()
    with contextlib.redirect_stderr(err):
        try:
            return _build_parser(argv[0]).parse_args(argv)
        except SystemExit:
            raise AssertionError(f"taptune {' '.join(argv)}: {err.getvalue().strip()}") from None


def _values(args, dests) -> list[str]:
    out = []
    for dest in dests:
        value = getattr(args, dest, None)
        out += [value] if isinstance(value, str) else [v for v in value or [] if isinstance(v, str)]
    return out


DOC_COMMANDS = [(page, argv) for page in PAGES if page.name != "cli.md" for argv in documented_commands(page)]


def test_the_documented_commands_are_found():
    pages = {page.name for page, _ in DOC_COMMANDS}
    assert {"README.md", "tap-test.md", "library.md", "machine.md"} <= pages
    assert len(DOC_COMMANDS) >= 15
    assert ["model", "my.toml:"] not in [argv[:2] for _, argv in DOC_COMMANDS]  # an error message, not a command


@pytest.mark.parametrize("page", sorted({p for p, _ in DOC_COMMANDS}), ids=lambda p: p.name)
def test_every_documented_command_parses_and_names_files_that_exist(page):
    """Run from the clone (or from the folder 'taptune examples' fills), a command reads
    only files that ship, files an earlier command of the page wrote, or files the page
    tells the user to make."""
    text_outside_code = FENCE.sub("", page.read_text(encoding="utf-8"))
    mine = USER_FILES.get(page.name, set())
    written = set()
    for argv in (a for p, a in DOC_COMMANDS if p == page):
        args = _parse(argv)
        for path in _values(args, READS):
            if path in mine:
                assert f"`{path}`" in text_outside_code, f"{page.name}: say in the text what {path} is"
                continue
            assert (REPO / path).exists() or path in written, (
                f"{page.name}: taptune {' '.join(argv)}: {path} does not ship and nothing before makes it")
        written |= set(_values(args, WRITES))


def _runnable():
    """(page, argv) of the cheap commands whose inputs ship, each command once."""
    seen = {}
    for page, argv in DOC_COMMANDS:
        if argv[0] in RUN and all((REPO / f).exists() for f in _values(_parse(argv), READS)):
            seen.setdefault(tuple(argv), page)
    return [(page, list(argv)) for argv, page in seen.items()]


@pytest.mark.parametrize("page, argv", _runnable(), ids=lambda v: v.name if isinstance(v, Path) else " ".join(v[:2]))
def test_the_cheap_documented_commands_run_as_written(page, argv, tmp_path, monkeypatch, capsys):
    from taptune.cli import main

    for name in ("assets", "recordings"):  # the clone's folders, the outputs in a temporary one
        (tmp_path / name).symlink_to(REPO / name)
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("TAPTUNE_LIBRARY", str(tmp_path / "holders.json"))
    code = main(argv)
    assert code == 0, f"{page.name}: taptune {' '.join(argv)}: {capsys.readouterr().err}"
