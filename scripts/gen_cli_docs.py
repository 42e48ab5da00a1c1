"""Write docs/cli.md, the command-line reference, from the argument parsers themselves.

Every command of ``taptune.cli.COMMANDS`` and every sub-command below it gets its usage
and options exactly as ``--help`` prints them (at a fixed width of 100 columns, so the
file does not depend on the terminal). ``tests/test_docs.py`` fails when docs/cli.md
differs from what this script writes now.

Run: ``python scripts/gen_cli_docs.py`` (or ``--check``: exit 1 if docs/cli.md is stale).
"""

from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from taptune.cli import COMMANDS, _build_parser  # noqa: E402

OUT = REPO / "docs" / "cli.md"
WIDTH = 100

HEADER = f"""# Command-line reference

<!-- generated with Python {sys.version_info.major}.{sys.version_info.minor}: argparse's layout differs a little between versions -->

Generated from the argument parsers by `scripts/gen_cli_docs.py`; do not edit by hand.
Every command prints the same text with `--help`.

Exit status of every command: 0 success, 2 bad input (one line naming the file and the
problem, never a traceback), 1 anything else, 130 interrupted (Ctrl-C).
"""


def _subcommands(parser: argparse.ArgumentParser) -> list[tuple[str, str, argparse.ArgumentParser]]:
    """(name, one-line help, parser) of each sub-command of ``parser``, in the order defined."""
    out = []
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            helps = {a.dest: a.help or "" for a in action._choices_actions}
            out += [(name, helps.get(name, ""), sub) for name, sub in action.choices.items()]
    return out


def _anchor(title: str) -> str:
    """The anchor GitHub gives a heading (lower case, spaces to dashes, punctuation dropped)."""
    return "".join(c for c in title.lower().replace(" ", "-") if c.isalnum() or c in "-_")


def _section(level: int, title: str, parser: argparse.ArgumentParser) -> list[str]:
    text = parser.format_help().rstrip()
    out = [f"{'#' * level} {title}", "", "```text", text, "```", ""]
    for name, _, sub in _subcommands(parser):
        out += _section(level + 1, f"{title} {name}", sub)
    return out


def render() -> str:
    """The text of docs/cli.md for the commands as they are now."""
    old = os.environ.get("COLUMNS")
    os.environ["COLUMNS"] = str(WIDTH + 2)  # argparse wraps at COLUMNS - 2
    try:
        root = _build_parser(None)
        lines = [HEADER, "## Commands", ""]
        lines += [f"- [`taptune {name}`](#{_anchor('taptune ' + name)}) — {text}" for name, text in COMMANDS.items()]
        lines += ["", "## taptune", "", "```text", root.format_help().rstrip(), "```", ""]
        for name in COMMANDS:
            parser = dict((n, p) for n, _, p in _subcommands(_build_parser(name)))[name]
            lines += _section(2, f"taptune {name}", parser)
    finally:
        if old is None:
            del os.environ["COLUMNS"]
        else:
            os.environ["COLUMNS"] = old
    return "\n".join(lines).rstrip() + "\n"


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description="Write docs/cli.md from the taptune argument parsers.")
    ap.add_argument("--check", action="store_true", help="do not write; exit 1 if docs/cli.md is not up to date")
    args = ap.parse_args(argv)
    text = render()
    if args.check:
        current = OUT.read_text(encoding="utf-8") if OUT.exists() else ""
        if current != text:
            print(f"{OUT.relative_to(REPO)} is out of date: run python scripts/gen_cli_docs.py", file=sys.stderr)
            return 1
        return 0
    OUT.write_text(text, encoding="utf-8")
    print(f"wrote {OUT.relative_to(REPO)} ({len(COMMANDS)} commands)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
