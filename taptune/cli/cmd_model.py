"""``taptune model ASSEMBLY [--holder NAME | --params JSON_FILE] [--library PATH] [--json OUT]``.

Free-free model of one assembly with the nominal holder parameters (docs/physics.md §2), a
library holder's, or those in a JSON file: bending frequencies, damping ratios, model
size, the physical bounds of the bending frequencies over the search space and the mode diagnostics.
"""

from __future__ import annotations

import json
import sys

from taptune.errors import InputError


def add_parser(sub, name, help_text):
    p = sub.add_parser(name, help=help_text, description=(
        "Free-free Timoshenko model of a tool clamped in a holder: the bending frequencies and "
        "damping ratios for the nominal holder parameters, a library holder's (--holder) or "
        "those in a JSON file (--params)."))
    p.add_argument("assembly", help="assembly TOML file (docs/assembly-format.md)")
    source = p.add_mutually_exclusive_group()
    source.add_argument("--holder", metavar="NAME", help="use this library holder's parameters")
    source.add_argument("--params", metavar="JSON_FILE",
                        help="JSON with k_tt, k_rr, eta_tt, eta_rr, alpha, density_factor, modulus_factor "
                             "(or an identify result with a 'params' object)")
    p.add_argument("--library", metavar="PATH", help="holder library file (for --holder)")
    p.add_argument("--json", metavar="OUT", help="write the result as JSON ('-' for stdout)")
    return p


def read_params_file(path: str):
    """HolderParams from a JSON file; every problem is an InputError naming the file."""
    from taptune.model.params import HolderParams

    from taptune.io.files import read_text

    text = read_text(path, "a parameter file", "JSON")
    try:
        data = json.loads(text)
    except json.JSONDecodeError as err:
        raise InputError(f"{path}: not valid JSON ({err.msg} at line {err.lineno} column {err.colno})") from None
    # An identify/library JSON carries the parameters under "params".
    if isinstance(data, dict) and isinstance(data.get("params"), dict):
        data = data["params"]
    return HolderParams.from_dict(data, path)


def holder_params(args):
    """(HolderParams, ModelOptions, description) from --holder, --params or the nominal set."""
    from taptune.model.options import ModelOptions
    from taptune.model.params import NOMINAL

    if args.params:
        return read_params_file(args.params), ModelOptions(), f"file {args.params}"
    if args.holder:
        try:
            from taptune.library.store import HolderLibrary, default_library_path
        except ImportError as err:
            raise InputError(f"--holder {args.holder}: the holder library is not available ({err})") from None
        library = HolderLibrary(default_library_path(args.library))
        entry = library.get(args.holder)
        try:
            options = entry.options()
        except (TypeError, ValueError) as err:
            raise InputError(f"{library.path}: holder {entry.name!r} has unusable model_options ({err})") from None
        return entry.params, options, f"library holder '{entry.name}'"
    return NOMINAL, ModelOptions(), "nominal (medians of published holders)"


def report(result, bounds, assembly, source: str, path: str) -> str:
    """The readable table printed to stdout."""
    from taptune.cli.common import format_table

    rows = []
    for n, (f, z) in enumerate(zip(result.bending_hz, result.damping_ratio)):
        lo, hi = bounds[n] if n < len(bounds) else (None, None)
        rows.append([
            str(n + 1), f"{f:.1f}", f"{100 * z:.3f}",
            f"{100 * result.tip_participation[n]:.0f}", f"{100 * result.contact_energy_share[n]:.1f}",
            f"{lo:.0f} … {hi:.0f}" if lo is not None else "",
        ])
    head = (
        f"assembly: {path}\n"
        f"holder:   {assembly.holder.name}\n"
        f"tool:     {assembly.tool.name}, stick-out {assembly.stickout * 1e3:g} mm, "
        f"contact {assembly.contact_length * 1e3:g} mm\n"
        f"params:   {source}\n"
    )
    table = format_table(rows, ["mode", "f [Hz]", "ζ [%]", "tip [%]", "contact energy [%]", "bounds [Hz]"])
    return head + table + f"\nmodel: {result.dofs} DOFs, {result.elements} elements"


def run(args) -> int:
    from taptune.cli.common import command_inputs, output_path, write_json
    from taptune.io.assembly import load_assembly
    from taptune.model.bounds import bending_bounds
    from taptune.model.fe import build_model
    from taptune.model.modes import analyse

    output_path(args.json, "JSON", library=args.library, inputs=command_inputs(args))
    assembly = load_assembly(args.assembly)
    params, options, source = holder_params(args)
    fe = build_model(assembly, options)
    result = analyse(assembly, params, options, fe=fe)
    bounds = bending_bounds(assembly, options, fe=fe)
    out = {
        "assembly": args.assembly,
        "holder": assembly.holder.name,
        "tool": assembly.tool.name,
        "stickout_mm": round(assembly.stickout * 1e3, 6),
        "params_source": source,
        **result.to_dict(),
        "bending_bounds_hz": [[round(float(lo), 1), round(float(hi), 1)] for lo, hi in bounds],
    }
    write_json(out, args.json)
    if args.json != "-":
        print(report(result, bounds, assembly, source, args.assembly))
    for w in result.warnings:
        print(f"warning: {w}", file=sys.stderr)
    return 0
