"""``taptune lobes (ASSEMBLY (--holder NAME | --params JSON) --machine MACHINE.toml | --frf CSV) --teeth N ...``.

Zero-order milling stability lobes (MODEL.md §11, MACHINE.md) from the tool-point FRF:
predicted on the machine (as ``taptune toolpoint``) or measured (``--frf``). Prints the
critical depth and the best speeds (pockets); writes JSON, CSV and a picture.
"""

from __future__ import annotations

import sys

from taptune.cli.cmd_toolpoint import add_holder_args, add_model_args

DEFAULT_MIN_RPM = 500.0
DEFAULT_STEP_RPM = 10.0
# Without a machine top speed, the diagram reaches a little beyond the k = 0 lobe's peak
# 60 f_c / N, which is the highest pocket a cut can have.
TOP_POCKET_MARGIN = 1.2


def add_parser(sub, name, help_text):
    from taptune.machine.materials import MATERIALS

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
    cut.add_argument("--teeth", type=int, required=True, metavar="N", help="number of teeth (flutes)")
    cut.add_argument("--ktc", type=float, metavar="MPA", help="tangential cutting-force coefficient K_tc [MPa = N/mm²]")
    cut.add_argument("--krc", type=float, metavar="MPA", help="radial cutting-force coefficient K_rc [MPa]")
    cut.add_argument("--material", metavar="NAME", help=f"work material instead of --ktc/--krc: {', '.join(MATERIALS)}")
    cut.add_argument("--diameter", type=float, metavar="MM", help="tool diameter [mm] (default: the assembly's "
                                                                   "flute diameter; required with --frf)")
    cut.add_argument("--ae", type=float, required=True, metavar="MM", help="radial depth of cut [mm]; = diameter is slotting")
    cut.add_argument("--milling", choices=("up", "down"), required=True, help="up- or down-milling")
    p.add_argument("--rpm", type=float, nargs=3, metavar=("MIN", "MAX", "STEP"),
                   help=f"spindle-speed grid [rpm], MAX included when on the grid (default: {DEFAULT_MIN_RPM:g} rpm "
                        f"to the machine's max_rpm, or just past the highest pocket, step {DEFAULT_STEP_RPM:g})")
    p.add_argument("--json", metavar="OUT", help="write the lobes as JSON ('-' for stdout)")
    p.add_argument("--csv", metavar="OUT", help="write rpm,a_lim_mm,chatter_hz")
    p.add_argument("--plot", metavar="PNG", help="write the lobe diagram")
    return p


def cutting_coefficients(args) -> tuple[float, float, str]:
    """(K_tc, K_rc [N/m²], description) from --material or --ktc/--krc."""
    from taptune.errors import InputError

    if args.material:
        if args.ktc is not None or args.krc is not None:
            raise InputError("give either --material or --ktc and --krc, not both")
        from taptune.machine.materials import cutting_coefficients as lookup

        c = lookup(args.material)
        return c.ktc, c.krc, f"{c.name} (K_tc {c.ktc / 1e6:g} MPa, K_rc {c.krc / 1e6:g} MPa)"
    if args.ktc is None or args.krc is None:
        raise InputError("give the cutting coefficients: --ktc MPA and --krc MPA, or --material NAME")
    return args.ktc * 1e6, args.krc * 1e6, f"K_tc {args.ktc:g} MPa, K_rc {args.krc:g} MPa"


def rpm_grid(args, freq_hz, gxx, gyy, teeth: int, max_rpm: float | None):
    """``--rpm`` or the default grid: from 500 rpm to the machine's top speed, else just past
    the highest pocket 60 f/N of the strongest mode."""
    import numpy as np

    from taptune.errors import InputError
    from taptune.library.exchange import frequency_grid as uniform_grid
    from taptune.machine import dominant_modes

    if args.rpm:
        lo, hi, step = args.rpm
        try:
            return uniform_grid(lo, hi, step)
        except InputError:
            raise InputError(f"--rpm {lo:g} {hi:g} {step:g}: needs 0 < MIN < MAX and STEP > 0 (rpm)") from None
    if max_rpm is None:
        modes = dominant_modes(freq_hz, gxx, "x") + dominant_modes(freq_hz, gyy, "y")
        f_top = max(modes, key=lambda m: m.magnitude).hz if modes else float(freq_hz[np.argmax(np.abs(gxx))])
        max_rpm = 1000.0 * np.ceil(TOP_POCKET_MARGIN * 60.0 * f_top / teeth / 1000.0)
    return uniform_grid(min(DEFAULT_MIN_RPM, 0.5 * max_rpm), max_rpm, DEFAULT_STEP_RPM)


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

        t = read_toolpoint_csv(args.frf)
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
    diameter_mm = (tool.flute_diameter or tool.segments[-1].od) * 1e3
    what = (f"{holder.name} with {tool.name} at {used.stickout * 1e3:g} mm on {machine.name} "
            f"(contact {args.contact})")
    return frf.freq_hz, frf.xx, frf.yy, what, diameter_mm, machine.max_rpm, warnings


def run(args) -> int:
    from taptune.cli.common import format_table, output_path, write_json
    from taptune.errors import InputError
    from taptune.machine import stability_lobes

    for path, what in ((args.json, "JSON"), (args.csv, "CSV"), (args.plot, "plot")):
        output_path(path, what)
    if args.teeth < 1:
        raise InputError(f"--teeth must be >= 1, got {args.teeth}")
    ktc, krc, coefficients = cutting_coefficients(args)
    if args.frf and args.diameter is None:
        raise InputError("--frf needs --diameter MM (the tool diameter)")
    freq, gxx, gyy, source, tool_diameter_mm, max_rpm, warnings = frf_input(args)
    diameter = args.diameter if args.diameter is not None else tool_diameter_mm
    rpm = rpm_grid(args, freq, gxx, gyy, args.teeth, max_rpm)
    lobes = stability_lobes(freq, gxx, gyy, teeth=args.teeth, ktc=ktc, krc=krc, diameter=diameter * 1e-3,
                            ae=args.ae * 1e-3, milling=args.milling, rpm=rpm)
    warnings += [w for w in lobes.warnings if w not in warnings]
    out = lobes.to_dict()
    cut = {"teeth": args.teeth, "ktc_mpa": ktc / 1e6, "krc_mpa": krc / 1e6, "diameter_mm": diameter,
           "ae_mm": args.ae, "milling": args.milling, "material": args.material}
    out.update(source=source, cut=cut, warnings=warnings)
    write_json(out, args.json)
    if args.csv:
        write_lobes_csv(args.csv, out)
    if args.json != "-":
        kind = "slotting" if args.ae >= diameter * (1 - 1e-9) else f"{args.milling}-milling, ae {args.ae:g} mm"
        print(f"FRF:  {source}\ncut:  {args.teeth} teeth, Ø{diameter:g} mm, {kind}; {coefficients}")
        print(f"critical depth (stable at every speed): {out['a_crit_mm']:.3g} mm  "
              f"[{rpm[0]:g}–{rpm[-1]:g} rpm]")
        rows = [[f"{p['rpm']:.0f}", f"{p['a_lim_mm']:.3g}", _chatter_at(out, p["rpm"])] for p in out["pockets"][:5]]
        print(format_table(rows, ["pocket [rpm]", "a_lim [mm]", "chatter [Hz]"]) if rows
              else "no pockets inside this speed range")
    for w in warnings:
        print(f"warning: {w}", file=sys.stderr)
    if args.plot:
        from taptune.report.machine_plot import plot_lobes

        plot_lobes(lobes.rpm, [a if a is not None else float("nan") for a in out["a_lim_mm"]], out["a_crit_mm"],
                   out["pockets"], args.plot, chatter_hz=lobes.chatter_hz,
                   title=f"{source}\n{args.teeth} teeth, Ø{diameter:g} mm, ae {args.ae:g} mm {args.milling}; {coefficients}")
    return 0


def _chatter_at(out: dict, rpm: float) -> str:
    """The chatter frequency on the boundary just beside a pocket (the peak joins two lobes)."""
    i = out["rpm"].index(rpm)
    f = out["chatter_hz"][i]
    return f"{f:.0f}" if f is not None else ""


def write_lobes_csv(path: str, out: dict) -> None:
    """rpm, a_lim_mm, chatter_hz per speed (empty where no lobe reaches)."""
    from taptune.errors import InputError
    from taptune.library.store import atomic_write_bytes

    def cell(v):
        return "" if v is None else f"{v:.10g}"

    lines = ["rpm,a_lim_mm,chatter_hz"]
    lines += [f"{r:.10g},{cell(a)},{cell(f)}" for r, a, f in zip(out["rpm"], out["a_lim_mm"], out["chatter_hz"])]

    try:
        atomic_write_bytes(path, ("\n".join(lines) + "\n").encode("ascii"))
    except OSError as err:
        raise InputError(f"{path}: cannot write ({err.strerror})") from None
