"""Where the teeth of a milling cutter cut: entry and exit angles of the radial immersion.

Angles are measured from the y axis, clockwise, with the feed along x (Altintas 2012,
*Manufacturing Automation*, ch. 3), as the zero-order lobes, the semi-discretization and
the time-domain simulation all use them.
"""

from __future__ import annotations

import numpy as np

from taptune.errors import InputError

MM = 1e-3
MILLING = ("up", "down")


def engagement_angles(ae: float, diameter: float, milling: str) -> tuple[float, float]:
    """Entry and exit angles φ_st, φ_ex [rad], measured from the y axis, feed along x.

    ``ae`` ≥ ``diameter`` (to 1e-9 relative) is slotting, 0 → π; up-milling
    0 → arccos(1 − 2a_e/D); down-milling arccos(2a_e/D − 1) → π.
    """
    if milling not in MILLING:
        raise InputError(f"milling must be 'up' or 'down', got {milling!r}")
    if not (diameter > 0 and np.isfinite(diameter)):
        raise InputError(f"the tool diameter must be > 0 mm, got {diameter / MM:g}")
    if not (ae > 0 and np.isfinite(ae)):
        raise InputError(f"the radial depth ae must be > 0 mm, got {ae / MM:g}")
    if ae > diameter * (1 + 1e-9):
        raise InputError(f"the radial depth ae ({ae / MM:g} mm) exceeds the tool diameter ({diameter / MM:g} mm)")
    if ae >= diameter * (1 - 1e-9):
        return 0.0, np.pi
    if milling == "up":
        return 0.0, float(np.arccos(1 - 2 * ae / diameter))
    return float(np.arccos(2 * ae / diameter - 1)), np.pi
