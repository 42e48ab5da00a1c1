"""``taptune batch PATH... [--assembly FILE] [--jobs N] [--out DIR] [--library PATH] [--force] [--joint] [--report PDF] [--seed N] [--no-save] [--timeout S] [--machine MACHINE.toml --teeth N ...]``."""

from __future__ import annotations

import argparse
import sys

from taptune.cli.cmd_toolpoint import add_model_args
from taptune.cli.cut import add_cut_args
from taptune.io.assembly import ASSEMBLY_BESIDE_RULE


def add_parser(sub, name, help_text):
    p = sub.add_parser(name, help=help_text, description=(
        "Identify every recording (WAV, FLAC, MP3, Ogg, M4A …) under the given files and folders (recursively), in "
        "parallel worker processes. Each recording uses --assembly, else the assembly file beside it: "
        f"{ASSEMBLY_BESIDE_RULE}. Writes one result JSON per recording "
        "(as 'taptune identify --json') and summary.csv into --out, and stores the holders in the "
        "library. One bad file never stops the batch; the exit status is 1 if any file failed. "
        "Recordings identified before with the same content (sha256) are skipped unless --force. "
        "With --machine and the cut, each identified holder is also put on the machine: its tool-point "
        "FRF and stability lobes go into the result JSON (lobes in a .lobes.csv beside it), the report "
        "pages and summary.csv (critical depth, best pocket)."))
    p.add_argument("paths", nargs="+", metavar="PATH", help="recordings or folders of recordings")
    p.add_argument("--assembly", metavar="FILE", help="one assembly TOML for every recording")
    p.add_argument("--jobs", type=int, default=None, metavar="N", help="worker processes (default: all cores)")
    p.add_argument("--out", default="taptune-batch", metavar="DIR",
                   help="folder for the result JSONs and summary.csv (default: ./taptune-batch)")
    p.add_argument("--library", metavar="PATH", help="holder library file (default: $TAPTUNE_LIBRARY or the user data folder)")
    p.add_argument("--force", action="store_true", help="identify again recordings already identified with the same content")
    p.add_argument("--joint", action="store_true",
                   help="fit all recordings of one holder together (one parameter set per holder)")
    p.add_argument("--report", metavar="PDF", help="write a PDF: a summary table, then one page per identified recording")
    p.add_argument("--seed", type=int, default=0, help="random seed of every fit (default 0)")
    p.add_argument("--no-save", action="store_true", help="do not store the holders in the library")
    p.add_argument("--timeout", type=float, default=None, metavar="S",
                   help="stop a recording's identification after S seconds and mark it 'error' (default: no limit)")
    on_machine = p.add_argument_group(
        "on the machine", "with --machine, after each identification: the tool-point FRF of the recording's "
                          "assembly on the spindle and the stability lobes of the cut (as 'taptune lobes')")
    add_model_args(on_machine)
    add_cut_args(on_machine, on_machine, required=False, diameter_note=" of each recording")
    # Optimiser budget: for tests and quick looks, not for real identifications.
    p.add_argument("--population", type=int, default=None, help=argparse.SUPPRESS)
    p.add_argument("--generations", type=int, default=None, help=argparse.SUPPRESS)
    p.add_argument("--polish-evaluations", type=int, default=None, help=argparse.SUPPRESS)
    return p


def _check(args) -> None:
    from taptune.cli.common import command_inputs, output_path
    from taptune.errors import InputError

    if args.timeout is not None and not args.timeout > 0:
        raise InputError(f"--timeout must be > 0 s, got {args.timeout:g}")
    for flag in ("jobs", "population", "generations", "polish_evaluations"):
        value = getattr(args, flag)
        if value is not None and value < 1:
            raise InputError(f"--{flag.replace('_', '-')} must be at least 1, got {value}")
    from taptune.cli.common import check_seed_and_jobs

    check_seed_and_jobs(args)
    setup = machine_setup(args)  # before anything is written

    # Even with --no-save: a report written over the library file would destroy it.
    output_path(args.report, "report", library=args.library, inputs=command_inputs(args))
    return setup


def machine_setup(args):
    """The checked ``--machine`` and cut as a :class:`taptune.batch.records.MachineSetup` (None without --machine)."""
    from taptune.cli.cut import cut_options, given_cut_flags
    from taptune.errors import InputError

    if not args.machine:
        extra = given_cut_flags(args) + ["--freq"] * bool(args.freq) + ["--contact"] * (args.contact != "distributed")
        if extra:
            raise InputError(f"{', '.join(extra)} describe the machine part: give --machine MACHINE_TOML too")
        return None
    from taptune.batch.records import MachineSetup
    from taptune.cli.cmd_toolpoint import frequency_grid
    from taptune.io.machine import load_machine

    cut = cut_options(args)
    machine = load_machine(args.machine)
    from pathlib import Path

    path = str(Path(args.machine).resolve())  # a rerun from another folder still recognises its results
    return MachineSetup(machine, frequency_grid(args, machine), cut, args.contact, path)


def format_row(row) -> str:
    """One line per finished recording: status, file, then f1–f3 or the message."""
    if row.status in ("ok", "skipped") and row.model_hz[0] is not None:
        freqs = " ".join("—" if f is None else f"{f:.0f}" for f in row.model_hz)
        detail = f"f1–f3 {freqs} Hz" + (f"  ({row.seconds:.1f} s)" if row.seconds is not None else "")
        if row.status == "ok" and row.message:
            detail += f"  [{row.message}]"
    else:
        detail = row.message
    return f"{row.status:<9} {row.file}  {detail}"


def print_result(result, out_dir, stream=None) -> None:
    """Counts, notes, where the outputs are and the list of the files that failed."""
    stream = stream or sys.stdout
    counts = ", ".join(f"{result.count(s)} {s}" for s in ("ok", "skipped", "failed", "error", "cancelled") if result.count(s))
    print(f"\n{len(result.rows)} recordings: {counts}", file=stream)
    for note in result.notes:
        print(f"note: {note}", file=stream)
    print(f"results: {out_dir}  (summary: {result.summary_path})", file=stream)
    if result.failed:
        print(f"{len(result.failed)} file{'s' if len(result.failed) > 1 else ''} failed:", file=stream)
        for row in result.failed:
            print(f"  {row.file}: {row.status}: {row.message}", file=stream)
    from taptune.batch.on_machine import MACHINE_FAILED

    machine_failed = [r for r in result.rows if r.status == "ok" and r.message.startswith(MACHINE_FAILED)]
    if machine_failed:
        print(f"identified, but not on the machine ({len(machine_failed)}):", file=stream)
        for row in machine_failed:
            print(f"  {row.file}: {row.message.split('; ')[0][len(MACHINE_FAILED):].strip()}", file=stream)


def run(args) -> int:
    from pathlib import Path

    from taptune.batch import BatchOptions, run_batch
    from taptune.cli.common import ProgressBar

    machine = _check(args)
    options = BatchOptions(
        out_dir=Path(args.out), library=args.library, jobs=args.jobs, seed=args.seed, force=args.force,
        joint=args.joint, save=not args.no_save, population=args.population, generations=args.generations,
        polish_evaluations=args.polish_evaluations, timeout_s=args.timeout,
        keep_pages=bool(args.report), machine=machine,
    )
    bar = ProgressBar("batch")

    def on_row(row) -> None:
        bar.close()  # the bar shares the terminal: clear it before a line
        print(format_row(row), flush=True)

    try:
        result = run_batch(args.paths, options, args.assembly, progress=bar, on_row=on_row)
    finally:
        bar.close()
    if args.report:
        from taptune.report.pdf import write_batch_report

        write_batch_report(args.report, result.pages, result.rows)
    print_result(result, args.out)
    if args.report:
        print(f"report: {args.report}")
    return result.exit_status
