"""Assembly files (TOML, mm at the boundary) and the SI geometry they describe.

An assembly is one tool clamped in one holder at one stick-out (docs/assembly-format.md).
:func:`load_assembly` parses and validates a file; every malformed or impossible file
raises :class:`~taptune.errors.InputError` naming the file, the key and the problem.
Inside, everything is SI (m, Pa, kg/m³); :func:`assembly_to_toml` writes mm again.

Axial coordinate z [m]: 0 at the spindle-side end of the holder, the holder front face
at ``holder.length``, the tool tip at ``holder.length + stickout``.
"""

from __future__ import annotations

import difflib
import math
import tomllib
from dataclasses import dataclass, field, replace
from pathlib import Path

from taptune.errors import InputError
from taptune.io.files import read_text

MM = 1e-3
GPA = 1e9
# Geometry comparisons (fits, equal lengths) are made to this tolerance [m].
TOL_M = 1e-8
# Plausible ranges: beyond them a number is a unit mistake (µm or m for mm, Pa for GPa) or
# a typo, refused before the model meshes it (a 10 km segment hung the model for minutes).
MAX_LENGTH_M = 2.0          # no tool or holder is longer than 2 m
MAX_DIAMETER_M = 1.0        # nor thicker than 1 m
MIN_DIAMETER_M = 10e-6      # nor thinner than 10 µm (the finest micro tools)
MIN_BODY_LENGTH_M = 10e-3   # nor a whole tool or holder shorter than 10 mm (below: metres for mm)
MIN_STICKOUT_M = 1e-3       # a tap needs at least 1 mm of tool out of the holder
NAME_MAX_LEN = 200          # holder, interface and tool names: one line, as the library keeps them
DENSITY_RANGE = (100.0, 30000.0)        # kg/m³: foams … tungsten heavy metal
MODULUS_RANGE_PA = (0.1e9, 1500e9)      # Pa: polymers … diamond


@dataclass(frozen=True)
class Material:
    """Isotropic material: density [kg/m³], Young's modulus [Pa], Poisson ratio, loss factor."""

    density: float
    youngs_modulus: float
    poisson: float
    loss_factor: float


STEEL = Material(density=7800.0, youngs_modulus=210e9, poisson=0.29, loss_factor=0.003)
CARBIDE = Material(density=15600.0, youngs_modulus=580e9, poisson=0.22, loss_factor=0.002)


@dataclass(frozen=True)
class Segment:
    """A coaxial cylinder: length, outer and inner diameter [m] (inner 0 = solid)."""

    length: float
    od: float
    id: float = 0.0


@dataclass(frozen=True)
class Holder:
    """Tool holder: segments from the spindle-side end (z = 0) to the front face.

    ``gauge_length`` [m] (optional) is the distance from the front face back to the
    coupling plane where the holder meets the spindle (docs/machine.md); ``None`` lets the
    interface decide (:func:`taptune.machine.coupling_plane`).
    """

    name: str
    interface: str
    clamp_length: float
    segments: tuple[Segment, ...]
    material: Material = STEEL
    gauge_length: float | None = None

    @property
    def length(self) -> float:
        """Holder length L_h [m] (z of the front face)."""
        return float(sum(s.length for s in self.segments))

    def breakpoints(self) -> list[float]:
        """z of every segment boundary, 0 … L_h [m]."""
        z = [0.0]
        for s in self.segments:
            z.append(z[-1] + s.length)
        return z


@dataclass(frozen=True)
class Tool:
    """Solid tool: segments from the shank (back) end to the tip [m].

    ``shank_diameter``/``flute_*`` are kept when the file gave them (for display and for
    re-writing the file); the model only uses ``segments``.
    """

    name: str
    total_length: float
    segments: tuple[Segment, ...]
    material: Material = CARBIDE
    shank_diameter: float | None = None
    flute_length: float | None = None
    flute_diameter: float | None = None
    flute_ratio: float | None = None


@dataclass(frozen=True)
class Tolerances:
    """How well the user knows the geometry (optional assembly keys; used by the prediction bands).

    stickout : float
        ± stick-out [m] (``[setup] stickout_tolerance`` in mm; default 0.3 mm, a ruler).
    diameter : float
        ± relative holder outer diameters (``[holder] diameter_tolerance`` in %; default
        1 %, measured roughly or taken from a catalogue drawing).
    flute_ratio : float
        ± flute ratio (``[tool] flute_ratio_tolerance``; default 0.05: the fluted part's
        equivalent diameter is rarely known better).
    """

    stickout: float = 0.3e-3
    diameter: float = 0.01
    flute_ratio: float = 0.05

    def to_dict(self) -> dict:
        return {"stickout_mm": round(self.stickout / MM, 6), "diameter_percent": round(100 * self.diameter, 6),
                "flute_ratio": round(self.flute_ratio, 6)}


@dataclass(frozen=True)
class Assembly:
    """One tool in one holder at one stick-out [m]. ``source`` names the file for messages."""

    holder: Holder
    tool: Tool
    stickout: float
    source: str = "<assembly>"
    warnings: tuple[str, ...] = field(default=(), compare=False)
    tolerances: Tolerances = field(default=Tolerances(), compare=False)
    #: Warnings about the file itself (unknown, probably misspelt keys), kept in
    #: ``warnings`` whatever stick-out or holder the assembly is later given.
    file_warnings: tuple[str, ...] = field(default=(), compare=False)

    @property
    def inserted_length(self) -> float:
        """L_in = L_tool − stickout [m]."""
        return self.tool.total_length - self.stickout

    @property
    def contact_length(self) -> float:
        """L_c = min(L_in, clamp_length) [m]."""
        return min(self.inserted_length, self.holder.clamp_length)

    @property
    def z_contact_start(self) -> float:
        """z_c0 = L_h − L_c, the deep (spindle-side) end of the contact zone [m]."""
        return self.holder.length - self.contact_length

    @property
    def z_tool_start(self) -> float:
        """z of the tool's back end [m]."""
        return self.holder.length - self.inserted_length

    @property
    def z_tip(self) -> float:
        """z of the tool tip [m]."""
        return self.holder.length + self.stickout

    @property
    def total_mass(self) -> float:
        """Mass of holder plus tool with nominal densities [kg]."""
        def mass(segments, rho):
            return sum(rho * math.pi / 4 * (s.od**2 - s.id**2) * s.length for s in segments)

        return mass(self.holder.segments, self.holder.material.density) + mass(
            self.tool.segments, self.tool.material.density
        )

    def with_stickout(self, stickout: float) -> "Assembly":
        """The same holder and tool at another stick-out [m], validated."""
        return validate(replace(self, stickout=float(stickout), warnings=()))

    def with_holder(self, holder: Holder) -> "Assembly":
        """The same tool and stick-out in another holder, validated."""
        return validate(replace(self, holder=holder, warnings=()))

    def tool_diameter_at(self, z: float) -> float:
        """Outer diameter of the tool at axial position z [m] (0 outside the tool)."""
        zz = self.z_tool_start
        for s in self.tool.segments:
            if zz - TOL_M <= z <= zz + s.length + TOL_M:
                return s.od
            zz += s.length
        return 0.0


def _check_material(m: Material, key: str, fail) -> None:
    """Raise through ``fail(key, problem)`` when a material value is impossible."""
    if not (m.density > 0 and math.isfinite(m.density)):
        fail(f"{key}.density", f"must be > 0 kg/m³, got {m.density:g}")
    if not (m.youngs_modulus > 0 and math.isfinite(m.youngs_modulus)):
        fail(f"{key}.youngs_modulus", f"must be > 0 GPa, got {m.youngs_modulus / GPA:g}")
    lo, hi = DENSITY_RANGE
    if not lo <= m.density <= hi:
        fail(f"{key}.density", f"must lie in {lo:g}…{hi:g} kg/m³ (steel 7800, carbide 15600), got {m.density:g}")
    lo, hi = MODULUS_RANGE_PA
    if not lo <= m.youngs_modulus <= hi:
        fail(f"{key}.youngs_modulus", f"must lie in {lo / GPA:g}…{hi / GPA:g} GPa (steel 210, carbide 580; "
             f"in GPa, not Pa), got {m.youngs_modulus / GPA:g}")
    # Holder steels and carbide lie near 0.2-0.3; negative ratios (auxetic foams) are no
    # tool material, and near -1 they break the shear coefficient of docs/physics.md §1.
    if not (0.0 <= m.poisson < 0.5):
        fail(f"{key}.poisson", f"must lie in [0, 0.5), got {m.poisson:g}")
    if not (0 <= m.loss_factor < 1):
        fail(f"{key}.loss_factor", f"must lie in [0, 1), got {m.loss_factor:g}")


def _check_segments(segs, label: str, fail) -> None:
    for i, s in enumerate(segs, 1):
        for name, value, top in (("length", s.length, MAX_LENGTH_M), ("od", s.od, MAX_DIAMETER_M)):
            if not (math.isfinite(value) and value > 0):
                fail(f"{label}[{i}].{name}", f"must be > 0 mm, got {value / MM:g}")
            if value > top:
                fail(f"{label}[{i}].{name}", f"({value / MM:g} mm) is implausible: above {top / MM:g} mm "
                     "(lengths are in mm, not µm)")
        if s.od < MIN_DIAMETER_M:
            fail(f"{label}[{i}].od", f"({s.od / MM:g} mm) is implausible: below {MIN_DIAMETER_M / MM:g} mm "
                 "(diameters are in mm, not m)")
        if not (math.isfinite(s.id) and s.id >= 0):
            fail(f"{label}[{i}].id", f"must be >= 0 mm, got {s.id / MM:g}")
        if s.id >= s.od:
            fail(f"{label}[{i}].id", f"must be smaller than od ({s.od / MM:g} mm), got {s.id / MM:g}")


def validate_holder(h: Holder, src: str) -> Holder:
    """Check a holder's own geometry (segments, clamp and gauge length, material).

    Raises InputError naming ``src`` on an impossible value; returns ``h`` unchanged.
    """

    def fail(key: str, problem: str):
        raise InputError(f"{src}: {key} {problem}")

    if not h.segments:
        fail("[holder] segments", "must list at least one segment")
    _check_segments(h.segments, "[holder] segments", fail)
    if not (math.isfinite(h.clamp_length) and h.clamp_length > 0):
        fail("[holder] clamp_length", f"must be > 0 mm, got {h.clamp_length / MM:g}")
    if h.clamp_length > h.length + TOL_M:
        fail("[holder] clamp_length", f"({h.clamp_length / MM:g} mm) is longer than the holder ({h.length / MM:g} mm)")
    g = h.gauge_length
    if g is not None:
        if not (math.isfinite(g) and g > 0):
            fail("[holder] gauge_length", f"must be > 0 mm, got {g / MM:g}")
        if g > h.length + TOL_M:
            fail("[holder] gauge_length", f"({g / MM:g} mm) is longer than the holder ({h.length / MM:g} mm)")
    _check_material(h.material, "[holder] material", fail)
    if h.length > MAX_LENGTH_M:
        fail("[holder] segments", f"add up to {h.length / MM:g} mm: implausible, above {MAX_LENGTH_M / MM:g} mm")
    if h.length < MIN_BODY_LENGTH_M:
        fail("[holder] segments", f"add up to {h.length / MM:g} mm: implausible, below {MIN_BODY_LENGTH_M / MM:g} mm "
                                  f"(lengths are in millimetres; this looks like metres)")
    return h


def validate(asm: Assembly) -> Assembly:
    """Check the geometry rules of docs/assembly-format.md (where things are).

    Returns the assembly with its ``warnings`` filled in; raises InputError on an
    impossible geometry.
    """
    src = asm.source
    h, t = asm.holder, asm.tool

    def fail(key: str, problem: str):
        raise InputError(f"{src}: {key} {problem}")

    validate_holder(h, src)
    _check_segments(t.segments, "[tool] segments", fail)
    for key, value in (
        ("[tool] total_length", t.total_length),
        ("[setup] stickout", asm.stickout),
    ):
        if not (math.isfinite(value) and value > 0):
            fail(key, f"must be > 0 mm, got {value / MM:g}")
    if t.total_length > MAX_LENGTH_M:
        fail("[tool] total_length", f"({t.total_length / MM:g} mm) is implausible: above {MAX_LENGTH_M / MM:g} mm")
    if t.total_length < MIN_BODY_LENGTH_M:
        fail("[tool] total_length", f"({t.total_length / MM:g} mm) is implausible: below {MIN_BODY_LENGTH_M / MM:g} mm "
                                    f"(lengths are in millimetres; this looks like metres)")
    if asm.stickout < MIN_STICKOUT_M:
        fail("[setup] stickout", f"({asm.stickout / MM:g} mm) is implausible: below {MIN_STICKOUT_M / MM:g} mm "
                                 f"(lengths are in millimetres)")
    _check_material(t.material, "[tool] material", fail)
    seg_sum = sum(s.length for s in t.segments)
    if abs(seg_sum - t.total_length) > 0.01 * MM + TOL_M:
        fail("[tool] total_length", f"is {t.total_length / MM:g} mm but the tool segments add up to {seg_sum / MM:g} mm")
    if asm.stickout >= t.total_length - TOL_M:
        fail("[setup] stickout", f"({asm.stickout / MM:g} mm) must be shorter than the tool ({t.total_length / MM:g} mm)")
    if asm.inserted_length > h.length + TOL_M:
        fail("[setup] stickout", f"leaves {asm.inserted_length / MM:g} mm of tool inside a holder only {h.length / MM:g} mm long")

    warnings: list[str] = list(asm.file_warnings)
    # The tool must fit the bore along the whole inserted length.
    z_back, L_h = asm.z_tool_start, h.length
    zb = 0.0
    for i, hs in enumerate(h.segments, 1):
        za, zb = zb, zb + hs.length
        lo, hi = max(za, z_back), min(zb, L_h)
        if hi - lo <= TOL_M:
            continue
        zt = z_back
        for ts in t.segments:
            ta, tb = zt, zt + ts.length
            zt = tb
            if min(tb, hi) - max(ta, lo) <= TOL_M:
                continue
            if ts.od > hs.id + TOL_M:
                fail(
                    f"[holder] segments[{i}].id",
                    f"= {hs.id / MM:g} mm is smaller than the tool ({ts.od / MM:g} mm) inserted there: the tool cannot fit",
                )
            if ts.od < hs.id - TOL_M and min(tb, hi) > asm.z_contact_start + TOL_M:
                warnings.append(
                    f"{src}: bore {hs.id / MM:g} mm is larger than the tool ({ts.od / MM:g} mm) in the contact zone: "
                    "a collet or sleeve is implied"
                )
    if t.flute_length is not None and t.flute_length > asm.stickout + TOL_M:
        warnings.append(
            f"{src}: the flutes ({t.flute_length / MM:g} mm) reach {(t.flute_length - asm.stickout) / MM:g} mm into the holder"
        )
    return replace(asm, warnings=tuple(dict.fromkeys(warnings)))


# --------------------------------------------------------------------------- parsing


class _Reader:
    """Typed access to a TOML table with messages that name the file and the key."""

    def __init__(self, src: str):
        self.src = src

    def fail(self, key: str, problem: str):
        raise InputError(f"{self.src}: {key} {problem}")

    def missing(self, data: dict, key: str, where: str):
        """Fail on a missing required key, naming a present key that looks like its misspelling."""
        close = difflib.get_close_matches(key, [k for k in data if isinstance(k, str)], n=1, cutoff=0.75)
        hint = f" (is {close[0]!r} a misspelling of {key!r}?)" if close else ""
        self.fail(f"{where} {key}".strip() if where else f"[{key}]", f"is missing{hint}")

    def unknown(self, data: dict, known, where: str, warnings: list[str]) -> None:
        """Add a warning for each key of ``data`` this format does not know (it is ignored)."""
        for key in data:
            if key in known:
                continue
            close = difflib.get_close_matches(str(key), list(known), n=1, cutoff=0.6)
            hint = f"; did you mean {close[0]!r}?" if close else ""
            warnings.append(f"{self.src}: {where} unknown key {key!r} is ignored{hint}")

    def table(self, data: dict, key: str, where: str = "") -> dict:
        if key not in data:
            self.missing(data, key, where)
        value = data[key]
        if not isinstance(value, dict):
            self.fail(f"[{key}]" if not where else f"{where} {key}", "must be a table")
        return value

    def number(self, data: dict, key: str, where: str, default: float | None = None) -> float:
        if key not in data:
            if default is not None:
                return float(default)
            self.missing(data, key, where)
        value = data[key]
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            self.fail(f"{where} {key}", f"must be a number, got {value!r}")
        if not math.isfinite(value):
            self.fail(f"{where} {key}", f"must be a finite number, got {value!r}")
        return float(value)

    def text(self, data: dict, key: str, where: str, default: str | None = None, max_len: int | None = None) -> str:
        if key not in data:
            if default is not None:
                return default
            self.missing(data, key, where)
        value = data[key]
        if not isinstance(value, str) or not value.strip():
            self.fail(f"{where} {key}", f"must be a non-empty string, got {value!r}")
        if max_len is not None and (len(value.strip()) > max_len or any(ord(c) < 32 for c in value.strip())):
            # What the library stores (a name that would be refused there only after the fit).
            self.fail(f"{where} {key}", f"must be one line of at most {max_len} characters, got {value[:60]!r}")
        return value.strip()

    def material(self, data: dict, where: str, default: Material) -> Material:
        if "material" not in data:
            return default
        m = data["material"]
        if not isinstance(m, dict):
            self.fail(f"{where} material", "must be a table")
        w = f"{where} material."
        return Material(
            density=self.number(m, "density", w, default.density),
            youngs_modulus=self.number(m, "youngs_modulus", w, default.youngs_modulus / GPA) * GPA,
            poisson=self.number(m, "poisson", w, default.poisson),
            loss_factor=self.number(m, "loss_factor", w, default.loss_factor),
        )

    def holder(self, data: dict, where: str) -> Holder:
        """A :class:`Holder` from its table (mm, GPa); not yet validated."""
        gauge = self.number(data, "gauge_length", where) * MM if "gauge_length" in data else None
        return Holder(
            name=self.text(data, "name", where, max_len=NAME_MAX_LEN),
            interface=self.text(data, "interface", where, "unknown", max_len=NAME_MAX_LEN),
            clamp_length=self.number(data, "clamp_length", where) * MM,
            segments=self.segments(data, where),
            material=self.material(data, where, STEEL),
            gauge_length=gauge,
        )

    def segments(self, data: dict, where: str) -> tuple[Segment, ...]:
        segs = data.get("segments")
        if not isinstance(segs, list) or not segs:
            self.fail(f"{where} segments", "must be a non-empty array of {length, od, id} tables")
        out = []
        for i, s in enumerate(segs, 1):
            w = f"{where} segments[{i}]"
            if not isinstance(s, dict):
                self.fail(w, "must be a table {length, od, id}")
            out.append(
                Segment(
                    length=self.number(s, "length", w + ".") * MM,
                    od=self.number(s, "od", w + ".") * MM,
                    id=self.number(s, "id", w + ".", 0.0) * MM,
                )
            )
        return tuple(out)


def parse_assembly(data: dict, source: str = "<assembly>") -> Assembly:
    """Build a validated :class:`Assembly` from TOML data (mm, GPa)."""
    r = _Reader(source)
    if not isinstance(data, dict):
        r.fail("", "must be a TOML table")
    h = r.table(data, "holder")
    t = r.table(data, "tool")
    s = r.table(data, "setup")
    holder = r.holder(h, "[holder]")
    total = r.number(t, "total_length", "[tool]") * MM
    if "segments" in t:
        tool = Tool(
            name=r.text(t, "name", "[tool]", "tool", max_len=NAME_MAX_LEN),
            total_length=total,
            segments=r.segments(t, "[tool]"),
            material=r.material(t, "[tool]", CARBIDE),
        )
    else:
        shank = r.number(t, "shank_diameter", "[tool]") * MM
        flute_len = r.number(t, "flute_length", "[tool]") * MM
        flute_d = r.number(t, "flute_diameter", "[tool]") * MM
        ratio = r.number(t, "flute_ratio", "[tool]", 0.8)
        for key, v in (("shank_diameter", shank), ("flute_length", flute_len), ("flute_diameter", flute_d)):
            if v <= 0:
                r.fail(f"[tool] {key}", f"must be > 0 mm, got {v / MM:g}")
            if key.endswith("diameter") and not MIN_DIAMETER_M <= v <= MAX_DIAMETER_M:
                r.fail(f"[tool] {key}", f"({v / MM:g} mm) is implausible: outside {MIN_DIAMETER_M / MM:g}…"
                       f"{MAX_DIAMETER_M / MM:g} mm (diameters are in mm)")
        if not 0 < ratio <= 1.5:
            r.fail("[tool] flute_ratio", f"must lie in (0, 1.5], got {ratio:g}")
        if flute_len >= total - TOL_M:
            r.fail("[tool] flute_length", f"({flute_len / MM:g} mm) must be shorter than total_length ({total / MM:g} mm)")
        tool = Tool(
            name=r.text(t, "name", "[tool]", "tool", max_len=NAME_MAX_LEN),
            total_length=total,
            segments=(Segment(total - flute_len, shank), Segment(flute_len, ratio * flute_d)),
            material=r.material(t, "[tool]", CARBIDE),
            shank_diameter=shank,
            flute_length=flute_len,
            flute_diameter=flute_d,
            flute_ratio=ratio,
        )
    stickout = r.number(s, "stickout", "[setup]") * MM
    return validate(Assembly(holder=holder, tool=tool, stickout=stickout, source=source,
                             tolerances=_tolerances(r, h, t, s), file_warnings=_unknown_keys(r, data)))


# The keys of docs/assembly-format.md (and the optional tolerances); anything else is ignored
# with a warning, so a misspelt optional key (``gauge_lenght``) is not silently lost.
_MATERIAL_KEYS = ("density", "youngs_modulus", "poisson", "loss_factor")
_SEGMENT_KEYS = ("length", "od", "id")
_KNOWN_KEYS = {
    "holder": ("name", "interface", "clamp_length", "gauge_length", "material", "segments", "diameter_tolerance"),
    "tool": ("name", "material", "total_length", "shank_diameter", "flute_length", "flute_diameter",
             "flute_ratio", "segments", "flute_ratio_tolerance"),
    "setup": ("stickout", "stickout_tolerance"),
}


def _unknown_keys(r: "_Reader", data: dict) -> tuple[str, ...]:
    """One warning per key the format does not know, with the known key it resembles.

    Extra top-level sections are welcome (docs/assembly-format.md) unless they look like a
    misspelt ``[holder]``, ``[tool]`` or ``[setup]``.
    """
    out: list[str] = []
    for key in data:
        if key not in _KNOWN_KEYS and difflib.get_close_matches(str(key), list(_KNOWN_KEYS), n=1, cutoff=0.75):
            r.unknown({key: None}, _KNOWN_KEYS, "top level:", out)
    for table, known in _KNOWN_KEYS.items():
        where = f"[{table}]"
        section = data[table]
        r.unknown(section, known, where, out)
        if isinstance(section.get("material"), dict):
            r.unknown(section["material"], _MATERIAL_KEYS, f"{where} material:", out)
        if table != "setup" and isinstance(section.get("segments"), list):
            for i, seg in enumerate(section["segments"], 1):
                if isinstance(seg, dict):
                    r.unknown(seg, _SEGMENT_KEYS, f"{where} segments[{i}]:", out)
    return tuple(out)


#: The largest stick-out tolerance a file may state [mm] (beyond it, a typo).
MAX_STICKOUT_TOLERANCE_MM = 20.0


def _tolerances(r: "_Reader", h: dict, t: dict, s: dict) -> Tolerances:
    """The optional geometry tolerances, validated (a negative or absurd one is a typo)."""
    d = Tolerances()
    checks = (
        (s, "stickout_tolerance", "[setup]", d.stickout / MM, MAX_STICKOUT_TOLERANCE_MM, "mm (how far the stick-out may be off; ruler ≈ 0.3–0.5)"),
        (h, "diameter_tolerance", "[holder]", 100 * d.diameter, 10.0, "% (how far the holder diameters may be off; calipers ≈ 0.2, catalogue ≈ 1)"),
        (t, "flute_ratio_tolerance", "[tool]", d.flute_ratio, 0.5, "(how far the flute ratio may be off; typical 0.05)"),
    )
    values = []
    for table, key, where, default, top, unit in checks:
        v = r.number(table, key, where, default)
        if not 0 <= v <= top:
            r.fail(f"{where} {key}", f"must lie in [0, {top:g}] {unit}, got {v:g}")
        values.append(v)
    return Tolerances(stickout=values[0] * MM, diameter=values[1] / 100, flute_ratio=values[2])


def _loads(text: str, source: str) -> dict:
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as err:
        raise InputError(f"{source}: not valid TOML ({err})") from None


def assembly_from_toml(text: str, source: str = "<assembly>") -> Assembly:
    """Parse and validate the TOML text of an assembly file; errors name ``source``."""
    if not text.strip():
        raise InputError(f"{source}: is empty (an assembly file has [holder], [tool] and [setup] tables)")
    return parse_assembly(_loads(text, source), source)


# How a recording finds its assembly file, in words for help texts and error messages.
ASSEMBLY_BESIDE_RULE = ("<name>.toml, else the .toml named like the start of <name> "
                        "(er32_d16_tap.wav -> er32_d16.toml), else assembly.toml")


def assembly_candidates(recording: str | Path) -> list[Path]:
    """The assembly files beside a recording that may describe it, best first.

    One rule for every front end (identify, batch, the desktop app): ``<stem>.toml``;
    then the ``.toml`` files whose name starts the recording's name and is followed
    there by ``_``, ``-``, a space or ``.``, the longest first (``er32_d16_tap.wav`` and
    ``er32_d16_tap2.wav`` → ``er32_d16.toml``, as in ``recordings/``: several takes of one
    assembly share one file); then ``assembly.toml`` (``tap.wav`` → ``assembly.toml``).
    Only files that exist are listed, except the first and last names, which are always
    there for an error message to name.
    """
    recording = Path(recording)
    stem, folder = recording.stem, recording.parent
    try:
        tomls = [p for p in folder.iterdir() if p.suffix.lower() == ".toml" and p.is_file()]
    except OSError:  # no such folder (yet): only the fixed names
        tomls = []
    prefixes = sorted((p for p in tomls if len(p.stem) < len(stem) and stem.startswith(p.stem)
                       and stem[len(p.stem)] in "_- ."), key=lambda p: -len(p.stem))
    return list(dict.fromkeys([recording.with_suffix(".toml"), *prefixes, folder / "assembly.toml"]))


def assembly_beside(recording: str | Path) -> Path | None:
    """The assembly file of a recording (:func:`assembly_candidates`, the first that is
    a file); None if there is none."""
    return next((c for c in assembly_candidates(recording) if c.is_file()), None)


def load_assembly(path: str | Path) -> Assembly:
    """Read and validate an assembly TOML file (docs/assembly-format.md)."""
    return assembly_from_toml(read_text(path, "an assembly file", "TOML"), str(path))


def parse_holder(data: dict, source: str = "<holder>") -> Holder:
    """A validated :class:`Holder` from TOML data holding a ``[holder]`` table (mm, GPa).

    Other tables (``[tool]``, ``[setup]``) are ignored: a holder-only file describes, for
    example, the dummy holder of an inverse-RCSA spindle measurement (docs/machine.md).
    """
    r = _Reader(source)
    if not isinstance(data, dict):
        r.fail("", "must be a TOML table")
    return validate_holder(r.holder(r.table(data, "holder"), "[holder]"), source)


def load_holder(path: str | Path) -> Holder:
    """Read and validate a holder-only TOML file (the ``[holder]`` table of docs/assembly-format.md)."""
    return parse_holder(_loads(read_text(path, "a holder file", "TOML"), str(path)), str(path))


# --------------------------------------------------------------------------- writing


def _fmt(x: float) -> str:
    return f"{x:.6g}" if "e" not in f"{x:.6g}" else repr(float(x))


def _seg_lines(segments) -> str:
    return "\n".join(
        f"  {{ length = {_fmt(s.length / MM)}, od = {_fmt(s.od / MM)}, id = {_fmt(s.id / MM)} }},"
        for s in segments
    )


def _material_line(m: Material) -> str:
    return (
        f"material = {{ density = {_fmt(m.density)}, youngs_modulus = {_fmt(m.youngs_modulus / GPA)}, "
        f"poisson = {_fmt(m.poisson)}, loss_factor = {_fmt(m.loss_factor)} }}"
    )


def _toml_str(s: str) -> str:
    return '"' + s.replace("\\", "\\\\").replace('"', '\\"') + '"'


def holder_to_toml(holder: Holder) -> str:
    """The ``[holder]`` table of an assembly file (mm, GPa)."""
    return (
        "[holder]\n"
        f"name = {_toml_str(holder.name)}\n"
        f"interface = {_toml_str(holder.interface)}\n"
        f"clamp_length = {_fmt(holder.clamp_length / MM)}\n"
        + (f"gauge_length = {_fmt(holder.gauge_length / MM)}\n" if holder.gauge_length is not None else "")
        + f"{_material_line(holder.material)}\n"
        f"segments = [\n{_seg_lines(holder.segments)}\n]\n"
    )


def tool_to_toml(tool: Tool) -> str:
    """The ``[tool]`` table of an assembly file (mm, GPa)."""
    out = f"[tool]\nname = {_toml_str(tool.name)}\n{_material_line(tool.material)}\n"
    out += f"total_length = {_fmt(tool.total_length / MM)}\n"
    if tool.shank_diameter is not None:
        out += (
            f"shank_diameter = {_fmt(tool.shank_diameter / MM)}\n"
            f"flute_length = {_fmt(tool.flute_length / MM)}\n"
            f"flute_diameter = {_fmt(tool.flute_diameter / MM)}\n"
            f"flute_ratio = {_fmt(tool.flute_ratio)}\n"
        )
    else:
        out += f"segments = [\n{_seg_lines(tool.segments)}\n]\n"
    return out


def assembly_to_toml(asm: Assembly) -> str:
    """An assembly file that :func:`load_assembly` reads back to the same geometry (and tolerances)."""
    tol, d = asm.tolerances, Tolerances()
    text = holder_to_toml(asm.holder)
    if tol.diameter != d.diameter:
        text += f"diameter_tolerance = {_fmt(100 * tol.diameter)}\n"
    text += "\n" + tool_to_toml(asm.tool)
    if tol.flute_ratio != d.flute_ratio and asm.tool.flute_ratio is not None:
        text += f"flute_ratio_tolerance = {_fmt(tol.flute_ratio)}\n"
    text += f"\n[setup]\nstickout = {_fmt(asm.stickout / MM)}\n"
    if tol.stickout != d.stickout:
        text += f"stickout_tolerance = {_fmt(tol.stickout / MM)}\n"
    return text


def material_to_dict(m: Material) -> dict:
    """A material as plain JSON-able data (kg/m³, GPa)."""
    return {"density": m.density, "youngs_modulus": m.youngs_modulus / GPA, "poisson": m.poisson,
            "loss_factor": m.loss_factor}


def segments_to_list(segments) -> list[dict]:
    """Segments as plain JSON-able data (mm)."""
    return [{"length": s.length / MM, "od": s.od / MM, "id": s.id / MM} for s in segments]


def holder_to_dict(holder: Holder) -> dict:
    """Holder geometry as plain JSON-able data (mm, GPa), for the holder library."""
    out = {
        "name": holder.name,
        "interface": holder.interface,
        "clamp_length": holder.clamp_length / MM,
        "material": material_to_dict(holder.material),
        "segments": segments_to_list(holder.segments),
    }
    if holder.gauge_length is not None:
        out["gauge_length"] = holder.gauge_length / MM
    return out


def holder_from_dict(data: dict, source: str = "<library>") -> Holder:
    """Inverse of :func:`holder_to_dict`; raises InputError naming ``source`` on bad data."""
    r = _Reader(source)
    if not isinstance(data, dict):
        r.fail("holder", "must be a table")
    return r.holder(data, "holder")
