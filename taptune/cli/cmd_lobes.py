"""``taptune lobes (ASSEMBLY (--holder NAME | --params JSON) --machine MACHINE.toml | --frf CSV) --teeth N ...``.

Zero-order milling stability lobes (MODEL.md §11, MACHINE.md) from the tool-point FRF:
predicted on the machine (as ``taptune toolpoint``) or measured (``--frf``). Prints the
critical depth and the best speeds (pockets); writes JSON, CSV and a picture.
"""

from __future__ import annotations

import sys

from taptune.cli.cmd_toolpoint import add_holder_args, add_model_args
from taptune.cli.cut import add_cut_args, cut_options, rpm_grid, tool_diameter_mm


def add_parser(sub, name, help_text):
    p = sub.add_parser(name, help=help_text, description=(
        "Stability lobes of a milling cut, zero-order approximation: the largest axial depth of cut "
        "without chatter at each spindle speed. The tool-point FRF comes from the holder on the "
        "machine (ASSEMBLY with --holder or --params, and --machine) or from a measured file (--frf)."))
    p.add_argument("assembly", nargs="?", help="assembly TOML with the tool (not with --frf)")
    add_holder_args(p)
    p.add_argument("--stickout", type=float, metavar="MM", help="stick-out [mm] (default: the assembly's)")
    add_model_args(p)
    p.add_argument("--frf", metavar="CSV", help="measured tool-point FRF: f_hz,xx_re,xx_im[,yy_re,yy_im] in m/N "
                                                "(y = x when the yy columns are absent)")
    cut = p.add_argument_group("the cut")
    add_cut_args(p, cut, required=True, diameter_note="; required with --frf")
    p.add_argument("--json", metavar="OUT", help="write the lobes as JSON ('-' for stdout)")
    p.add_argument("--csv", metavar="OUT", help="write rpm,a_lim_mm,chatter_hz")
    p.add_argument("--plot", metavar="PNG", help="write the lobe diagram")
    return p


def frf_input(args):
    """(freq_hz, Φ_xx, Φ_yy, description, tool diameter [mm] or None, max rpm or None, warnings)."""
    from taptune.errors import InputError

    if args.frf:
        extra = [n for n, v in (("ASSEMBLY", args.assembly), ("--holder", args.holder), ("--params", args.params),
                                ("--machine", args.machine), ("--stickout", args.stickout), ("--freq", args.freq))
                 if v is not None]
        if extra:
            raise InputError(f"--frf {args.frf}: the FRF is measured; {', '.join(extra)} belong to the predicted one")
        from taptune.io.machine import read_toolpoint_csv
        from taptune.machine.lobes import MIN_FREQUENCIES

        t = read_toolpoint_csv(args.frf)
        if t.freq_hz.size < MIN_FREQUENCIES:
            raise InputError(f"{args.frf}: the lobes need at least {MIN_FREQUENCIES} frequencies of the "
                             f"tool-point FRF, got {t.freq_hz.size}")
        warnings = [f"{args.frf}: no yy columns; the x FRF is used for y"] if t.y_from_x else []
        return t.freq_hz, t.xx, t.yy, f"measured FRF {args.frf}", None, None, warnings
    if not args.assembly:
        raise InputError("lobes needs ASSEMBLY with --holder/--params and --machine, or --frf CSV")
    from taptune.cli.cmd_toolpoint import frequency_grid, machine_inputs, toolpoint_frfs

    assembly, machine, holder, warnings = machine_inputs(args, "lobes")
    stickouts = [args.stickout] if args.stickout is not None else None
    frfs, assemblies = toolpoint_frfs(assembly, machine, holder, frequency_grid(args, machine), stickouts, args.contact)
    frf, used = frfs[0], assemblies[0]
    warnings += [w for w in used.warnings if w not in warnings]
    tool = used.tool
    diameter_mm = tool_diameter_mm(used)
    what = (f"{holder.name} with {tool.name} at {used.stickout * 1e3:g} mm on {machine.name} "
            f"(contact {args.contact})")
    return frf.freq_hz, frf.xx, frf.yy, what, diameter_mm, machine.max_rpm, warnings


def run(args) -> int:
    from taptune.cli.common import command_inputs, format_table, output_path, write_json
    from taptune.errors import InputError
    from taptune.machine import stability_lobes

    inputs = command_inputs(args)
    for path, what in ((args.json, "JSON"), (args.csv, "CSV"), (args.plot, "plot")):
        output_path(path, what, library=args.library, inputs=inputs)
    cut = cut_options(args)  # the whole cut checked before the tool-point FRF is computed
    if args.frf and args.diameter is None:
        raise InputError("--frf needs --diameter MM (the tool diameter)")
    freq, gxx, gyy, source, tool_diameter_mm, max_rpm, warnings = frf_input(args)
    diameter = cut.diameter_mm if cut.diameter_mm is not None else tool_diameter_mm
    rpm = rpm_grid(cut.rpm, freq, gxx, gyy, cut.teeth, max_rpm)
    lobes = stability_lobes(freq, gxx, gyy, teeth=cut.teeth, ktc=cut.ktc, krc=cut.krc, diameter=diameter * 1e-3,
                            ae=cut.ae_mm * 1e-3, milling=cut.milling, rpm=rpm)
    warnings += [w for w in lobes.warnings if w not in warnings]
    out = lobes.to_dict()
    out.update(source=source, cut=cut.to_dict(diameter), warnings=warnings)
    write_json(out, args.json)
    if args.csv:
        write_lobes_csv(args.csv, out)
    if args.json != "-":
        print(f"FRF:  {source}\ncut:  {cut.describe(diameter)}")
        crit = "none: no depth chatters" if out["a_crit_mm"] is None else f"{out['a_crit_mm']:.3g} mm"
        print(f"critical depth (stable at every speed): {crit}  [{rpm[0]:g}–{rpm[-1]:g} rpm]")
        rows = [[f"{p['rpm']:.0f}", f"{p['a_lim_mm']:.3g}", _chatter_at(out, p["rpm"])] for p in out["pockets"][:5]]
        print(format_table(rows, ["pocket [rpm]", "a_lim [mm]", "chatter [Hz]"]) if rows
              else "no pockets inside this speed range")
    for w in warnings:
        print(f"warning: {w}", file=sys.stderr)
    if args.plot:
        from taptune.report.machine_plot import plot_lobes

        plot_lobes(lobes.rpm, [a if a is not None else float("nan") for a in out["a_lim_mm"]], out["a_crit_mm"],
                   out["pockets"], args.plot, chatter_hz=lobes.chatter_hz,
                   title=f"{source}\n{cut.teeth} teeth, Ø{diameter:g} mm, ae {cut.ae_mm:g} mm {cut.milling}; {cut.coefficients}")
    return 0


def _chatter_at(out: dict, rpm: float) -> str:
    """The chatter frequency on the boundary just beside a pocket (the peak joins two lobes)."""
    i = out["rpm"].index(rpm)
    f = out["chatter_hz"][i]
    return f"{f:.0f}" if f is not None else ""


def write_lobes_csv(path: str, out: dict) -> None:
    """rpm, a_lim_mm, chatter_hz per speed (empty where no lobe reaches)."""
    from taptune.errors import InputError
    from taptune.io.atomic import atomic_write_bytes

    def cell(v):
        return "" if v is None else f"{v:.10g}"

    lines = ["rpm,a_lim_mm,chatter_hz"]
    lines += [f"{r:.10g},{cell(a)},{cell(f)}" for r, a, f in zip(out["rpm"], out["a_lim_mm"], out["chatter_hz"])]

    try:
        atomic_write_bytes(path, ("\n".join(lines) + "\n").encode("ascii"))
    except OSError as err:
        raise InputError(f"{path}: cannot write ({err.strerror})") from None
