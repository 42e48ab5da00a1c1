"""``taptune toolpoint ASSEMBLY (--holder NAME | --params JSON) --machine MACHINE.toml [...]``.

The tool-point FRF on the machine (docs/machine.md): the holder's free-free
model with the library's or the given parameters, cut at the coupling plane and rigidly
coupled to the measured spindle receptance. The helpers here (arguments, the frequency
grid, the holder and machine inputs) are shared with ``taptune lobes``.
"""

from __future__ import annotations

import sys
from dataclasses import dataclass

CONTACTS = ("distributed", "rigid", "lumped")
DEFAULT_STEP_HZ = 2.0
DEFAULT_F_MIN_HZ = 50.0
DEFAULT_F_MAX_HZ = 20000.0


def add_parser(sub, name, help_text):
    p = sub.add_parser(name, help=help_text, description=(
        "Tool-point FRF on the machine: the holder's free-free model (library holder or a "
        "parameter file) with the assembly's tool, cut at the coupling plane and rigidly coupled "
        "to the spindle receptance of the machine file, in x and y. Prints the dominant modes."))
    p.add_argument("assembly", help="assembly TOML with the tool (and the holder as clamped on it)")
    add_holder_args(p)
    p.add_argument("--stickout", type=float, nargs="+", action="extend", metavar="MM", help="stick-out(s) [mm]")
    add_model_args(p)
    p.add_argument("--json", metavar="OUT", help="write the FRFs and modes as JSON ('-' for stdout)")
    p.add_argument("--csv", metavar="OUT", help="write f_hz,xx_re,xx_im,yy_re,yy_im (the file 'taptune lobes --frf' "
                                                "reads); with several stick-outs one file each, OUT_<mm>mm.csv")
    p.add_argument("--uff", metavar="OUT", help="write the FRFs as a universal file (UFF58, x and y per stick-out)")
    p.add_argument("--plot", metavar="PNG", help="write a picture of the FRFs")
    return p


def add_holder_args(p) -> None:
    """--holder / --params / --library (one of the first two is needed; checked in machine_inputs)."""
    source = p.add_mutually_exclusive_group()
    source.add_argument("--holder", metavar="NAME", help="library holder whose identified parameters to use")
    source.add_argument("--params", metavar="JSON",
                        help="JSON with k_tt, k_rr, eta_tt, eta_rr, alpha, density_factor, modulus_factor "
                             "(or an identify result with a 'params' object)")
    p.add_argument("--library", metavar="PATH", help="holder library file (for --holder; only read)")


def add_model_args(p) -> None:
    """--machine, --freq and --contact."""
    p.add_argument("--machine", metavar="MACHINE_TOML", help="machine file with the spindle receptance files")
    p.add_argument("--freq", type=float, nargs=3, metavar=("START", "STOP", "STEP"),
                   help=f"frequency grid [Hz], STOP included when on the grid (default: the spindle files' "
                        f"band within {DEFAULT_F_MIN_HZ:g}–{DEFAULT_F_MAX_HZ:g} Hz, step {DEFAULT_STEP_HZ:g} Hz)")
    p.add_argument("--contact", choices=CONTACTS, default="distributed",
                   help="tool-holder contact of the model: the identified distributed layer (default), "
                        "rigid, or lumped front-face springs of the same total stiffness (to compare)")


@dataclass(frozen=True)
class HolderInput:
    """What the holder model runs with: parameters, model options, holder name, where they came from."""

    params: object
    options: object
    name: str
    source: str


def holder_input(args, assembly) -> HolderInput:
    """The holder's parameters from ``--holder`` (library, only read) or ``--params``."""
    from taptune.cli.cmd_model import holder_params

    params, options, source = holder_params(args)
    # Library names are exact (HolderLibrary.get), so --holder is the entry's name.
    return HolderInput(params, options, args.holder or assembly.holder.name, source)


def frequency_grid(args, machine):
    """``--freq`` (checked against the spindle files' band) or the default grid in their band."""
    import numpy as np

    from taptune.errors import InputError
    from taptune.library.exchange import frequency_grid as uniform_grid

    lo = max(float(machine.x.freq_hz[0]), float(machine.y.freq_hz[0]))
    hi = min(float(machine.x.freq_hz[-1]), float(machine.y.freq_hz[-1]))
    if args.freq:
        start, stop, step = args.freq
        f = uniform_grid(start, stop, step)
        if f[0] < lo * (1 - 1e-9) or f[-1] > hi * (1 + 1e-9):
            raise InputError(f"--freq {start:g} {stop:g} {step:g}: the machine's spindle files {machine.source} "
                             f"cover {lo:g}–{hi:g} Hz; choose a grid inside")
        return f
    step = DEFAULT_STEP_HZ
    start = step * np.ceil(max(lo, DEFAULT_F_MIN_HZ) / step)
    return uniform_grid(start, min(hi, DEFAULT_F_MAX_HZ), step)


def machine_inputs(args, what: str):
    """(assembly, machine, HolderInput, warnings) for a command on ASSEMBLY --machine with --holder/--params."""
    from taptune.errors import InputError
    from taptune.io.assembly import load_assembly
    from taptune.io.machine import load_machine
    from taptune.machine.plane import plane_warning, same_interface

    if not (args.holder or args.params):
        raise InputError(f"{what}: give --holder NAME (a library holder) or --params JSON for the holder model")
    if not args.machine:
        raise InputError(f"{what} on the machine needs --machine MACHINE_TOML (the spindle receptance)")
    assembly = load_assembly(args.assembly)
    machine = load_machine(args.machine)
    holder = holder_input(args, assembly)
    warnings = list(assembly.warnings)
    if args.holder and assembly.holder.name != holder.name:
        warnings.append(f"{args.assembly}: its holder is '{assembly.holder.name}', using the contact of library "
                        f"holder '{holder.name}'")
    if not same_interface(machine.interface, assembly.holder.interface):
        warnings.append(f"{args.machine}: interface {machine.interface!r} differs from the holder's "
                        f"{assembly.holder.interface!r} ({args.assembly})")
    if machine.y_from_x:
        warnings.append(f"{args.machine}: no [spindle] y; the x receptance is used for y")
    if plane := plane_warning(assembly.holder, args.assembly):
        warnings.append(plane)
    return assembly, machine, holder, warnings


def toolpoint_frfs(assembly, machine, holder: HolderInput, freq_hz, stickouts_mm=None, contact="distributed"):
    """One :class:`taptune.machine.ToolpointFRF` per stick-out (the assembly's when none given)."""
    from taptune.machine import toolpoint_frf

    assemblies = [assembly] if not stickouts_mm else [assembly.with_stickout(s * 1e-3) for s in stickouts_mm]
    spindle = {"x": machine.x, "y": machine.y}
    frfs = [toolpoint_frf(a, holder.params, spindle, freq_hz, holder.options, contact=contact) for a in assemblies]
    return frfs, assemblies


def csv_paths(out: str, stickouts_mm) -> list[str]:
    """``out`` for one stick-out; ``<stem>_<mm>mm<suffix>`` for each of several."""
    from pathlib import Path

    if len(stickouts_mm) == 1:
        return [out]
    p = Path(out)
    return [str(p.with_name(f"{p.stem}_{s:g}mm{p.suffix or '.csv'}")) for s in stickouts_mm]


def write_uff(path: str, frfs, holder_name: str) -> None:
    """x and y of every stick-out as UFF58 datasets (the library exporter's receptance sets)."""
    from taptune.errors import InputError
    from taptune.library.exchange import _pyuff, uff58_dataset
    from taptune.io.atomic import atomic_write

    sets = []
    for frf in frfs:
        for direction, g, code in (("x", frf.xx, 1), ("y", frf.yy, 2)):
            label = f"{holder_name}, stick-out {frf.stickout * 1e3:g} mm, {direction}"
            s = uff58_dataset(frf.freq_hz, g, label, f"tool-point FRF G_{direction}{direction} on the machine [m/N]")
            s.update(rsp_dir=code, ref_dir=code)
            sets.append(s)
    pyuff = _pyuff()
    try:
        # pyuff writes dataset 58 correctly only with mode="add" into an empty file (ENV-NOTES.md).
        atomic_write(path, lambda tmp: pyuff.UFF(str(tmp)).write_sets(sets, mode="add"))
    except OSError as err:
        raise InputError(f"{path}: cannot write ({err.strerror or err})") from None


def mode_rows(frf) -> list[list[str]]:
    """Table rows of the dominant modes of one stick-out."""
    rows = []
    for m in sorted(frf.modes, key=lambda m: (m.hz, m.direction)):
        rows.append([f"{frf.stickout * 1e3:g}", f"{m.hz:.0f}", f"{100 * m.damping_ratio:.2f}", m.direction,
                     f"{m.magnitude * 1e6:.3g}"])
    return rows


def run(args) -> int:
    from taptune.cli.common import command_inputs, format_table, output_path, write_json
    from taptune.io.machine import write_toolpoint_csv

    inputs = command_inputs(args)
    for path, what in ((args.json, "JSON"), (args.csv, "CSV"), (args.uff, "universal file"), (args.plot, "plot")):
        output_path(path, what, library=args.library, inputs=inputs)
    assembly, machine, holder, warnings = machine_inputs(args, "toolpoint")
    freq = frequency_grid(args, machine)
    frfs, assemblies = toolpoint_frfs(assembly, machine, holder, freq, args.stickout, args.contact)
    warnings = list(dict.fromkeys(warnings + [w for a in assemblies for w in a.warnings]))
    out = {"holder": holder.name, "machine": machine.name, "assembly": args.assembly, "tool": assembly.tool.name,
           "params_source": holder.source, "contact": args.contact,
           "predictions": [f.to_dict() for f in frfs], "warnings": warnings}
    write_json(out, args.json)
    stickouts = [f.stickout * 1e3 for f in frfs]
    if args.csv:
        for path, frf in zip(csv_paths(args.csv, stickouts), frfs):
            write_toolpoint_csv(path, frf.freq_hz, frf.xx, frf.yy, comments=[
                f"tool-point FRF on {machine.name}: {holder.name}, {assembly.tool.name}, "
                f"stick-out {frf.stickout * 1e3:g} mm, contact {frf.contact} (taptune toolpoint)"])
    if args.uff:
        write_uff(args.uff, frfs, holder.name)
    if args.json != "-":
        print(f"holder:  {holder.name} ({holder.source})\ntool:    {assembly.tool.name}\n"
              f"machine: {machine.name}\ncoupling plane: {frfs[0].coupling_plane * 1e3:g} mm from the holder's "
              f"spindle-side end; contact: {args.contact}; {freq[0]:g}–{freq[-1]:g} Hz")
        rows = [r for f in frfs for r in mode_rows(f)]
        print(format_table(rows, ["stick-out [mm]", "mode [Hz]", "ζ [%]", "dir", "|G| [µm/N]"]))
    for w in warnings:
        print(f"warning: {w}", file=sys.stderr)
    if args.plot:
        from taptune.report.machine_plot import plot_toolpoint

        curves = [(f"{f.stickout * 1e3:g} mm", f.freq_hz, f.xx, f.yy) for f in frfs]
        plot_toolpoint(curves, args.plot, f"{holder.name} on {machine.name}\n{assembly.tool.name}, contact {args.contact}")
    return 0
