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
