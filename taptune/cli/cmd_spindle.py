"""``taptune spindle --dummy FILE --aa CSV --ab CSV --bb CSV --points A_MM B_MM --out SPINDLE_CSV [--plot PNG]``.

Inverse receptance coupling (docs/machine.md, "Measuring the spindle"): the spindle's 2×2 receptance
at the coupling plane in one bending direction, from three hammer-test FRFs on a simple
dummy holder in the spindle. Ill-conditioned by nature: noisy FRFs are replaced by a
rational fit first, and the bands where the result cannot be trusted are reported and shaded.
"""

from __future__ import annotations

import sys


def add_parser(sub, name, help_text):
    p = sub.add_parser(name, help=help_text, description=(
        "Spindle receptance at the coupling plane (one bending direction) from three translational "
        "hammer-test FRFs w/f on a dummy holder clamped in the spindle: G_aa, G_ab, G_bb between "
        "points a and b. Writes the spindle file that a machine file names. Run once per direction."))
    p.add_argument("--dummy", required=True, metavar="FILE", help="holder-only TOML of the dummy ([holder] table)")
    for key in ("aa", "ab", "bb"):
        p.add_argument(f"--{key}", required=True, metavar="FRF",
                       help=f"G_{key} [m/N]: CSV f_hz,re,im, CutPro-style .frf text or UFF58 (.uff/.unv)")
    p.add_argument("--points", type=float, nargs=2, required=True, metavar=("A_MM", "B_MM"),
                   help="points a and b as distances from the dummy's front face [mm] (a = 0: its free end)")
    p.add_argument("--out", required=True, metavar="SPINDLE_CSV", help="the spindle receptance file to write (.csv)")
    p.add_argument("--smooth", default="auto", metavar="auto|fit|N",
                   help="what to do with the FRFs before the solve: fit = replace them by a rational fit "
                        "(common poles), N = local quadratic smoothing over 2N+1 points, 0 = nothing; "
                        "auto (default) fits only noisy FRFs")
    p.add_argument("--json", metavar="OUT", help="write a summary (trusted bands, warnings) as JSON ('-' for stdout)")
    p.add_argument("--plot", metavar="PNG", help="write a picture of the three receptance terms")
    return p


def read_measurements(args):
    """(freq_hz, g_aa, g_ab, g_bb) from the three files, which must share one frequency grid."""
    import numpy as np

    from taptune.errors import InputError
    from taptune.io.machine import read_frf

    frfs = [read_frf(path) for path in (args.aa, args.ab, args.bb)]
    ref = frfs[0]
    for other in frfs[1:]:
        same = other.freq_hz.shape == ref.freq_hz.shape and np.allclose(other.freq_hz, ref.freq_hz, rtol=1e-9, atol=0)
        if not same:
            raise InputError(
                f"{other.source}: its frequency grid ({len(other.freq_hz)} points, {other.freq_hz[0]:g}–"
                f"{other.freq_hz[-1]:g} Hz) differs from {ref.source}'s ({len(ref.freq_hz)} points, "
                f"{ref.freq_hz[0]:g}–{ref.freq_hz[-1]:g} Hz); export the three FRFs on one grid")
    names = ("--aa", "--ab", "--bb")
    for i in range(3):
        for j in range(i):
            if np.array_equal(frfs[i].h, frfs[j].h):  # one file given twice, or a copy of it
                raise InputError(f"{frfs[i].source}: {names[i]} holds the same FRF as {names[j]} "
                                 f"({frfs[j].source}); G_aa, G_ab and G_bb are three measurements (hammer at a, "
                                 f"accelerometer at a; hammer at a, accelerometer at b; both at b)")
    return ref.freq_hz, frfs[0].h, frfs[1].h, frfs[2].h


def smoothing(value: str):
    from taptune.errors import InputError

    if value in ("auto", "fit"):
        return value
    try:
        n = int(value)
    except ValueError:
        n = -1
    if n < 0:
        raise InputError(f"--smooth must be 'auto', 'fit' or a whole number >= 0, got {value!r}")
    return n


def untrusted_bands(freq_hz, trusted) -> list[tuple[float, float]]:
    """Contiguous frequency bands [Hz] where ``trusted`` is False."""
    import numpy as np

    idx = np.flatnonzero(~np.asarray(trusted))
    if idx.size == 0:
        return []
    runs = np.split(idx, np.flatnonzero(np.diff(idx) > 1) + 1)
    return [(float(freq_hz[r[0]]), float(freq_hz[r[-1]])) for r in runs]


def run(args) -> int:
    from pathlib import Path

    from taptune.cli.common import command_inputs, output_path, write_json
    from taptune.errors import InputError
    from taptune.io.assembly import load_holder
    from taptune.io.machine import write_spindle_csv
    from taptune.machine import spindle_from_dummy

    if Path(args.out).suffix.lower() != ".csv":
        raise InputError(f"--out {args.out}: the spindle receptance is written as CSV; name the file .csv")
    inputs = command_inputs(args)
    for path, what in ((args.out, "spindle receptance"), (args.json, "JSON"), (args.plot, "plot")):
        output_path(path, what, inputs=inputs)
    smooth = smoothing(args.smooth)
    dummy = load_holder(args.dummy)
    freq, g_aa, g_ab, g_bb = read_measurements(args)
    a_mm, b_mm = args.points
    spindle, warnings, fit = spindle_from_dummy(dummy, a_mm * 1e-3, b_mm * 1e-3, freq, g_aa, g_ab, g_bb,
                                                smooth=smooth, source=args.out, return_fit=True)
    bands = untrusted_bands(freq, fit.trusted)
    comments = [
        f"spindle receptance at the coupling plane by inverse RCSA (taptune spindle) from dummy {dummy.name} ({args.dummy})",
        f"G_aa {args.aa}, G_ab {args.ab}, G_bb {args.bb}; points a = {a_mm:g} mm, b = {b_mm:g} mm from the dummy's front face",
        "m/N, 1/N, rad/(N m); theta = dw/dz, z toward the tool",
    ] + [f"not trustworthy: {lo:g}-{hi:g} Hz" for lo, hi in bands]
    write_spindle_csv(args.out, spindle, comments)
    trusted_share = float(fit.trusted.mean())
    summary = {"out": args.out, "dummy": dummy.name, "points_mm": [a_mm, b_mm], "points": len(freq),
               "frequency_range_hz": [float(freq[0]), float(freq[-1])], "trusted_share": trusted_share,
               "untrusted_hz": [list(b) for b in bands], "max_condition_number": float(fit.cond.max()),
               "warnings": warnings}
    write_json(summary, args.json)
    if args.json != "-":
        h0 = spindle.h[0]
        print(f"dummy:  {dummy.name}, points a = {a_mm:g} mm, b = {b_mm:g} mm\n"
              f"FRFs:   {len(freq)} frequencies, {freq[0]:g}–{freq[-1]:g} Hz\n"
              f"wrote:  {args.out}\n"
              f"static: h_wf {abs(h0[0, 0]):.3g} m/N, h_wm {abs(h0[0, 1]):.3g} 1/N, h_θm {abs(h0[1, 1]):.3g} rad/(N·m) "
              f"at {freq[0]:g} Hz\n"
              f"trusted at {100 * trusted_share:.1f} % of the frequencies (condition number ≤ {fit.cond.max():.3g})")
    for w in warnings:
        print(f"warning: {w}", file=sys.stderr)
    if args.plot:
        from taptune.report.machine_plot import plot_spindle

        plot_spindle(freq, spindle.h, args.plot, fit.trusted, title=f"spindle receptance from dummy {dummy.name}")
    return 0
