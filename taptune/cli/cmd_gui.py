"""``taptune gui``: the desktop app; with ``--screenshot`` a PNG of its window (docs/cli.md)."""

from __future__ import annotations

import re
from pathlib import Path

from taptune.io.assembly import ASSEMBLY_BESIDE_RULE

VIEWS = ("record", "spectrum", "fit", "predict", "machine", "library", "check")


def _size(text: str) -> tuple[int, int]:
    import argparse

    m = re.fullmatch(r"\s*(\d{3,5})\s*[xX×]\s*(\d{3,5})\s*", text)
    if not m:
        raise argparse.ArgumentTypeError(f"expected WIDTHxHEIGHT in pixels, e.g. 1366x768, got {text!r}")
    return int(m.group(1)), int(m.group(2))


def _views(text: str) -> list[str]:
    """``--view`` as given: one view or a comma list (``fit,predict``)."""
    import argparse

    names = [n.strip() for n in text.split(",") if n.strip()]
    wrong = [n for n in names if n not in VIEWS]
    if wrong or not names:
        raise argparse.ArgumentTypeError(f"no such view {(wrong or [text])[0]!r} (views: {', '.join(VIEWS)})")
    return names


def add_parser(sub, name: str, help_text: str) -> None:
    p = sub.add_parser(name, help=help_text, description=help_text + ".")
    p.add_argument("wav", nargs="?", metavar="WAV", help="recording to open and analyse")
    p.add_argument("--assembly", metavar="FILE", help=f"assembly file (default: the one beside the WAV: {ASSEMBLY_BESIDE_RULE})")
    p.add_argument("--second", metavar="WAV",
                   help="a recording of the same holder and tool at another stick-out (its .toml beside it "
                        "gives the stick-out); both are identified together")
    p.add_argument("--library", metavar="PATH", help="holder library file")
    p.add_argument("--holder", metavar="NAME", help="open the predictor with this library holder (and the assembly's tool)")
    p.add_argument("--machine", metavar="MACHINE_TOML",
                   help="machine file for the Machine view (tool-point FRF and lobes; remembered)")
    p.add_argument("--screenshot", metavar="PNG", help="save a picture of the window to PNG and exit")
    p.add_argument("--size", type=_size, default=(1366, 768), metavar="WxH",
                   help="window size in pixels (default 1366x768)")
    p.add_argument("--view", type=_views, action="extend", metavar="VIEW",
                   help=f"with --screenshot: the tab to show ({', '.join(VIEWS)}); several (repeated, or a comma "
                        "list) give one picture each from one window, the PNG name holding {view}: "
                        "--view fit,predict --screenshot shot_{view}.png")
    p.add_argument("--identify", action="store_true", help="with --screenshot: identify the holder first")
    p.add_argument("--check", action="store_true",
                   help="with --screenshot: check WAV against --holder first (the check is saved to its history)")


def require_qt() -> None:
    """One line naming the extra to install when PySide6 is missing (it is optional)."""
    import importlib.util

    from taptune.errors import TaptuneError

    try:
        found = importlib.util.find_spec("PySide6") is not None
    except (ImportError, ValueError):
        found = False
    if not found:
        raise TaptuneError("the desktop app needs PySide6, which is not installed here: pip install 'taptune[gui]'")


def run(args) -> int:
    from taptune.cli.common import command_inputs, output_path
    from taptune.errors import InputError

    require_qt()

    output_path(args.screenshot, "screenshot", library=args.library, inputs=command_inputs(args))  # a folder or an unwritable place: now, not after the window
    for wav in (args.wav, args.second):
        if wav and not Path(wav).is_file():
            raise InputError(f"{wav}: no such file")
    if args.second and not args.wav:
        raise InputError("--second needs the first recording (WAV) too")
    if args.assembly:
        from taptune.io.assembly import load_assembly

        load_assembly(args.assembly)  # a bad file is a one-line error before any window opens
    if args.machine:
        from taptune.io.machine import load_machine

        load_machine(args.machine)
    if (args.view or args.identify or args.check) and not args.screenshot:
        raise InputError("--view, --identify and --check only apply with --screenshot")
    if args.view and len(dict.fromkeys(args.view)) > 1 and "{view}" not in args.screenshot:
        raise InputError(f"--screenshot {args.screenshot}: with several views the file name must hold {{view}} "
                         "(e.g. shot_{view}.png), one picture per view")
    if args.check and not (args.wav and args.holder):
        raise InputError("--check needs a recording (WAV) and --holder NAME")
    holder = None
    if args.holder:
        from taptune.library import HolderLibrary, default_library_path

        holder = HolderLibrary(default_library_path(args.library)).get(args.holder)  # unknown: one line, exit 2
    from taptune.gui.app import run as run_app

    views = list(dict.fromkeys(args.view or []))
    view = views if len(views) > 1 else (views[0] if views else None)
    return run_app(args.wav, args.assembly, args.library, args.screenshot, args.size, view, args.identify,
                   holder, second=args.second, machine=args.machine,
                   check=args.check)
