"""Holder families and tools of the realism corpus: the asset holders, clamped on D6–D20 tools.

Four families, from taptune's ``assets/`` (all HSK-A63): the ER32 collet chucks ×100 and
×80, the hydraulic chuck and the shrink-fit chuck. Each takes the tool diameters such
a holder is sold for; the bore around the tool is the tool diameter (a collet of that
size, a hydraulic or shrink-fit chuck for that shank). Tools: solid carbide end mills
after DIN 6527 (short and long). Lengths in mm here; :func:`described_assembly` builds
the SI :class:`~taptune.io.assembly.Assembly`.
"""

from __future__ import annotations

from dataclasses import dataclass

from taptune.io.assembly import CARBIDE, STEEL, Assembly, Holder, Segment, Tool, validate

MM = 1e-3

# (diameter, total length, flute length) [mm]: DIN 6527 short and long series.
TOOLS = {
    6: ((57.0, 13.0), (75.0, 18.0)),
    8: ((63.0, 19.0), (80.0, 24.0)),
    10: ((72.0, 22.0), (100.0, 30.0)),
    12: ((83.0, 26.0), (100.0, 36.0)),
    16: ((92.0, 32.0), (110.0, 40.0)),
    20: ((104.0, 38.0), (125.0, 45.0)),
}

HSK_BASE = ((16.0, 47.0, 34.0), (16.0, 47.8, 34.0), (6.0, 63.0, 26.0), (8.0, 55.0, 26.0), (6.0, 63.0, 26.0))


@dataclass(frozen=True)
class Family:
    """A holder design: segments (length, od, id) [mm] as a function of the tool diameter."""

    key: str
    title: str
    clamp_mm: float
    diameters: tuple
    collet: bool  # a clamping nut the file folds into a cylinder (or leaves out)

    def segments(self, d: float) -> tuple:
        if self.key == "er32x100":
            return ((32.0, 48.0, 24.0), (10.0, 63.0, 24.0), (58.0, 50.0, d))
        if self.key == "er32x80":
            return HSK_BASE + ((14.0, 46.0, 20.0), (14.0, 50.0, d), (20.0, 50.0, d))
        if self.key == "hydraulic":
            collar = {12: 32.0, 16: 36.0, 20: 40.0}[int(d)]
            return HSK_BASE + ((14.0, 52.0, 12.0 if d > 12 else 8.0), (50.0, 50.0, d), (16.0, collar, d))
        if self.key == "shrinkfit":
            # The 4.5° nose of the D12 asset, widened or narrowed with the shank.
            nose = (36.0, 33.0, 30.0, 27.0, 24.5)
            body_bore = min(8.0, d - 2.0)
            return HSK_BASE + ((10.0, 44.0, body_bore),) + tuple((12.0, od + (d - 12.0), d) for od in nose)
        raise ValueError(self.key)


FAMILIES = (
    Family("er32x100", "ER32 collet chuck HSK-A63 x 100", 40.0, (8, 10, 12, 16, 20), True),
    Family("er32x80", "ER32 collet chuck HSK-A63 x 80", 30.0, (6, 8, 10, 12), True),
    Family("hydraulic", "Hydraulic chuck HSK-A63 x 100", 50.0, (12, 16, 20), False),
    Family("shrinkfit", "Shrink-fit chuck HSK-A63 x 90", 45.0, (6, 8, 10, 12, 16, 20), False),
)


def make_holder(family: Family, d: float, name: str, od_factors=None) -> Holder:
    """The holder for tool diameter ``d`` [mm]; ``od_factors`` scale each segment's od (truth)."""
    segs = family.segments(d)
    factors = od_factors if od_factors is not None else (1.0,) * len(segs)
    return Holder(
        name=name,
        interface="HSK-A63",
        clamp_length=family.clamp_mm * MM,
        segments=tuple(Segment(l * MM, od * f * MM, i * MM) for (l, od, i), f in zip(segs, factors)),
        material=STEEL,
    )


def make_tool(d: float, total: float, flute: float, ratio: float = 0.8) -> Tool:
    """A solid carbide end mill [mm in, SI out] modelled as shank + fluted cylinder (docs/assembly-format.md)."""
    return Tool(
        name=f"solid carbide end mill D{d:g} x {total:g}",
        total_length=total * MM,
        segments=(Segment((total - flute) * MM, d * MM), Segment(flute * MM, ratio * d * MM)),
        material=CARBIDE,
        shank_diameter=d * MM,
        flute_length=flute * MM,
        flute_diameter=d * MM,
        flute_ratio=ratio,
    )


def max_insertion_mm(holder: Holder, d: float) -> float:
    """Deepest a Ø``d`` shank goes into the holder [mm]: back from the front face while the bore fits."""
    depth = 0.0
    for seg in reversed(holder.segments):
        if seg.id + 1e-9 < d * MM:
            break
        depth += seg.length / MM
    return depth


def assemble_geometry(holder: Holder, tool: Tool, stickout_mm: float, source: str) -> Assembly:
    """A validated assembly (raises InputError when the tool does not fit)."""
    return validate(Assembly(holder=holder, tool=tool, stickout=stickout_mm * MM, source=source))
