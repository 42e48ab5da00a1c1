"""``taptune spectrum WAV [--assembly FILE] [--json OUT] [--plot PNG]`` (docs/cli.md)."""

from __future__ import annotations

import sys


def add_parser(sub, name, help_text):
    p = sub.add_parser(name, help=help_text, description=(
        "Find the taps in a recording, average their spectra, pick the peaks and label them "
        "bending (modes 1-3), local (the spindle interface's own modes) or other. Without "
        "--assembly the bending labels are a best guess; with it, the model of the assembly "
        "guides them."))
    p.add_argument("wav", help="tap recording: WAV, FLAC, MP3, Ogg/Opus, M4A/AAC or a phone video")
    p.add_argument("--assembly", metavar="FILE", help="assembly TOML: the model guides the bending labels")
    p.add_argument("--json", metavar="OUT", help="write the result as JSON ('-' for stdout)")
    p.add_argument("--plot", metavar="PNG", help="write a picture of the spectrum and the labeled peaks")
    p.add_argument("--interface", metavar="NAME",
                   help="spindle interface for the local-mode band (default: the assembly's, else HSK-A63)")
    p.add_argument("--interface-tap", metavar="WAV",
                   help="a recording tapped on the interface itself: the peaks that grow there are local")
    p.add_argument("--bands", metavar="FILE",
                   help="extra table of interface local-mode bands, TOML or JSON "
                        "(also $TAPTUNE_INTERFACE_BANDS)")
    return p


def print_summary(analysis, stream=None) -> None:
    """Peaks as a table, bending frequencies and warnings, for people."""
    from taptune.cli.common import format_table

    stream = stream or sys.stdout
    d = analysis
    print(f"{d.file}: {d.sample_rate} Hz, {d.channels} channel(s), {d.n_taps} of {len(d.taps)} taps used",
          file=stream)
    rows = []
    for p in d.peaks:
        rows.append([f"{p.hz:.2f}", f"{p.level_db:.1f}", p.kind + (f" {p.mode}" if p.mode else ""),
                     "" if p.damping_ratio is None else f"{100 * p.damping_ratio:.3f}",
                     f"{p.scatter_hz:.2f}", p.note])
    print(format_table(rows, ["Hz", "dB", "kind", "zeta %", "scatter Hz", "note"]), file=stream)
    if d.bending_peaks:
        print("bending: " + ", ".join(f"f{p.mode} = {p.hz:.2f} Hz" for p in d.bending_peaks), file=stream)
    for w in d.warnings:
        print(f"warning: {w}", file=stream)


def run(args) -> int:
    from dataclasses import replace

    from taptune.cli.common import command_inputs, output_path, write_json
    from taptune.io.audio import read_audio
    from taptune.signal.analysis import SpectrumOptions, analyse_recording

    inputs = command_inputs(args)
    output_path(args.json, "JSON", inputs=inputs)
    output_path(args.plot, "plot", inputs=inputs)
    recording = read_audio(args.wav)
    interface_tap = read_audio(args.interface_tap) if args.interface_tap else None
    options = SpectrumOptions()
    if args.bands:
        from taptune.signal.labels import load_band_table

        load_band_table(args.bands)  # fail early, naming the file
        options = replace(options, band_table=args.bands)
    expected = bounds = spread = None
    interface = args.interface or "HSK-A63"
    if args.assembly:
        from taptune.io.assembly import load_assembly

        assembly = load_assembly(args.assembly)
        interface = args.interface or assembly.holder.interface
        from taptune.identify.pipeline import model_expectation

        expected, bounds, spread = model_expectation(assembly)
    analysis = analyse_recording(recording, interface=interface, expected_hz=expected,
                                 bounds_hz=bounds, options=options, interface_tap=interface_tap,
                                 spread_hz=spread)
    if args.assembly and assembly.warnings:
        # The assembly file's own warnings (a misspelt key, an implied collet) first.
        analysis = replace(analysis, warnings=list(dict.fromkeys([*assembly.warnings, *analysis.warnings])))
    data = analysis.to_dict()
    if expected is not None:
        data["model_bending_hz"] = [round(float(f), 2) for f in expected]
        data["model_bounds_hz"] = [[round(float(a), 1), round(float(b), 1)] for a, b in bounds]
    write_json(data, args.json)
    if args.plot:
        from taptune.report.spectrum_plot import plot_spectrum

        plot_spectrum(analysis, args.plot, expected_hz=expected)
    if args.json != "-":
        print_summary(analysis)
    return 0
