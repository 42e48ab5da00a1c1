"""The example data that ships with taptune: assembly files, tap recordings, a machine.

In a clone of the repository these are its ``assets/`` and ``recordings/`` folders (this
package links to them); in an installed wheel they are package data here. Both are read
through :mod:`importlib.resources`, so the demo and the app find them either way, and
``taptune examples DIR`` copies them out for the user to edit and run.
"""

from __future__ import annotations

import shutil
from importlib.resources import files
from pathlib import Path


def _folder(name: str) -> Path:
    """A folder of this package's data, as a real directory."""
    root = files(__name__)
    if not isinstance(root, Path):  # a zip import has no folders to hand to numpy or soundfile
        from taptune.errors import TaptuneError

        raise TaptuneError(f"taptune's example {name} are inside an archive ({root}): install taptune unzipped")
    return root / name


def recordings_dir() -> Path:
    """The example tap recordings, their assembly and truth files, ``demo.json`` and ``machine/``."""
    return _folder("recordings")


def assets_dir() -> Path:
    """The example assembly files (holders on HSK-A63 with their tools)."""
    return _folder("assets")


def machine_file() -> Path:
    """The example machine file (a synthetic HSK-A63 spindle)."""
    return recordings_dir() / "machine" / "machine.toml"


def example_files() -> list[tuple[Path, Path]]:
    """(source, path relative to the destination) of every example file, in a stable order."""
    out = []
    for name, folder in (("assets", assets_dir()), ("recordings", recordings_dir())):
        for path in sorted(folder.rglob("*")):
            if path.is_file() and "__pycache__" not in path.parts:
                out.append((path, Path(name) / path.relative_to(folder)))
    return out


def copy_examples(dest: Path) -> list[Path]:
    """Copy every example file into ``dest/assets`` and ``dest/recordings``; return the new files.

    Nothing is overwritten: when any of the files is already there, nothing is copied and
    an InputError names it.
    """
    from taptune.errors import InputError

    dest = Path(dest)
    if dest.exists() and not dest.is_dir():
        raise InputError(f"{dest}: not a folder")
    pairs = [(src, dest / rel) for src, rel in example_files()]
    for _, target in pairs:
        if target.exists() or target.is_symlink():
            raise InputError(f"{target}: already there (nothing copied; give an empty or new folder)")
    written = []
    for src, target in pairs:
        target.parent.mkdir(parents=True, exist_ok=True)
        shutil.copyfile(src, target)
        written.append(target)
    return written
