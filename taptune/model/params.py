"""The seven holder parameters of the distributed tool–holder contact (docs/physics.md §1, §2).

Units are those of the holder library ("per mm of contact"): ``k_tt`` [N/m per mm],
``k_rr`` [N·m/rad per mm], ``eta_tt``/``eta_rr`` [1/mm], ``alpha`` [%], the two factors
dimensionless. The optimiser works on the vector p (log10 for the four
intensities), see :func:`to_p` and :func:`from_p`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields

import numpy as np

from taptune.errors import InputError

# The fixed reference length that turns an eta [1/mm] into a loss factor (docs/physics.md §1).
ETA_REFERENCE_MM = 10.0

NAMES = ("k_tt", "k_rr", "eta_tt", "eta_rr", "alpha", "density_factor", "modulus_factor")
# Bounds of p (docs/physics.md §2, binding). The first four are log10 of the parameter.
P_LOWER = np.array([4.0, 2.0, -7.0, -7.0, -25.0, 0.95, 0.90])
P_UPPER = np.array([10.0, 5.0, -1.0, -1.0, 25.0, 1.05, 1.10])
LOG_PARAMS = 4


@dataclass(frozen=True)
class HolderParams:
    """Contact and holder parameters; see the module docstring for units."""

    k_tt: float
    k_rr: float
    eta_tt: float
    eta_rr: float
    alpha: float = 0.0
    density_factor: float = 1.0
    modulus_factor: float = 1.0

    @property
    def c_t(self) -> complex:
        """Complex translational line stiffness at the zone middle [N/m per m of contact]."""
        return self.k_tt * 1e3 * (1 + 1j * self.eta_tt * ETA_REFERENCE_MM)

    @property
    def c_r(self) -> complex:
        """Complex rotational line stiffness at the zone middle [N·m/rad per m of contact]."""
        return self.k_rr * 1e3 * (1 + 1j * self.eta_rr * ETA_REFERENCE_MM)

    def to_dict(self) -> dict:
        # Not dataclasses.asdict: its deep copy made saving a large holder library slow.
        return {k: float(getattr(self, k)) for k in NAMES}

    @classmethod
    def from_dict(cls, data: dict, source: str = "<params>") -> "HolderParams":
        """Parameters from a mapping with the library keys; raises InputError naming ``source``."""
        if not isinstance(data, dict):
            raise InputError(f"{source}: holder parameters must be a JSON object with keys {', '.join(NAMES)}")
        missing = [k for k in NAMES if k not in data]
        if missing:
            raise InputError(f"{source}: holder parameters lack {', '.join(missing)}")
        values = {}
        for k in NAMES:
            v = data[k]
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not _finite(v):
                raise InputError(f"{source}: parameter {k} must be a finite number, got {v!r}")
            values[k] = float(v)
        # One test for the usual case (a holder library reads thousands of sets), then the reason.
        if not all(lo <= values[k] <= hi for k, lo, hi in _PLAUSIBLE) or abs(values["alpha"]) >= 100:
            for k in ("k_tt", "k_rr", "density_factor", "modulus_factor"):
                if values[k] <= 0:
                    raise InputError(f"{source}: parameter {k} must be > 0, got {values[k]:g}")
            for k in ("eta_tt", "eta_rr"):
                if values[k] < 0:
                    raise InputError(f"{source}: parameter {k} must be >= 0, got {values[k]:g}")
            if abs(values["alpha"]) >= 100:
                raise InputError(f"{source}: parameter alpha must lie in (-100, 100) %, got {values['alpha']:g}")
            for k, lo, hi in _PLAUSIBLE:
                if not lo <= values[k] <= hi:
                    raise InputError(f"{source}: parameter {k} = {values[k]:g} is not plausible "
                                     f"(expected {lo:g} … {hi:g})")
        return cls(**values)


# Two decades beyond the search space (docs/physics.md §2) is still a holder; far beyond it the
# matrices overflow or lose all precision.
_PLAUSIBLE = (("k_tt", 1e2, 1e12), ("k_rr", 1.0, 1e7), ("eta_tt", 0.0, 1.0), ("eta_rr", 0.0, 1.0),
              ("density_factor", 0.1, 10.0), ("modulus_factor", 0.1, 10.0))


def _finite(v) -> bool:
    try:
        return math.isfinite(v)
    except OverflowError:  # an integer beyond any float
        return False


# Medians of five published holders (docs/physics.md §2), used when nothing else is known.
NOMINAL = HolderParams(k_tt=2.81e9, k_rr=1.51e4, eta_tt=4.57e-3, eta_rr=6.19e-3)


def to_p(params: HolderParams) -> np.ndarray:
    """The optimiser's vector p (log10 of the four intensities, then alpha and factors)."""
    v = np.array([getattr(params, f.name) for f in fields(HolderParams)], dtype=float)
    v[:LOG_PARAMS] = np.log10(v[:LOG_PARAMS])
    return v


def from_p(p) -> HolderParams:
    """Inverse of :func:`to_p`."""
    p = np.asarray(p, dtype=float)
    v = p.copy()
    v[:LOG_PARAMS] = 10.0 ** p[:LOG_PARAMS]
    return HolderParams(*map(float, v))


def p_to_unit(p) -> np.ndarray:
    """Map p inside the bounds to [0, 1]^7 (what the optimisers search)."""
    return (np.asarray(p, dtype=float) - P_LOWER) / (P_UPPER - P_LOWER)


def unit_to_p(u) -> np.ndarray:
    """Inverse of :func:`p_to_unit`; works on one vector or rows of vectors."""
    return P_LOWER + np.asarray(u, dtype=float) * (P_UPPER - P_LOWER)
