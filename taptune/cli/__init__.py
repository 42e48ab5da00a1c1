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
    "check": "check a library holder with one tap: consistent, differs (worn, badly seated) or inconclusive",
    "toolpoint": "tool-point FRF of a holder and tool on a machine (spindle receptance coupling)",
    "lobes": "milling stability lobes from the tool-point FRF (zero-order approximation)",
    "cut": "listen to a milling cut: stable or chatter, and the next speed to try",
    "spindle": "spindle receptance from hammer tests on a dummy holder (inverse receptance coupling)",
    "batch": "identify every recording under folders, in parallel",
    "library": "list, show, export, import or remove holders; export receptances (UFF58, CSV)",
    "record": "record taps from the microphone into a WAV file",
    "gui": "the desktop app",
    "examples": "copy the example assemblies, recordings and machine into a folder",
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


#: Commands whose process ends without the interpreter's teardown (see :func:`_end_process`):
#: after ``predict`` it took 0.2 s of a 1 s command.
FAST_EXIT = frozenset({"identify", "predict"})


def main(argv: list[str] | None = None) -> int:
    """Run the CLI; return the exit status (0 ok, 2 bad input, 1 anything else)."""
    return _main(argv)


def entry() -> None:
    """The process entry (the ``taptune`` script, ``python -m taptune``): run the CLI on
    ``sys.argv`` and exit with its status; a command of :data:`FAST_EXIT` ends the process
    without the interpreter's teardown (:func:`_end_process`); numpy's :data:`UNUSED_MODULES`
    load on first use only (:class:`_OnFirstUse`). In-process callers use :func:`main`,
    which always returns and leaves the imports as they are."""
    if not any(isinstance(f, _OnFirstUse) for f in sys.meta_path):
        sys.meta_path.insert(0, _OnFirstUse())
    try:
        status = _main(None)
        if _command(sys.argv[1:]) in FAST_EXIT:
            _end_process(status)
        sys.stdout.flush()
    except BrokenPipeError:
        # The reader closed the pipe (taptune spectrum x.wav | head -1): stop quietly, with
        # stdout pointed at nothing so that the exit's own flush cannot fail again.
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        raise SystemExit(1) from None
    raise SystemExit(status)


#: numpy submodules taptune's computations never use that scipy's import loads all the same:
#: its vendored array-API layer (scipy._lib.array_api_compat) looks up every public name of
#: numpy, and a look-up of a lazily loaded submodule imports it. f2py's Fortran parser, the
#: testing tools and the masked arrays (which only matplotlib uses) are ≈ 0.09 s CPU of
#: every command that imports scipy.
UNUSED_MODULES = frozenset({"numpy.f2py", "numpy.testing", "numpy.ma"})


class _OnFirstUse:
    """Import finder that gives :data:`UNUSED_MODULES` a lazy loader
    (:class:`importlib.util.LazyLoader`, pure-Python packages): the module object exists at
    once, its code runs at the first access to one of its attributes."""

    def find_spec(self, name, path=None, target=None):
        if name not in UNUSED_MODULES:
            return None
        import importlib.machinery
        import importlib.util

        spec = importlib.machinery.PathFinder.find_spec(name, path, target)
        if spec is None or spec.loader is None or not hasattr(spec.loader, "exec_module"):
            return spec
        spec.loader = importlib.util.LazyLoader(spec.loader)
        return spec


def _end_process(status: int) -> None:
    """End the process with ``status`` now, skipping the interpreter's teardown.

    Tearing down numpy, scipy and the built models takes 0.1–0.2 s after ``identify`` has
    said everything. The atexit handlers (multiprocessing's clean-up, coverage, logging)
    still run and stdout and stderr are flushed first. Returns without ending anything
    when that is not safe: another thread still runs, a profiler or tracer is attached
    (it writes its results after the entry returns), or flushing fails (the normal exit
    then reports it).
    """
    import atexit
    import threading

    # Python ≥ 3.12's cProfile and coverage use sys.monitoring, not setprofile/settrace.
    monitoring = getattr(sys, "monitoring", None)
    watched = monitoring is not None and any(monitoring.get_tool(i) for i in range(6))
    if threading.active_count() > 1 or sys.getprofile() is not None or sys.gettrace() is not None or watched:
        return
    try:
        sys.stdout.flush()
        sys.stderr.flush()
    except (OSError, ValueError):
        return
    atexit._run_exitfuncs()
    try:
        sys.stdout.flush()
        sys.stderr.flush()
    finally:
        os._exit(status)


def _command(argv) -> str | None:
    """The command ``argv`` names (its first word not an option), None if none is known."""
    command = next((a for a in argv if not a.startswith("-")), None)
    return command if command in COMMANDS else None


def _main(argv: list[str] | None) -> int:
    """Parse ``argv`` (default ``sys.argv[1:]``), run the command, return its exit status."""
    argv = list(sys.argv[1:] if argv is None else argv)
    os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
    os.environ.setdefault("OMP_NUM_THREADS", "1")
    command = _command(argv)
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

    from taptune.errors import InputError, InterruptedAfterWrite, TaptuneError

    try:
        module = importlib.import_module(f"taptune.cli.cmd_{args.command}")
        return int(module.run(args) or 0)
    except InputError as err:
        print(f"taptune {args.command}: {err}", file=sys.stderr)
        return 2
    except TaptuneError as err:
        print(f"taptune {args.command}: {err}", file=sys.stderr)
        return 1
    except InterruptedAfterWrite as err:
        print(f"taptune {args.command}: interrupted after {err.path} was written (that change is saved)",
              file=sys.stderr)
        return 130
    except KeyboardInterrupt:
        print(f"taptune {args.command}: interrupted", file=sys.stderr)
        return 130
