"""``taptune identify WAV... [--assembly FILE...] [--library PATH] [--seed N] [--json OUT] [--plot PNG] [--no-save | --save-anyway]``."""

from __future__ import annotations

import sys
from pathlib import Path

from taptune.io.assembly import ASSEMBLY_BESIDE_RULE


def add_parser(sub, name, help_text):
    p = sub.add_parser(name, help=help_text, description=(
        "Find the taps, label the bending peaks, fit the holder's contact parameters and store "
        "the holder in the library. Several recordings of one holder (other tools or stick-outs) "
        "are fitted jointly: give one --assembly per recording, in the same order."))
    p.add_argument("wav", nargs="+", help="tap recording(s): WAV, FLAC, MP3, Ogg/Opus, M4A/AAC or a phone video")
    p.add_argument("--assembly", action="append", metavar="FILE",
                   help="assembly TOML (once for all recordings, or once per recording; default: the one "
                        f"beside each recording: {ASSEMBLY_BESIDE_RULE})")
    p.add_argument("--library", metavar="PATH", help="holder library file (default: $TAPTUNE_LIBRARY or the user data folder)")
    p.add_argument("--seed", type=int, default=0, help="random seed: the same seed gives the same result (default 0)")
    p.add_argument("--json", metavar="OUT", help="write the result as JSON ('-' for stdout)")
    p.add_argument("--plot", metavar="PNG", help="write a picture of the measured spectrum and the fit")
    p.add_argument("--report", metavar="PDF", help="write a one-page-per-recording PDF report")
    p.add_argument("--no-save", action="store_true", help="do not store the holder in the library")
    p.add_argument("--save-anyway", action="store_true",
                   help="store the holder even when the fitted model misses a measured mode by more than 5 %% "
                        "(without it such a fit is reported, exit 2, and not stored)")
    p.add_argument("--jobs", type=int, default=None, help="processes for the optimiser (default: all cores)")
    return p


def assemblies_beside(wavs) -> list[str]:
    """The assembly file beside each recording, named on stderr; an InputError if one has none."""
    from taptune.errors import InputError
    from taptune.io.assembly import assembly_beside

    found = []
    for wav in wavs:
        if not Path(wav).is_file():  # a misspelt recording is that, not a missing assembly file
            raise InputError(f"{wav}: no such file")
        path = assembly_beside(wav)
        if path is None:
            tried = ASSEMBLY_BESIDE_RULE.replace("<name>", Path(wav).stem)
            raise InputError(f"{wav}: no assembly file beside it ({tried}); give one with --assembly FILE")
        print(f"assembly of {wav}: {path} (beside it)", file=sys.stderr)
        found.append(str(path))
    return found


def load_inputs(wavs, assembly_files):
    """Recordings and their assemblies (one assembly for all, or one each)."""
    from taptune.errors import InputError
    from taptune.io.assembly import load_assembly
    from taptune.io.audio import read_audio

    if len(assembly_files) not in (1, len(wavs)):
        raise InputError(f"give one --assembly for all recordings or one per recording ({len(wavs)}), got {len(assembly_files)}")
    assemblies = [load_assembly(f) for f in assembly_files]
    if len(assemblies) == 1:
        assemblies *= len(wavs)
    recordings = [read_audio(w) for w in wavs]
    return recordings, assemblies


def run_identification(recordings, assemblies, seed=0, jobs=None, progress=None):
    """Analyse and fit; returns (analyses, Identification)."""
    from taptune.identify import IdentifyOptions
    from taptune.identify.pipeline import identify_recordings

    return identify_recordings(recordings, assemblies, IdentifyOptions(seed=seed, jobs=jobs), progress)


def print_summary(out: dict, result, stream=None) -> None:
    from taptune.cli.common import format_table
    from taptune.report.text import signed

    stream = stream or sys.stdout
    measured = result.bending_measured_hz
    model = result.bending_model_hz
    print(f"holder: {out['holder']}", file=stream)
    for i, (m, f) in enumerate(zip(measured, model)):
        rows = [[f"f{n + 1}", "—" if m[n] is None else f"{m[n]:.1f}", f"{f[n]:.1f}",
                 "—" if m[n] is None else signed(100 * (f[n] / m[n] - 1), 3)] for n in range(3)]
        if len(measured) > 1:
            print(f"recording {i + 1}:", file=stream)
        print(format_table(rows, ["mode", "measured [Hz]", "model [Hz]", "error [%]"]), file=stream)
    p = result.params
    spread = result.param_spread
    print(
        f"k_tt = {p.k_tt:.3g} ± {spread['k_tt']:.2g} N/m/mm   k_rr = {p.k_rr:.3g} ± {spread['k_rr']:.2g} N·m/rad/mm\n"
        f"eta_tt = {p.eta_tt:.3g} 1/mm   eta_rr = {p.eta_rr:.3g} 1/mm   alpha = {signed(p.alpha, 1)} %   "
        f"density ×{p.density_factor:.3f}   modulus ×{p.modulus_factor:.3f}",
        file=stream,
    )
    print(f"objective {result.objective:.4g}, {result.evaluations} evaluations, {result.seconds:.2f} s", file=stream)
    outlook = out.get("transfer_outlook")
    if outlook:
        rel = [s / f for s, f in zip(outlook["bending_hz_spread"], outlook["bending_hz"])]
        # In words: how the band adds up is in --json (transfer_outlook.band).
        print(f"other stick-outs: at {outlook['stickout']:g} mm the predicted f1–f3 are good to "
              f"±{100 * min(rel):.1f}–{100 * max(rel):.1f} % (each ± holds the true frequency about 9 times in 10)",
              file=stream)
    for w in out["warnings"]:
        print(f"warning: {w}", file=stream)


def run(args) -> int:
    from taptune.cli.common import ProgressBar, command_inputs, output_path, write_json
    from taptune.errors import TaptuneError
    from taptune.identify.pipeline import identification_record
    from taptune.identify.optimize import Cancelled

    from taptune.cli.common import check_seed_and_jobs

    check_seed_and_jobs(args)
    if not args.assembly:
        args.assembly = assemblies_beside(args.wav)
    library = None
    if not args.no_save:
        # The library's modules only when the holder is stored (--no-save skips their import).
        from taptune.library.store import default_library_path

        library = default_library_path(args.library)
    inputs = command_inputs(args)
    for path, what in ((args.json, "JSON"), (args.plot, "plot"), (args.report, "report")):
        output_path(path, what, library=args.library, inputs=inputs)
    recordings, assemblies = load_inputs(args.wav, args.assembly)
    if library is not None:
        from taptune.library.store import HolderLibrary

        # A broken or unwritable library is reported before the fit, not after it.
        HolderLibrary(library).check_writable()
    bar = ProgressBar("identify")
    try:
        analyses, result = run_identification(recordings, assemblies, args.seed, args.jobs, bar)
    except Cancelled:
        bar.close()
        print("taptune identify: cancelled", file=sys.stderr)
        return 130
    finally:
        bar.close()
    out = identification_record(recordings, assemblies, analyses, result)
    if not args.no_save:
        from taptune.library.record import FitTooPoor, save_identification

        try:
            name = save_identification(args.library, result, recordings, assemblies, force=args.save_anyway)
        except TaptuneError as err:
            # The library could not take it (a disk full, a lock held too long) or the fit
            # is too poor to store: it is not lost, the JSON (or the screen) still gets it.
            write_json(out, args.json)
            if args.json != "-":
                print_summary(out, result)
            if isinstance(err, FitTooPoor):
                raise FitTooPoor(f"{err} (--save-anyway stores it)") from None
            raise
        out["library_entry"] = name
    write_json(out, args.json)
    if args.json != "-":
        print_summary(out, result)
        if not args.no_save:
            print(f"saved holder '{out['library_entry']}' to the library")
    if args.plot:
        from taptune.report.fit_plot import plot_identification

        plot_identification(result, analyses, args.plot, title=out["holder"])
    if args.report:
        from taptune.report.pdf import write_identification_report

        write_identification_report(args.report, result, analyses, recordings, assemblies)
    return 0
