"""Named work materials with their cutting-force coefficients (for the lobes, docs/machine.md).

K_tc and K_rc are the tangential and radial shearing-force coefficients of the linear
(mechanistic) milling force model, F_t = K_tc a h + K_te a, F_r = K_rc a h + K_re a; the
zero-order lobes use K_tc and K_rc only. They depend on the tool (rake, helix, edge)
and the feed range they were identified for, so treat them as starting values and
prefer coefficients measured with your own tool. Only values whose source could be
checked are listed; add others with their source.

Signature::

    MATERIALS: dict[str, CuttingCoefficients]     # keys are lower-case names
    cutting_coefficients(name) -> CuttingCoefficients
"""

from __future__ import annotations

from dataclasses import dataclass

from taptune.errors import InputError

MPA = 1e6


@dataclass(frozen=True)
class CuttingCoefficients:
    """K_tc, K_rc [N/m²] of a work material, and where the values come from."""

    name: str
    ktc: float
    krc: float
    source: str

    def to_dict(self) -> dict:
        return {"name": self.name, "ktc_mpa": self.ktc / MPA, "krc_mpa": self.krc / MPA, "source": self.source}


MATERIALS = {
    c.name: c
    for c in (
        CuttingCoefficients(
            "al6082", 902 * MPA, 243 * MPA,
            "aluminium EN AW-6082, 12 mm 4-flute carbide end mill, 0.05 mm/tooth: the cutting data "
            "published with the tap-test identification method this program implements",
        ),
        CuttingCoefficients(
            "al7075", 767 * MPA, 169 * MPA,
            "aluminium 7075-T6, cemented-carbide end mill, dry: K_tc 767.01, K_rc 168.8 N/mm² as tabulated "
            "in the review 'Milling Force Model for Aviation Aluminum Alloy: Academic Insight and "
            "Perspective Analysis', Chinese Journal of Mechanical Engineering 34 (2021), Table 5",
        ),
    )
}
#: Other spellings users type for the same materials.
ALIASES = {
    "aluminium6082": "al6082", "aluminum6082": "al6082", "al6082t6": "al6082", "enaw6082": "al6082",
    "aluminium7075": "al7075", "aluminum7075": "al7075", "al7075t6": "al7075", "enaw7075": "al7075",
}


def cutting_coefficients(name: str) -> CuttingCoefficients:
    """The coefficients of a named material (case-insensitive); InputError lists the known names."""
    key = name.strip().lower().replace("-", "").replace(" ", "")
    key = ALIASES.get(key, key)
    if key not in MATERIALS:
        raise InputError(f"unknown work material {name!r} (known: {', '.join(MATERIALS)}); give --ktc and --krc")
    return MATERIALS[key]
