"""Dominant modes of a measured or predicted FRF: peak frequency and damping ratio.

Peaks of |G| are picked on the grid; each is then fitted locally by a single mode plus
a straight residual, G(s) ≈ (n0 + n1 s + n2 s²) / (s² + b1 s + b0) with s = iω/ω_peak,
solved linearly (Levy's method) over about ±2 half-power bandwidths. Its pole p nearest
the peak gives f_n = |p|·f_peak and ζ = −Re p / |p| (viscous or hysteretic
damping alike); the half-power estimate is the fallback when the fit finds no such pole.

Signature::

    dominant_modes(freq_hz, frf, direction, rel_level=0.1, max_modes=5) -> list[FRFMode]
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class FRFMode:
    """A peak of a tool-point FRF: frequency [Hz], damping ratio ζ, direction, |G| [m/N]."""

    hz: float
    damping_ratio: float
    direction: str
    magnitude: float

    def to_dict(self) -> dict:
        return {"hz": round(self.hz, 3), "damping_ratio": float(f"{self.damping_ratio:.5g}"),
                "direction": self.direction}


def _half_power(f, mag, i) -> tuple[float, float]:
    """(f_lo, f_hi) where |G| falls to |G_peak|/√2 on each side (NaN when not reached)."""
    level = mag[i] / np.sqrt(2.0)
    lo = hi = np.nan
    j = i
    while j > 0 and mag[j] > level:
        j -= 1
    if mag[j] <= level and j < i:
        lo = np.interp(level, [mag[j], mag[j + 1]], [f[j], f[j + 1]])
    j = i
    while j < len(f) - 1 and mag[j] > level:
        j += 1
    if mag[j] <= level and j > i:
        hi = np.interp(level, [mag[j], mag[j - 1]], [f[j], f[j - 1]])
    return lo, hi


def _local_fit(f, g, i, width_hz):
    """(f_n, ζ) of the single-mode-plus-residual fit around grid index i, or None."""
    f0 = f[i]
    sel = np.abs(f - f0) <= max(width_hz, 3 * np.median(np.diff(f)))
    if np.count_nonzero(sel) < 6:
        return None
    s, gs = 1j * f[sel] / f0, g[sel]
    # G (s² + b1 s + b0) = n0 + n1 s + n2 s²  →  [−G s, −G, 1, s, s²] · [b1, b0, n0, n1, n2] = G s²
    a = np.stack([-gs * s, -gs, np.ones_like(s), s, s * s], axis=1)
    scale = np.abs(a).max(axis=0)
    coef, *_ = np.linalg.lstsq(a / scale, gs * s * s, rcond=None)
    b1, b0 = (coef / scale)[:2]
    # Complex b0, b1 cover viscous and hysteretic damping alike (the two roots are then no
    # conjugate pair): take the pole p nearest the peak, s = i, then f_n = |p| f_peak and
    # ζ = −Re p / |p|.
    roots = np.roots([1.0, b1, b0])
    p = roots[np.argmin(np.abs(roots - 1j))]
    wn = abs(p)
    zeta = -p.real / wn
    if not (p.imag > 0 and 0 < zeta < 0.5 and abs(wn - 1) * f0 <= width_hz):
        return None
    return f0 * wn, zeta


def dominant_modes(freq_hz, frf, direction: str, rel_level: float = 0.1, max_modes: int = 5) -> list[FRFMode]:
    """Peaks of |frf| at least ``rel_level`` × the highest one, strongest first.

    Parameters
    ----------
    freq_hz : ndarray, shape (n,)
        Ascending frequencies [Hz].
    frf : ndarray, complex, shape (n,)
        Receptance [m/N].
    direction : str
        Label stored with each mode ("x", "y").
    rel_level : float
        Peaks below this fraction of the largest are not dominant.
    max_modes : int
        At most this many modes.
    """
    f = np.asarray(freq_hz, dtype=float)
    g = np.asarray(frf, dtype=complex)
    mag = np.abs(g)
    if len(f) < 3:
        return []
    inner = np.flatnonzero((mag[1:-1] > mag[:-2]) & (mag[1:-1] >= mag[2:])) + 1
    inner = inner[mag[inner] >= rel_level * mag.max()]
    out = []
    for i in inner[np.argsort(-mag[inner])][:max_modes]:
        lo, hi = _half_power(f, mag, i)
        zeta_hp = (hi - lo) / (2 * f[i]) if np.isfinite(lo) and np.isfinite(hi) else np.nan
        width = 2 * (hi - lo) if np.isfinite(zeta_hp) else 0.05 * f[i]
        fit = _local_fit(f, g, i, width)
        hz, zeta = fit if fit is not None else (f[i], zeta_hp)
        out.append(FRFMode(hz=float(hz), damping_ratio=float(zeta), direction=direction, magnitude=float(mag[i])))
    return out
