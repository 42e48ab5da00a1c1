"""``taptune lobes (ASSEMBLY (--holder NAME | --params JSON) --machine MACHINE.toml | --frf FILE [--frf-y FILE]) --teeth N ...``.

Milling stability lobes (docs/machine.md) from the tool-point FRF: predicted on the
machine (as ``taptune toolpoint``) or measured (``--frf``, one file per direction in CSV,
CutPro-style ``.frf`` or UFF58). ``--method auto`` (default) is the semi-discretization,
``zoa`` the fast zero-order preview. The holder's prediction band (or ``--frf-tolerance``)
gives the depth stable with probability ``--confidence`` and the safe pockets. Prints
the safe pockets first, the critical depth and the lobe peaks; writes JSON, CSV and a picture.
"""

from __future__ import annotations

import sys
from dataclasses import dataclass

from taptune.cli.cmd_toolpoint import add_holder_args, add_model_args
from taptune.cli.cut import add_cut_args, cut_options, rpm_grid, tool_diameter_mm

METHODS = ("auto", "sdm", "zoa")

def add_parser(sub, name, help_text):
    p = sub.add_parser(name, help=help_text, description=(
        "Stability lobes of a milling cut: the largest axial depth of cut without chatter at each spindle "
        "speed, by semi-discretization (flip and Hopf lobes of intermittent cuts) or the zero-order "
        "approximation. The tool-point FRF comes from the holder on the machine (ASSEMBLY with --holder or "
        "--params, and --machine) or from measured files (--frf, --frf-y). With a library holder (or "
        "--frf-tolerance) the holder's uncertainty gives the depth stable with probability --confidence "
        "and the safe pockets: speed windows a machinist can hold."))
    p.add_argument("assembly", nargs="?", help="assembly TOML with the tool (not with --frf)")
    add_holder_args(p)
    p.add_argument("--stickout", type=float, metavar="MM", help="stick-out [mm] (default: the assembly's)")
    add_model_args(p)
    p.add_argument("--frf", metavar="FILE", help="measured tool-point FRF in m/N (e^{iωt}: Im ≤ 0 below resonance): "
                                                 "CSV f_hz,xx_re,xx_im[,yy_re,yy_im], or the x FRF alone as CSV "
                                                 "f_hz,re,im, CutPro-style .frf text or UFF58 (y = x without --frf-y)")
    p.add_argument("--frf-y", metavar="FILE", help="the y FRF for --frf, in any of its one-FRF formats")
    p.add_argument("--frf-tolerance", type=float, metavar="PCT",
                   help="how well the measured FRF's modal frequencies are known, ± %% (90 %% band; default: exact)")
    p.add_argument("--flute-length", type=float, metavar="MM",
                   help="cutting-edge length [mm]: no deeper cut is reported stable (default: the assembly's "
                        "[tool] flute_length)")
    cut = p.add_argument_group("the cut")
    add_cut_args(p, cut, required=True, diameter_note="; required with --frf")
    p.add_argument("--method", choices=METHODS, default="auto",
                   help="auto (default): semi-discretization; sdm: the same, refusing an FRF its modal fit cannot "
                        "reproduce; zoa: zero-order approximation (fast preview, misses flip lobes)")
    p.add_argument("--confidence", type=float, default=0.9, metavar="P",
                   help="probability that the safe depth and safe pockets are stable, in (0.5, 1) (default 0.9)")
    p.add_argument("--json", metavar="OUT", help="write the lobes as JSON ('-' for stdout)")
    p.add_argument("--csv", metavar="OUT", help="write rpm,a_lim_mm,a_lim_mm_safe,chatter_hz,instability")
    p.add_argument("--plot", metavar="PNG", help="write the lobe diagram")
    return p


@dataclass(frozen=True)
class LobesInput:
    """What the lobes are computed from: the FRFs, where they came from, the tool's limits, the band."""

    freq_hz: object
    xx: object
    yy: object
    source: str
    diameter_mm: float | None
    max_rpm: float | None
    warnings: list
    flute_length_mm: float | None = None
    band: tuple = (0.0, 0.9, "")


def frf_input(args) -> LobesInput:
    """The tool-point FRFs and all that goes with them, from --frf or the holder on the machine."""
    from taptune.errors import InputError
    from taptune.machine.band import NO_BAND, band_from_tolerance

    if args.frf_y and not args.frf:
        raise InputError("--frf-y needs --frf (the x FRF)")
    if args.frf:
        extra = [n for n, v in (("ASSEMBLY", args.assembly), ("--holder", args.holder), ("--params", args.params),
                                ("--machine", args.machine), ("--stickout", args.stickout), ("--freq", args.freq))
                 if v is not None]
        if extra:
            raise InputError(f"--frf {args.frf}: the FRF is measured; {', '.join(extra)} belong to the predicted one")
        from taptune.io.machine import read_toolpoint
        from taptune.machine.lobes import MIN_FREQUENCIES

        t = read_toolpoint(args.frf, args.frf_y)
        if t.freq_hz.size < MIN_FREQUENCIES:
            raise InputError(f"{args.frf}: the lobes need at least {MIN_FREQUENCIES} frequencies of the "
                             f"tool-point FRF, got {t.freq_hz.size}")
        warnings = [f"{args.frf}: no y FRF (--frf-y or yy columns); the x FRF is used for y"] if t.y_from_x else []
        band = band_from_tolerance(args.frf_tolerance) if args.frf_tolerance is not None else (0.0, 0.9, NO_BAND)
        return LobesInput(t.freq_hz, t.xx, t.yy, f"measured FRF {t.source}", None, None, warnings,
                          args.flute_length, band)
    if args.frf_tolerance is not None:
        raise InputError("--frf-tolerance belongs to --frf; a predicted FRF carries the holder's own band")
    if not args.assembly:
        raise InputError("lobes needs ASSEMBLY with --holder/--params and --machine, or --frf FILE")
    from taptune.cli.cmd_toolpoint import frequency_grid, machine_inputs, toolpoint_frfs

    assembly, machine, holder, warnings = machine_inputs(args, "lobes")
    stickouts = [args.stickout] if args.stickout is not None else None
    frfs, assemblies = toolpoint_frfs(assembly, machine, holder, frequency_grid(args, machine), stickouts, args.contact)
    frf, used = frfs[0], assemblies[0]
    warnings += [w for w in used.warnings if w not in warnings]
    tool = used.tool
    what = (f"{holder.name} with {tool.name} at {used.stickout * 1e3:g} mm on {machine.name} "
            f"(contact {args.contact})")
    flute = args.flute_length if args.flute_length is not None else (
        tool.flute_length * 1e3 if tool.flute_length is not None else None)
    return LobesInput(frf.freq_hz, frf.xx, frf.yy, what, tool_diameter_mm(used), machine.max_rpm, warnings, flute,
                      holder_band(args, used))


def holder_band(args, assembly) -> tuple:
    """The library holder's prediction band for ``assembly`` (``--params``: none)."""
    from taptune.machine.band import band_from_prediction

    if not args.holder:
        return 0.0, 0.9, f"none (--params {args.params}: a parameter file carries no prediction band)"
    from taptune.library.store import HolderLibrary, default_library_path

    entry = HolderLibrary(default_library_path(args.library)).get(args.holder)
    return band_from_prediction(entry.predict(assembly))


def run(args) -> int:
    from taptune.cli.common import command_inputs, format_table, output_path, write_json
    from taptune.errors import InputError
    from taptune.machine.band import check_confidence, lobes_with_band

    inputs = command_inputs(args)
    for path, what in ((args.json, "JSON"), (args.csv, "CSV"), (args.plot, "plot")):
        output_path(path, what, library=args.library, inputs=inputs)
    check_confidence(args.confidence)
    if args.flute_length is not None and not args.flute_length > 0:
        raise InputError(f"--flute-length must be > 0 mm, got {args.flute_length:g}")
    cut = cut_options(args)  # the whole cut checked before the tool-point FRF is computed
    if args.frf and args.diameter is None:
        raise InputError("--frf needs --diameter MM (the tool diameter)")
    src = frf_input(args)
    diameter = cut.diameter_mm if cut.diameter_mm is not None else src.diameter_mm
    rpm = rpm_grid(cut.rpm, src.freq_hz, src.xx, src.yy, cut.teeth, src.max_rpm)
    cap = src.flute_length_mm * 1e-3 if src.flute_length_mm is not None else float("inf")
    lobes, band = lobes_with_band(src.freq_hz, src.xx, src.yy, teeth=cut.teeth, ktc=cut.ktc, krc=cut.krc,
                                  diameter=diameter * 1e-3, ae=cut.ae_mm * 1e-3, milling=cut.milling, rpm=rpm,
                                  method=args.method, confidence=args.confidence, band=src.band, depth_cap=cap)
    warnings = src.warnings + [w for w in lobes.warnings if w not in src.warnings]
    if src.flute_length_mm is None:
        warnings.append("the tool's flute length is unknown (--flute-length or [tool] flute_length): "
                        "depths are not capped")
    out = lobes_json(lobes, band)
    out.update(source=src.source, cut=cut.to_dict(diameter), warnings=warnings)
    write_json(out, args.json)
    if args.csv:
        write_lobes_csv(args.csv, out)
    if args.json != "-":
        print(f"FRF:  {src.source}\ncut:  {cut.describe(diameter)}")
        print(f"method: {describe_method(lobes)}")
        print(f"band: {band.sources}")
        print(safe_pocket_table(out, format_table))
        crit = "none: no depth chatters" if out["a_crit_mm"] is None else f"{out['a_crit_mm']:.3g} mm"
        print(f"critical depth (stable at every speed): {crit}  [{rpm[0]:g}–{rpm[-1]:g} rpm]"
              + (f"; depth cap (flutes) {out['depth_cap_mm']:g} mm" if out["depth_cap_mm"] is not None else ""))
        rows = [[f"{p['rpm']:.0f}", f"{p['a_lim_mm']:.3g}", _chatter_at(out, p["rpm"]), _kind_at(out, p["rpm"])]
                for p in out["pockets"][:5]]
        print(format_table(rows, ["lobe peak [rpm]", "a_lim [mm]", "chatter [Hz]", "beside"]) if rows
              else "no lobe peaks inside this speed range")
    for w in warnings:
        print(f"warning: {w}", file=sys.stderr)
    if args.plot:
        from taptune.report.machine_plot import plot_lobes

        plot_lobes(lobes.rpm, _mm(out["a_lim_mm"]), out["a_crit_mm"], out["pockets"], args.plot,
                   chatter_hz=lobes.chatter_hz, safe_mm=_mm(out["a_lim_mm_safe"]),
                   band_mm=(band.a_low * 1e3, band.a_high * 1e3) if band.samples > 1 else None,
                   depth_cap_mm=out["depth_cap_mm"], safe_pockets=out["safe_pockets"],
                   title=f"{src.source}\n{cut.teeth} teeth, Ø{diameter:g} mm, ae {cut.ae_mm:g} mm {cut.milling}; "
                         f"{cut.coefficients}; {lobes.method.upper()}")
    return 0


def _mm(values):
    import numpy as np

    return np.array([np.nan if v is None else v for v in values], dtype=float)


def describe_method(lobes) -> str:
    """One line: which method, and how well the modes reproduce the FRFs."""
    if lobes.method == "sdm":
        return "semi-discretization (" + "; ".join(lobes.notes) + ")"
    return "zero-order approximation (the average force; misses the flip lobes of intermittent cuts)"


def lobes_json(lobes, band) -> dict:
    """The ``lobes`` JSON with the band: ``confidence``, ``a_lim_mm_safe``, ``safe_pockets``, ``band_sources``."""
    import numpy as np

    out = lobes.to_dict()
    cap = lobes.depth_cap
    out["confidence"] = band.confidence
    out["a_lim_mm_safe"] = [float(min(a, cap)) * 1e3 if np.isfinite(min(a, cap)) else None for a in band.a_safe]
    out["safe_pockets"] = [p.to_dict() for p in band.safe_pockets]
    out["band_sources"] = band.sources
    out["band_samples"] = band.samples
    out["modal_fit"] = list(lobes.notes)
    return out


def safe_pocket_table(out: dict, format_table) -> str:
    """The safe pockets, best first: speed window, depth, confidence."""
    rows = [[f"{p['rpm_low']:.0f}–{p['rpm_high']:.0f}", f"{p['rpm']:.0f}", f"{p['a_mm']:.3g}",
             f"{100 * out['confidence']:.0f} %"] for p in out["safe_pockets"][:5]]
    if not rows:
        return "no safe pocket inside this speed range"
    return format_table(rows, ["safe pocket [rpm]", "centre [rpm]", "depth [mm]", "stable with"])


def _kind_at(out: dict, rpm: float) -> str:
    i = out["rpm"].index(rpm)
    return out["instability"][i]


def _chatter_at(out: dict, rpm: float) -> str:
    """The chatter frequency on the boundary just beside a pocket (the peak joins two lobes)."""
    i = out["rpm"].index(rpm)
    f = out["chatter_hz"][i]
    return f"{f:.0f}" if f is not None else ""


def write_lobes_csv(path: str, out: dict) -> None:
    """rpm, a_lim_mm, a_lim_mm_safe, chatter_hz, instability per speed (empty where no lobe reaches)."""
    from taptune.errors import InputError
    from taptune.io.atomic import atomic_write_bytes

    def cell(v):
        return "" if v is None else f"{v:.10g}"

    n = len(out["rpm"])
    safe = out.get("a_lim_mm_safe", out["a_lim_mm"])
    kind = out.get("instability", ["hopf"] * n)
    lines = ["rpm,a_lim_mm,a_lim_mm_safe,chatter_hz,instability"]
    lines += [f"{r:.10g},{cell(a)},{cell(s)},{cell(f)},{k}"
              for r, a, s, f, k in zip(out["rpm"], out["a_lim_mm"], safe, out["chatter_hz"], kind)]

    try:
        atomic_write_bytes(path, ("\n".join(lines) + "\n").encode("ascii"))
    except OSError as err:
        raise InputError(f"{path}: cannot write ({err.strerror})") from None
