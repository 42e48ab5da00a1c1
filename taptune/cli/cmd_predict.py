"""``taptune predict ASSEMBLY --holder NAME [--stickout MM ...] [--library PATH] [--json OUT] [--plot PNG]``."""

from __future__ import annotations

import sys


def add_parser(sub, name, help_text):
    p = sub.add_parser(name, help=help_text, description=(
        "Predict the free-free bending modes of a library holder with the assembly's tool, at the "
        "assembly's stick-out or at each --stickout. The assembly describes the holder as clamped on "
        "this tool (bore, collet); the contact parameters come from the library."))
    p.add_argument("assembly", help="assembly TOML with the tool (and the holder as clamped on it)")
    p.add_argument("--holder", required=True, metavar="NAME", help="holder name in the library")
    p.add_argument("--stickout", type=float, nargs="+", action="extend", metavar="MM", help="stick-out(s) [mm]")
    p.add_argument("--library", metavar="PATH", help="holder library file")
    p.add_argument("--json", metavar="OUT", help="write the predictions as JSON ('-' for stdout)")
    p.add_argument("--plot", metavar="PNG", help="write a picture of the predicted tip receptances")
    return p


def predict_stickouts(entry, assembly, stickouts_mm=None):
    """Predictions (one per stick-out) and the assemblies they were made for."""
    assemblies = [assembly] if not stickouts_mm else [assembly.with_stickout(s * 1e-3) for s in stickouts_mm]
    return [entry.predict(a) for a in assemblies], assemblies


def run(args) -> int:
    from taptune.cli.common import command_inputs, format_table, output_path, write_json
    from taptune.identify.bands import second_tap_advice
    from taptune.io.assembly import load_assembly
    from taptune.library.store import HolderLibrary, default_library_path

    inputs = command_inputs(args)
    output_path(args.json, "JSON", library=args.library, inputs=inputs)
    output_path(args.plot, "plot", library=args.library, inputs=inputs)
    assembly = load_assembly(args.assembly)
    library = HolderLibrary(default_library_path(args.library))
    try:
        entry = library.get(args.holder)
    finally:
        library.close()  # before the work: the process may end without closing it (cli.FAST_EXIT)
    warnings = list(entry.warnings) + list(assembly.warnings)
    if assembly.holder.name != entry.name:
        warnings.append(
            f"{args.assembly}: its holder is '{assembly.holder.name}', predicting with the contact of library holder '{entry.name}'"
        )
    predictions, assemblies = predict_stickouts(entry, assembly, args.stickout)
    # Each stick-out has its own geometry warnings (e.g. flutes reaching into the holder).
    warnings = list(dict.fromkeys(warnings + [w for a in assemblies for w in a.warnings]))
    advice = second_tap_advice(predictions)
    if advice:
        warnings.append(advice)
    out = {"holder": entry.name, "assembly": args.assembly, "tool": assembly.tool.name,
           "predictions": [p.to_dict() for p in predictions], "warnings": warnings}
    write_json(out, args.json)
    if args.json != "-":
        rows = []
        for p in predictions:
            rows.append([f"{p.stickout_mm:g}"] + [f"{f:.0f} ± {s:.0f}" for f, s in zip(p.bending_hz, p.bending_hz_spread)]
                        + [f"{100 * p.damping_ratio[0]:.2f}"])
        print(f"holder: {entry.name}\ntool:   {assembly.tool.name}")
        print(format_table(rows, ["stick-out [mm]", "f1 [Hz]", "f2 [Hz]", "f3 [Hz]", "ζ1 [%]"]))
        for p in predictions:
            print(f"{p.stickout_mm:g} mm: {p.band_text()}")
        for w in warnings:
            print(f"warning: {w}", file=sys.stderr)
    if args.plot:
        from taptune.report.fit_plot import plot_predictions

        plot_predictions(entry, assemblies, predictions, args.plot)
    return 0
