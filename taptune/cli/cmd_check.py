"""``taptune check WAV --assembly FILE --holder NAME [--library PATH] [--json OUT] [--no-save]``."""

from __future__ import annotations

import sys

_IN_WORDS = {
    "consistent": "consistent: the tap agrees with the library's prediction for this holder",
    "differs": "differs: the holder no longer behaves as identified (worn, dirty or badly seated collet or "
               "taper, wrong tool or stick-out in the assembly) — clean and re-seat it, tap again, or re-identify",
    "inconclusive": "inconclusive: this tap cannot tell — see the reasons",
}


def add_parser(sub, name, help_text):
    p = sub.add_parser(name, help=help_text, description=(
        "Tap a library holder once more (any tool and stick-out the assembly describes) and compare "
        "the bending peaks with the library's prediction and its band: consistent, differs (e.g. a worn "
        "or badly seated collet) or inconclusive. Exits 0 whenever a verdict is reached; the check is "
        "kept in the holder's history (taptune library show NAME)."))
    p.add_argument("wav", help="tap recording: WAV, FLAC, MP3, Ogg/Opus, M4A/AAC or a phone video")
    p.add_argument("--assembly", required=True, metavar="FILE", help="assembly TOML of this tap (tool, stick-out)")
    p.add_argument("--holder", required=True, metavar="NAME", help="holder name in the library")
    p.add_argument("--library", metavar="PATH", help="holder library file (default: $TAPTUNE_LIBRARY or the user data folder)")
    p.add_argument("--json", metavar="OUT", help="write the result as JSON ('-' for stdout)")
    p.add_argument("--no-save", action="store_true", help="do not add the check to the holder's history")
    return p


def print_check(check, stream=None) -> None:
    """The per-mode table and the verdict in words, for people."""
    from taptune.cli.common import format_table
    from taptune.report.text import signed

    stream = stream or sys.stdout
    r = check.result
    print(f"holder: {check.holder}\ntool:   {check.record.tool} at {check.record.stickout_mm:g} mm", file=stream)
    rows = []
    for m in r.modes:
        measured = "—" if m.measured_hz is None else f"{m.measured_hz:.1f}"
        dev = "—" if m.deviation_pct is None else signed(m.deviation_pct, 2)
        rows.append([f"f{m.mode}", measured, f"{m.predicted_hz:.1f} ± {m.band_hz:.1f}", dev, m.status])
    print(format_table(rows, ["mode", "measured [Hz]", "predicted [Hz]", "deviation [%]", "status"]), file=stream)
    band = check.prediction.band
    if band is not None:
        print(f"band: {band.text(check.prediction.bending_hz)}", file=stream)
    print(f"verdict: {_IN_WORDS[r.verdict]}", file=stream)
    for reason in r.reasons:
        print(f"  - {reason}", file=stream)
    for w in check.warnings:
        print(f"warning: {w}", file=stream)


def run(args) -> int:
    from taptune.cli.common import command_inputs, output_path, write_json
    from taptune.io.assembly import load_assembly
    from taptune.io.audio import read_audio
    from taptune.library.checks import check_holder
    from taptune.library.store import HolderLibrary, default_library_path

    library = HolderLibrary(default_library_path(args.library))
    output_path(args.json, "JSON", protect=(library.path,), library=args.library, inputs=command_inputs(args))
    assembly = load_assembly(args.assembly)
    entry = library.get(args.holder)  # an unknown holder or a broken library: before the analysis
    if not args.no_save:
        from taptune.io.atomic import check_writable

        check_writable(library.path)  # an unwritable library: before the analysis, too
    recording = read_audio(args.wav)
    check = check_holder(recording, assembly, entry.name, library, save=not args.no_save, entry=entry)
    write_json(check.to_dict(), args.json)
    if args.json != "-":
        print_check(check)
    return 0
