"""Milling stability lobes, zero-order approximation (MODEL.md §11; Altintas & Budak 1995).

For each chatter-frequency candidate ω_c the characteristic equation
a0 Λ² + a1 Λ + 1 = 0 with

    a0 = Φxx Φyy (αxx αyy − αxy αyx),   a1 = αxx Φxx + αyy Φyy

gives two eigenvalues Λ (both roots are kept), and each gives

    κ = Im Λ / Re Λ,  a_lim = −2π Re Λ (1 + κ²) / (N K_tc)  [m] (positive values only),
    ψ = arctan κ,  ε = π − 2ψ,  n_k = 60 ω_c / (N (ε + 2kπ))  [rpm],  k = 0, 1, 2, …

The stability boundary is the lower envelope of all (n_k, a_lim) curves on the
requested speed grid: every lobe is cut into segments between consecutive scan points
(monotonic pieces) and each is interpolated linearly onto the grid speeds it spans; the
chatter frequency of the segment that sets the boundary is kept per speed. Lobes are
followed down to the lowest requested speed.

Chatter-frequency scan: every frequency of the FRF grid, plus ``refine`` extra points
per grid interval (cubic interpolation of the FRF in re and im) within ``REFINE_BANDS``
half-power bandwidths of each dominant peak of |Φxx|, |Φyy|, where the lobes are
steep. tests/machine/test_lobes.py shows that doubling ``refine`` moves the envelope by
less than 0.2 %.

Signatures::

    directional_factors(ae, diameter, milling, kr) -> (axx, axy, ayx, ayy)
    stability_lobes(freq_hz, phi_xx, phi_yy, *, teeth, ktc, krc, diameter, ae, milling, rpm,
                    refine=8) -> Lobes
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from taptune.errors import InputError
from taptune.machine.peaks import dominant_modes

MM = 1e-3
#: Half-power bandwidths on each side of a dominant peak where the scan is refined.
REFINE_BANDS = 6.0
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


def directional_factors(ae: float, diameter: float, milling: str, kr: float) -> tuple[float, float, float, float]:
    """Average directional factors (αxx, αxy, αyx, αyy) of MODEL.md §11 for K_r = K_rc/K_tc."""
    st, ex = engagement_angles(ae, diameter, milling)

    def bracket(fn):
        return 0.5 * (fn(ex) - fn(st))

    return (
        bracket(lambda p: np.cos(2 * p) - 2 * kr * p + kr * np.sin(2 * p)),
        bracket(lambda p: -np.sin(2 * p) - 2 * p + kr * np.cos(2 * p)),
        bracket(lambda p: -np.sin(2 * p) + 2 * p + kr * np.cos(2 * p)),
        bracket(lambda p: -np.cos(2 * p) - 2 * kr * p - kr * np.sin(2 * p)),
    )


@dataclass(frozen=True)
class Lobes:
    """Stability boundary on a speed grid (SI inside: m).

    Attributes
    ----------
    rpm : ndarray, shape (m,)
        Spindle speeds [rpm].
    a_lim : ndarray, shape (m,)
        Limiting axial depth of cut on the boundary [m] (inf where no lobe reaches).
    chatter_hz : ndarray, shape (m,)
        Chatter frequency of the lobe that sets the boundary [Hz] (NaN where none).
    a_crit : float
        Lowest limit over all speeds [m] (the minimum over the whole scan).
    pockets : tuple of (rpm, a_lim [m])
        Local maxima of the boundary inside the grid (lobe peaks), best first.
    curves : tuple of (k, rpm ndarray, a_lim ndarray)
        Every lobe k (both roots) that reaches the grid, in chatter-frequency order over
        the scan (NaN/inf where a root gives no positive limit), for plots.
    warnings : tuple of str
        E.g. speeds that no lobe reaches because the FRF's band ends too early.
    """

    rpm: np.ndarray = field(repr=False)
    a_lim: np.ndarray = field(repr=False)
    chatter_hz: np.ndarray = field(repr=False)
    a_crit: float = float("nan")
    pockets: tuple = ()
    curves: tuple = field(default=(), repr=False)
    warnings: tuple = ()

    def to_dict(self) -> dict:
        """MACHINE.md's ``lobes`` JSON (mm, rpm, Hz); non-finite values are null."""

        def num(v, scale=1.0):
            return float(v) / scale if np.isfinite(v) else None

        return {
            "rpm": [float(r) for r in self.rpm],
            "a_lim_mm": [num(a, MM) for a in self.a_lim],
            "a_crit_mm": num(self.a_crit, MM),
            "pockets": [{"rpm": float(r), "a_lim_mm": float(a) / MM} for r, a in self.pockets],
            "chatter_hz": [num(f) for f in self.chatter_hz],
        }


def _scan(freq_hz, phi_xx, phi_yy, refine: int):
    """Chatter-frequency candidates [Hz] and the FRFs there (grid plus refined bands)."""
    f = np.asarray(freq_hz, dtype=float)
    if refine <= 1:
        return f, phi_xx, phi_yy
    from scipy.interpolate import CubicSpline

    extra = []
    for g in (phi_xx, phi_yy):
        for m in dominant_modes(f, g, "", rel_level=0.05, max_modes=8):
            half = max(REFINE_BANDS * 2 * m.damping_ratio * m.hz, 3 * np.median(np.diff(f)))
            i = np.flatnonzero(np.abs(f - m.hz) <= half)
            if len(i) < 2:
                continue
            lo, hi = f[i[0]], f[i[-1]]
            t = (np.arange(1, refine) / refine)[None, :]
            seg = f[i[:-1], None] + (f[i[1:]] - f[i[:-1]])[:, None] * t
            extra.append(seg[(seg > lo) & (seg < hi)].ravel())
    if not extra:
        return f, phi_xx, phi_yy
    fs = np.unique(np.concatenate([f] + extra))

    def interp(g):
        return CubicSpline(f, g.real)(fs) + 1j * CubicSpline(f, g.imag)(fs)

    return fs, interp(phi_xx), interp(phi_yy)


def _eigenvalues(phi_xx, phi_yy, a) -> np.ndarray:
    """Both roots Λ of a0 Λ² + a1 Λ + 1 = 0, shape (2, n) (inf where a root does not exist)."""
    axx, axy, ayx, ayy = a
    a0 = phi_xx * phi_yy * (axx * ayy - axy * ayx)
    a1 = axx * phi_xx + ayy * phi_yy
    root = np.sqrt(a1 * a1 - 4 * a0)
    # q with the sign that avoids cancellation; the roots are q/a0 and 1/q (1/q → −1/a1 as a0 → 0).
    sign = np.where(np.real(np.conj(a1) * root) >= 0, 1.0, -1.0)
    q = -0.5 * (a1 + sign * root)
    with np.errstate(divide="ignore", invalid="ignore"):
        lam1 = np.where(a0 != 0, q / a0, np.inf)
        lam2 = np.where(q != 0, 1.0 / q, np.inf)
    return _follow(np.stack([lam1, lam2]))


def _follow(lam) -> np.ndarray:
    """Label the two roots continuously along the scan, shape (2, n).

    The sign choice above swaps the roots wherever Re(ā1·√disc) changes sign; a lobe
    joining one root at one frequency to the other at the next would draw a false
    segment across the speed axis. Each point keeps the pairing nearest (in 1/Λ, which
    stays finite) to the previous point; the swaps accumulate as a parity.
    """
    with np.errstate(divide="ignore", invalid="ignore"):
        inv = np.where(np.isfinite(lam), 1.0 / lam, 0.0)
    same = np.abs(inv[0, 1:] - inv[0, :-1]) + np.abs(inv[1, 1:] - inv[1, :-1])
    cross = np.abs(inv[0, 1:] - inv[1, :-1]) + np.abs(inv[1, 1:] - inv[0, :-1])
    flip = np.concatenate([[False], np.cumsum(cross < same) % 2 == 1])
    return np.where(flip[None, :], lam[::-1], lam)


def _lower_envelope(grid, n, a, fc, best, chatter) -> bool:
    """Lower ``best`` (and set ``chatter``) on the ascending speed grid with one lobe curve.

    The curve (n, a, f_c) over the scan is cut into segments between consecutive valid
    scan points; each segment is interpolated linearly onto the grid speeds it spans
    (its monotonic piece). Returns whether the curve reached the grid.
    """
    ok = np.isfinite(a) & np.isfinite(n)
    seg = np.flatnonzero(ok[:-1] & ok[1:])
    if seg.size == 0:
        return False
    n0, n1 = n[seg], n[seg + 1]
    lo = np.searchsorted(grid, np.minimum(n0, n1), "left")
    hi = np.searchsorted(grid, np.maximum(n0, n1), "right")
    count = hi - lo
    if count.sum() == 0:
        return bool(np.any((n[ok] >= grid[0]) & (n[ok] <= grid[-1])))
    which = np.repeat(np.arange(seg.size), count)
    # Grid index of every (segment, speed) pair: lo of its segment plus its rank inside.
    start = np.cumsum(count) - count
    g = lo[which] + np.arange(which.size) - start[which]
    s0 = seg[which]
    dn = n[s0 + 1] - n[s0]
    t = np.where(dn != 0, (grid[g] - n[s0]) / np.where(dn != 0, dn, 1.0), 0.0)
    val = a[s0] + t * (a[s0 + 1] - a[s0])
    np.minimum.at(best, g, val)
    win = val <= best[g]
    chatter[g[win]] = (fc[s0] + t * (fc[s0 + 1] - fc[s0]))[win]
    return True


def stability_lobes(freq_hz, phi_xx, phi_yy=None, *, teeth: int, ktc: float, krc: float, diameter: float,
                    ae: float, milling: str, rpm, refine: int = 8) -> Lobes:
    """Zero-order stability lobes of a milling cut (MODEL.md §11).

    Parameters
    ----------
    freq_hz : array_like, shape (n,)
        Ascending frequencies of the tool-point FRFs [Hz], > 0.
    phi_xx, phi_yy : array_like, complex, shape (n,)
        Tool-point receptances [m/N]; ``phi_yy=None`` uses Φxx for y.
    teeth : int
        Number of teeth N.
    ktc, krc : float
        Tangential and radial cutting-force coefficients [N/m²] (MPa × 1e6).
    diameter, ae : float
        Tool diameter and radial depth of cut [m]; ae = diameter is slotting.
    milling : {"up", "down"}
    rpm : array_like, shape (m,)
        Spindle speeds of the boundary [rpm], > 0.
    refine : int
        Scan points per FRF grid interval near dominant peaks (1: the grid only).

    Returns
    -------
    Lobes
    """
    f = np.asarray(freq_hz, dtype=float)
    pxx = np.asarray(phi_xx, dtype=complex)
    pyy = pxx if phi_yy is None else np.asarray(phi_yy, dtype=complex)
    speeds = np.asarray(rpm, dtype=float)
    if f.ndim != 1 or len(f) < 4 or pxx.shape != f.shape or pyy.shape != f.shape:
        raise InputError("the tool-point FRF needs at least 4 frequencies with one value each")
    if np.any(np.diff(f) <= 0) or f[0] <= 0:
        raise InputError("the FRF frequencies must be positive and strictly ascending")
    if not (int(teeth) == teeth and teeth >= 1):
        raise InputError(f"the number of teeth must be a whole number >= 1, got {teeth!r}")
    if not (ktc > 0 and np.isfinite(ktc)):
        raise InputError(f"K_tc must be > 0, got {ktc / 1e6:g} MPa")
    if not (krc >= 0 and np.isfinite(krc)):
        raise InputError(f"K_rc must be >= 0, got {krc / 1e6:g} MPa")
    if speeds.ndim != 1 or speeds.size == 0 or np.any(~(speeds > 0)) or np.any(~np.isfinite(speeds)):
        raise InputError("the spindle speeds must be finite and > 0 rpm")
    a = directional_factors(ae, diameter, milling, krc / ktc)
    fs, sxx, syy = _scan(f, pxx, pyy, int(refine))
    lam = _eigenvalues(sxx, syy, a)  # (2, n_scan)
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        kappa = lam.imag / lam.real
        a_lim = -2 * np.pi * lam.real * (1 + kappa**2) / (teeth * ktc)
        eps = np.pi - 2 * np.arctan(kappa)
    a_lim = np.where(np.isfinite(a_lim) & (a_lim > 0), a_lim, np.inf)
    a_crit = float(np.min(a_lim))
    omega = 2 * np.pi * fs

    n_lo = speeds.min()
    k_max = int(np.ceil(np.nanmax(60 * omega / (teeth * n_lo) / (2 * np.pi)))) + 1
    order = np.argsort(speeds)
    grid = speeds[order]
    best = np.full(len(grid), np.inf)
    chatter = np.full(len(grid), np.nan)
    curves = []
    for k in range(k_max + 1):
        n_k = 60 * omega[None, :] / (teeth * (eps + 2 * k * np.pi))
        for r in range(2):
            if _lower_envelope(grid, n_k[r], a_lim[r], fs, best, chatter):
                curves.append((k, np.where(np.isfinite(a_lim[r]), n_k[r], np.nan), a_lim[r]))
    out_a = np.empty_like(best)
    out_c = np.empty_like(chatter)
    out_a[order], out_c[order] = best, chatter
    warnings = []
    gap = ~np.isfinite(best)
    if gap.any():
        warnings.append(
            f"no lobe reaches {gap.sum()} of {len(grid)} speeds ({grid[gap].min():g}–{grid[gap].max():g} rpm): "
            f"their chatter frequencies lie outside the FRF's band ({f[0]:g}–{f[-1]:g} Hz); the limit there is unknown"
        )
    return Lobes(rpm=speeds, a_lim=out_a, chatter_hz=out_c, a_crit=a_crit, pockets=_pockets(grid, best),
                 curves=tuple(curves), warnings=tuple(warnings))


def _pockets(grid, a) -> tuple:
    """Local maxima of the boundary strictly inside the speed grid, highest first."""
    if len(grid) < 3:
        return ()
    fin = np.isfinite(a)
    i = np.flatnonzero((a[1:-1] > a[:-2]) & (a[1:-1] >= a[2:]) & fin[1:-1] & fin[:-2] & fin[2:]) + 1
    i = i[np.argsort(-a[i])]
    return tuple((float(grid[j]), float(a[j])) for j in i)
