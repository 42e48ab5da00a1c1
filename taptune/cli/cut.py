"""The milling cut on the command line, shared by ``taptune lobes`` and ``taptune batch --machine``.

:func:`add_cut_args` adds --teeth, --material or --ktc/--krc, --diameter, --ae,
--milling and --rpm; :func:`cut_options` checks them into a :class:`CutOptions`
(SI for the coefficients, mm at this boundary) before any long work;
:func:`rpm_grid` is the spindle-speed grid of a lobe diagram.
"""

from __future__ import annotations

from dataclasses import dataclass

DEFAULT_MIN_RPM = 500.0
DEFAULT_STEP_RPM = 10.0
# Without a machine top speed, the diagram reaches a little beyond the k = 0 lobe's peak
# 60 f_c / N, which is the highest pocket a cut can have.
TOP_POCKET_MARGIN = 1.2
# The options of the cut, as argparse destinations, with the flag a message names.
# Plausible ranges: beyond them a number is a typo or a unit mistake (µm for mm, Pa for
# MPa), refused rather than turned into a lobe diagram. The largest face mills are ~500 mm;
# hardened steels and titanium stay below 10 000 MPa of K_tc.
MAX_TEETH = 200
MAX_DIAMETER_MM = 1000.0
MAX_COEFFICIENT_MPA = 20000.0
CUT_FLAGS = {"teeth": "--teeth", "ktc": "--ktc", "krc": "--krc", "material": "--material",
             "diameter": "--diameter", "ae": "--ae", "milling": "--milling", "rpm": "--rpm"}


def add_cut_args(p, group, required: bool = True, diameter_note: str = "") -> None:
    """The cut options: --teeth, --ktc/--krc or --material, --diameter, --ae, --milling into ``group``;
    --rpm into the parser ``p``. ``required`` makes argparse demand --teeth, --ae and --milling."""
    from taptune.machine.materials import MATERIALS

    group.add_argument("--teeth", type=int, required=required, metavar="N", help="number of teeth (flutes)")
    group.add_argument("--ktc", type=float, metavar="MPA", help="tangential cutting-force coefficient K_tc [MPa = N/mm²]")
    group.add_argument("--krc", type=float, metavar="MPA", help="radial cutting-force coefficient K_rc [MPa]")
    group.add_argument("--material", metavar="NAME", help=f"work material instead of --ktc/--krc: {', '.join(MATERIALS)}")
    group.add_argument("--diameter", type=float, metavar="MM",
                       help=f"tool diameter [mm] (default: the assembly's flute diameter{diameter_note})")
    group.add_argument("--ae", type=float, required=required, metavar="MM",
                       help="radial depth of cut [mm]; = diameter is slotting")
    group.add_argument("--milling", choices=("up", "down"), required=required, help="up- or down-milling")
    p.add_argument("--rpm", type=float, nargs=3, metavar=("MIN", "MAX", "STEP"),
                   help=f"spindle-speed grid [rpm], MAX included when on the grid (default: {DEFAULT_MIN_RPM:g} rpm "
                        f"to the machine's max_rpm, or just past the highest pocket, step {DEFAULT_STEP_RPM:g})")


@dataclass(frozen=True)
class CutOptions:
    """A milling cut: teeth, cutting coefficients [N/m²], tool diameter and radial depth [mm], direction.

    ``diameter_mm`` None means the tool's own (:func:`tool_diameter_mm`); ``rpm`` is the
    ``--rpm`` triple or None for :func:`rpm_grid`'s default; ``coefficients`` describes
    where K_tc and K_rc came from, for people.
    """

    teeth: int
    ktc: float
    krc: float
    ae_mm: float
    milling: str
    diameter_mm: float | None = None
    material: str | None = None
    rpm: tuple[float, float, float] | None = None
    coefficients: str = ""

    def to_dict(self, diameter_mm: float | None = None) -> dict:
        """The cut as ``taptune lobes`` writes it in its JSON (mm, MPa)."""
        return {"teeth": self.teeth, "ktc_mpa": self.ktc / 1e6, "krc_mpa": self.krc / 1e6,
                "diameter_mm": self.diameter_mm if diameter_mm is None else diameter_mm,
                "ae_mm": self.ae_mm, "milling": self.milling, "material": self.material}

    def describe(self, diameter_mm: float) -> str:
        """One line: teeth, diameter, slotting or up/down with ae, coefficients."""
        kind = ("slotting" if self.ae_mm >= diameter_mm * (1 - 1e-9)
                else f"{self.milling}-milling, ae {self.ae_mm:g} mm")
        return f"{self.teeth} teeth, Ø{diameter_mm:g} mm, {kind}; {self.coefficients}"


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


def cut_options(args) -> CutOptions:
    """The checked cut of ``args`` (InputError naming the option); nothing is computed yet."""
    from taptune.errors import InputError

    missing = [CUT_FLAGS[k] for k in ("teeth", "ae", "milling") if getattr(args, k, None) is None]
    if missing:
        raise InputError(f"the cut needs {', '.join(missing)}")
    if not 1 <= args.teeth <= MAX_TEETH:
        raise InputError(f"--teeth must lie in 1…{MAX_TEETH}, got {args.teeth}")
    ktc, krc, coefficients = cutting_coefficients(args)
    for flag, value in (("--ktc", args.ktc), ("--krc", args.krc)):
        if value is not None and not (0 <= value <= MAX_COEFFICIENT_MPA):
            raise InputError(f"{flag} must lie in 0…{MAX_COEFFICIENT_MPA:g} MPa (N/mm², not Pa), got {value:g}")
    if not 0 < args.ae <= MAX_DIAMETER_MM:
        raise InputError(f"--ae must be > 0 mm (and at most {MAX_DIAMETER_MM:g}), got {args.ae:g}")
    if args.diameter is not None:
        if not 0 < args.diameter <= MAX_DIAMETER_MM:
            raise InputError(f"--diameter must be > 0 mm and at most {MAX_DIAMETER_MM:g} mm, got {args.diameter:g}")
        if args.ae > args.diameter * (1 + 1e-9):
            raise InputError(f"--ae {args.ae:g} mm exceeds the tool diameter {args.diameter:g} mm")
    rpm = tuple(args.rpm) if getattr(args, "rpm", None) else None
    if rpm is not None:
        rpm_grid(rpm, None, None, None, args.teeth, None)  # a bad grid is bad input now, not after the fit
    return CutOptions(args.teeth, ktc, krc, args.ae, args.milling, args.diameter, args.material, rpm, coefficients)


def given_cut_flags(args) -> list[str]:
    """The cut options given on the command line (for 'these need --machine')."""
    return [flag for key, flag in CUT_FLAGS.items() if getattr(args, key, None) is not None]


def tool_diameter_mm(assembly) -> float:
    """The tool's cutting diameter [mm]: its flute diameter, else its last segment's."""
    tool = assembly.tool
    return (tool.flute_diameter or tool.segments[-1].od) * 1e3


def rpm_grid(rpm, freq_hz, gxx, gyy, teeth: int, max_rpm: float | None):
    """The spindle speeds [rpm]: the ``rpm`` triple (MIN, MAX, STEP), or from 500 rpm to the
    machine's top speed ``max_rpm``, else just past the highest pocket 60 f/N of the
    strongest mode of the FRFs ``gxx``, ``gyy`` on ``freq_hz``."""
    import numpy as np

    from taptune.errors import InputError
    from taptune.library.exchange import frequency_grid as uniform_grid
    from taptune.machine import dominant_modes

    if rpm:
        lo, hi, step = rpm
        try:
            return uniform_grid(lo, hi, step)
        except InputError as err:
            ordered = 0 < lo < hi and step > 0 and np.isfinite(rpm).all()
            # The grid's own message for an ordered but too fine grid; the bounds in rpm words otherwise.
            why = str(err).replace("frequency grid", "speed grid") if ordered else "needs 0 < MIN < MAX and STEP > 0 (rpm)"
            raise InputError(f"--rpm {lo:g} {hi:g} {step:g}: {why}") from None
    if max_rpm is None:
        modes = dominant_modes(freq_hz, gxx, "x") + dominant_modes(freq_hz, gyy, "y")
        f_top = max(modes, key=lambda m: m.magnitude).hz if modes else float(freq_hz[np.argmax(np.abs(gxx))])
        max_rpm = 1000.0 * np.ceil(TOP_POCKET_MARGIN * 60.0 * f_top / teeth / 1000.0)
    return uniform_grid(min(DEFAULT_MIN_RPM, 0.5 * max_rpm), max_rpm, DEFAULT_STEP_RPM)
