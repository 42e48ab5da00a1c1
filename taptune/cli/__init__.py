"""Command-line front end: argument parsing, one module per command, exit codes.

No physics here. Each command lives in ``taptune/cli/cmd_<name>.py`` and exposes
``add_parser(subparsers)`` and ``run(args) -> int``; this module imports a command's
module only when that command runs, so ``taptune --help`` stays fast (no numpy-heavy,
Qt, matplotlib or sounddevice import on that path).
"""

from __future__ import annotations

import argparse
import importlib
import os
import sys

# name -> one-line help. Order is the order shown in --help.
COMMANDS = {
    "demo": "run the main job on the bundled example recording",
    "spectrum": "find taps, compute the spectrum, pick and label peaks",
    "model": "free-free model of an assembly (bending frequencies, damping)",
    "identify": "identify a holder from a tap recording and store it in the library",
    "predict": "predict a library holder with a tool at other stick-outs",
    "toolpoint": "tool-point FRF of a holder and tool on a machine (spindle receptance coupling)",
    "lobes": "milling stability lobes from the tool-point FRF (zero-order approximation)",
    "spindle": "spindle receptance from hammer tests on a dummy holder (inverse receptance coupling)",
    "check": "check a library holder with one tap: consistent, differs (worn, badly seated) or inconclusive",
    "batch": "identify every recording under folders, in parallel",
    "library": "list, show, export, import or remove holders; export receptances (UFF58, CSV)",
    "record": "record taps from the microphone into a WAV file",
    "gui": "the desktop app",
}


def _build_parser(command: str | None) -> argparse.ArgumentParser:
    from taptune import __version__

    parser = argparse.ArgumentParser(
        prog="taptune",
        description="Tool-holder dynamics from the sound of a tap.",
    )
    parser.add_argument("--version", action="version", version=f"taptune {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    for name, help_text in COMMANDS.items():
        if name == command:
            module = importlib.import_module(f"taptune.cli.cmd_{name}")
            module.add_parser(sub, name, help_text)
        else:
            sub.add_parser(name, help=help_text, add_help=False)
    return parser


def main(argv: list[str] | None = None) -> int:
    """Run the CLI; return the exit status (0 ok, 2 bad input, 1 anything else)."""
    argv = list(sys.argv[1:] if argv is None else argv)
    os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
    os.environ.setdefault("OMP_NUM_THREADS", "1")
    command = next((a for a in argv if not a.startswith("-")), None)
    if command not in COMMANDS:
        command = None
    try:
        parser = _build_parser(command)
    except ImportError as err:
        # A command whose optional dependency is missing (e.g. PySide6 for gui) must say so.
        print(f"taptune {command}: not available here ({err})", file=sys.stderr)
        return 1
    try:
        args = parser.parse_args(argv)
    except SystemExit as exc:  # argparse: usage errors exit 2, --help exits 0
        return int(exc.code or 0)
    if args.command is None:
        parser.print_help()
        return 2

    from taptune.errors import InputError, TaptuneError

    try:
        module = importlib.import_module(f"taptune.cli.cmd_{args.command}")
        return int(module.run(args) or 0)
    except InputError as err:
        print(f"taptune {args.command}: {err}", file=sys.stderr)
        return 2
    except TaptuneError as err:
        print(f"taptune {args.command}: {err}", file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        print(f"taptune {args.command}: interrupted", file=sys.stderr)
        return 130
