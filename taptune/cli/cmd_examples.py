"""``taptune examples DIR``: copy the example assemblies, recordings and machine out.

The files ship inside the package (:mod:`taptune.examples`); copied out they keep the
repository's layout (``assets/``, ``recordings/``, ``recordings/machine/``), so the
commands of the documentation run as written from inside ``DIR``.
"""

from __future__ import annotations

# What to run first in the copied folder, in this order: identify the tapped holder (it goes
# into the library), then predict it with the same tool at two other stick-outs (an assembly
# of another holder would only borrow this holder's contact, with a warning).
TRY = (
    "taptune identify recordings/er32_d16_tap.wav --assembly recordings/er32_d16.toml",
    'taptune predict assets/er32_hsk63_d16.toml --holder "ER32 collet chuck HSK-A63 x 100" --stickout 60 70',
)


def add_parser(sub, name: str, help_text: str) -> None:
    p = sub.add_parser(name, help=help_text, description=(
        "Copy the example files that ship with taptune into DIR: assets/ (assembly files of four "
        "holders on HSK-A63 with their tools), recordings/ (three synthetic tap recordings with their "
        "assembly and truth files) and recordings/machine/ (a synthetic machine with its spindle "
        "receptance). Nothing is overwritten. Then 'cd DIR' and the commands of the documentation run "
        "as written."))
    p.add_argument("dir", metavar="DIR", help="folder to copy into (made if missing; must not hold these files yet)")


def run(args) -> int:
    from pathlib import Path

    from taptune.examples import copy_examples

    dest = Path(args.dir)
    written = copy_examples(dest)
    groups = {}
    for path in written:
        groups.setdefault(path.relative_to(dest).parent, []).append(path.name)
    for folder, names in groups.items():
        print(f"{dest / folder}/: {', '.join(names)}")
    print(f"\n{len(written)} files copied. Try, from {dest}:")
    for command in TRY:
        print("  " + command)
    return 0
