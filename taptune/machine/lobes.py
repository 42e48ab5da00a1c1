"""Milling stability lobes: the zero-order approximation here, and the entry point for all methods.

:func:`stability_lobes` (``method="zoa"|"sdm"|"auto"``) returns :class:`Lobes` from either the
zero-order lobes below or the semi-discretization of :mod:`taptune.machine.sdm` on modes
fitted to the FRFs (:func:`fit_modes`), with a depth cap (the flute length).

Zero-order approximation (Altintas & Budak 1995).

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

Speed (the Machine view redraws on a slider): the lobes are stacked in blocks and done
at once, and a lobe skips the segments whose both ends lie above an upper bound of the
boundary over the speeds it can reach (a first envelope from the low segments alone).
Skipped segments can never set the boundary, so the result is the same as lobe by lobe
(tests/machine/test_lobes.py checks it against a plain per-lobe route).

Chatter-frequency scan: every frequency of the FRF grid, plus ``refine`` extra points
per grid interval (cubic interpolation of the FRF in re and im) within ``REFINE_BANDS``
half-power bandwidths of each dominant peak of |Φxx|, |Φyy|, where the lobes are
steep. tests/machine/test_lobes.py shows that doubling ``refine`` moves the envelope by
less than 0.2 %.

Signatures::

    directional_factors(ae, diameter, milling, kr) -> (axx, axy, ayx, ayy)
    zoa_lobes(freq_hz, phi_xx, phi_yy, *, teeth, ktc, krc, diameter, ae, milling, rpm, refine=8) -> Lobes
    stability_lobes(freq_hz, phi_xx, phi_yy, *, teeth, ktc, krc, diameter, ae, milling, rpm,
                    refine=8, method="zoa", depth_cap=inf, modes=None) -> Lobes
    fit_modes(freq_hz, phi_xx, phi_yy) -> (ModalSet x, ModalSet y or None, notes)
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from taptune.errors import InputError
from taptune.machine.engagement import MILLING, engagement_angles  # noqa: F401 (engagement_angles is public here)
from taptune.machine.peaks import dominant_modes

MM = 1e-3
#: Fewest frequencies of a tool-point FRF the lobes are computed from.
MIN_FREQUENCIES = 4
#: Half-power bandwidths on each side of a dominant peak where the scan is refined.
REFINE_BANDS = 6.0
#: First pass of the envelope: segments with a limit below this many critical depths.
LOW_SEGMENTS = 4.0
#: Lobes × segments handled at once by the envelope (bounds its temporary arrays).
BLOCK_ELEMENTS = 500_000


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
    curves : sequence of (k, rpm ndarray, a_lim ndarray)
        Every lobe k (both roots) that reaches the grid, in chatter-frequency order over
        the scan (NaN/inf where a root gives no positive limit), for plots; a
        :class:`LobeCurves`, whose arrays are built when read.
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
    method: str = "zoa"
    flip: np.ndarray = field(default=None, repr=False)
    depth_cap: float = float("inf")
    modes: tuple = field(default=(), repr=False)
    notes: tuple = ()

    def on(self, part: slice) -> "Lobes":
        """The lobes on ``rpm[part]`` (an ascending grid's slice): pockets found again; the
        critical depth kept for the zero-order lobes (the minimum over their whole scan),
        the lowest limit on the slice otherwise."""
        from dataclasses import replace

        rpm, a = self.rpm[part], self.a_lim[part]
        if rpm.size == self.rpm.size:
            return self
        fin = a[np.isfinite(a)]
        crit = self.a_crit if self.method == "zoa" else (float(fin.min()) if fin.size else float("inf"))
        return replace(self, rpm=rpm, a_lim=a, chatter_hz=self.chatter_hz[part], a_crit=crit,
                       pockets=_pockets(rpm, a), flip=None if self.flip is None else self.flip[part])

    @property
    def instability(self) -> list[str]:
        """Per speed "flip" (period doubling: the critical Floquet multiplier is real and
        negative) or "hopf" (complex); the zero-order lobes know only "hopf"."""
        flip = np.zeros(len(self.rpm), bool) if self.flip is None else np.asarray(self.flip, bool)
        return ["flip" if f else "hopf" for f in flip]

    def to_dict(self) -> dict:
        """The ``lobes`` JSON (mm, rpm, Hz); non-finite values are null; depths above the
        cap are reported at the cap."""

        def num(v, scale=1.0):
            return float(v) / scale if np.isfinite(v) else None

        cap = self.depth_cap
        return {
            "method": self.method,
            "rpm": [float(r) for r in self.rpm],
            "a_lim_mm": [num(min(a, cap), MM) for a in self.a_lim],
            "a_crit_mm": num(min(self.a_crit, cap), MM),
            "pockets": [{"rpm": float(r), "a_lim_mm": min(float(a), cap) / MM} for r, a in self.pockets],
            "chatter_hz": [num(f) for f in self.chatter_hz],
            "instability": self.instability,
            "depth_cap_mm": num(cap, MM),
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


def _speeds(omega, eps, teeth: int, k):
    """n_k = 60 ω_c / (N (ε + 2kπ)) [rpm]; one expression everywhere, so every route agrees bitwise."""
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        return 60 * omega / (teeth * (eps + 2 * k * np.pi))


def _envelope(grid, omega, eps, a_lim, fs, teeth: int, limit):
    """Lower envelope of lobes k = 0 … len(limit) − 1 on the ascending speed grid.

    Returns (best [m], chatter [Hz]). Lobe k uses the valid scan segments (i, i+1) whose
    lower end is at most ``limit[k]`` [m] (non-increasing in k). All lobes of a block are
    done at once: each segment of each lobe is interpolated linearly in n_k onto the grid
    speeds it spans (its monotonic piece). Pairs are visited in the order (k, root,
    segment), and on equal limits the later one sets the chatter frequency.
    """
    best = np.full(len(grid), np.inf)
    chatter = np.full(len(grid), np.nan)
    ok = np.isfinite(a_lim) & np.isfinite(eps)
    lowest = np.minimum(a_lim[:, :-1], a_lim[:, 1:])
    seg = [np.flatnonzero(ok[r, :-1] & ok[r, 1:] & (lowest[r] <= limit[0])) for r in range(2)]
    s = np.concatenate(seg)
    root = np.repeat([0, 1], [len(seg[0]), len(seg[1])])
    low_end = lowest[root, s]
    by_low = np.argsort(low_end, kind="stable")
    kept = np.searchsorted(low_end[by_low], limit, "right")  # segments per lobe, non-increasing in k
    k0 = 0
    while k0 < len(limit) and kept[k0] > 0:
        # The lobes of a block use the segments of its first one, each masked to its own;
        # back in scan order, so that ties resolve as lobe by lobe.
        c = np.sort(by_low[: kept[k0]])
        halved = int(np.searchsorted(-kept, -(kept[k0] // 2), "left"))  # where a lobe keeps half as many
        block = max(1, min(BLOCK_ELEMENTS // c.size, halved - k0))
        k = np.arange(k0, min(k0 + block, len(limit)))[:, None]
        k0 += block
        sc, rc = s[c], root[c]
        w0, w1, e0, e1 = omega[sc], omega[sc + 1], eps[rc, sc], eps[rc, sc + 1]
        a0, da = a_lim[rc, sc], a_lim[rc, sc + 1] - a_lim[rc, sc]
        f0, df = fs[sc], fs[sc + 1] - fs[sc]
        n0, n1 = _speeds(w0, e0, teeth, k), _speeds(w1, e1, teeth, k)
        low, high = np.fmin(n0, n1), np.fmax(n0, n1)
        near = (high >= grid[0]) & (low <= grid[-1]) & np.isfinite(low) & np.isfinite(high)
        row, j = np.nonzero(near & (low_end[c][None, :] <= limit[k]))
        lo = np.searchsorted(grid, low[row, j], "left")
        # Most segments span no grid speed (the scan is finer than the grid): drop them
        # before the second search.
        span = np.flatnonzero(grid[np.minimum(lo, len(grid) - 1)] <= high[row, j])
        if span.size == 0:
            continue
        row, j, lo = row[span], j[span], lo[span]
        count = np.searchsorted(grid, high[row, j], "right") - lo
        which = np.repeat(np.arange(j.size), count)
        # Grid index of every (segment, speed) pair: lo of its segment plus its rank inside.
        start = np.cumsum(count) - count
        g = lo[which] + np.arange(which.size) - start[which]
        row, j = row[which], j[which]
        m0 = n0[row, j]
        dn = n1[row, j] - m0
        t = np.where(dn != 0, (grid[g] - m0) / np.where(dn != 0, dn, 1.0), 0.0)
        val = a0[j] + t * da[j]
        np.minimum.at(best, g, val)
        win = val <= best[g]
        chatter[g[win]] = (f0[j] + t * df[j])[win]
    return best, chatter


def _lobes_below(omega, eps, teeth: int, speed: float, strict: bool, k_cap: int):
    """Per scan point, how many lobes k = 0, 1, … put it above ``speed`` [rpm] (> if ``strict``, else ≥).

    n_k falls with k, so these lobes are a prefix: inverted analytically, then corrected
    with :func:`_speeds` itself so that the count agrees with the direct comparison
    (capped at ``k_cap``).
    """
    def above(k):
        n = _speeds(omega, eps, teeth, k)
        return n > speed if strict else n >= speed

    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        guess = np.ceil((60 * omega / (teeth * speed) - eps) / (2 * np.pi))
    k = np.clip(np.nan_to_num(guess, nan=0.0), 0, k_cap).astype(np.int64)
    for _ in range(64):
        up = (k < k_cap) & above(k)
        down = (k > 0) & ~above(np.maximum(k - 1, 0))
        if not (up.any() or down.any()):
            break
        k = k + up - down
    return k


def _reached(grid, omega, eps, a_lim, teeth: int, k_max: int) -> np.ndarray:
    """(k_max + 1, 2) bool: lobe k of root r reaches the speed grid.

    It does when a valid scan point lands inside the grid's span or a valid segment
    crosses all of it. Found per scan point from the range of k that puts it inside the
    span, without evaluating every lobe at every point.
    """
    out = np.zeros((k_max + 1, 2), bool)
    for r in range(2):
        ok = np.isfinite(a_lim[r]) & np.isfinite(eps[r])
        pair = ok[:-1] & ok[1:]
        if not pair.any():
            continue
        i = np.flatnonzero(ok)
        first = np.full(len(omega), k_max + 2)  # first lobe at or below the top speed
        last = np.full(len(omega), -1)  # last lobe at or above the bottom speed
        first[i] = _lobes_below(omega[i], eps[r, i], teeth, grid[-1], True, k_max + 2)
        last[i] = _lobes_below(omega[i], eps[r, i], teeth, grid[0], False, k_max + 2) - 1
        s = np.flatnonzero(pair)
        # Intervals of k: points inside the span, then segments from above it to below it (both ways).
        lo = np.concatenate([first[i], last[s + 1] + 1, last[s] + 1])
        hi = np.minimum(np.concatenate([last[i], first[s] - 1, first[s + 1] - 1]), k_max)
        use = lo <= hi
        edges = np.bincount(lo[use], minlength=k_max + 2)[: k_max + 2]
        edges -= np.bincount(hi[use] + 1, minlength=k_max + 2)[: k_max + 2]
        out[:, r] = np.cumsum(edges)[: k_max + 1] > 0
    return out


class LobeCurves(Sequence):
    """Every lobe that reaches the speed grid as (k, rpm ndarray, a_lim ndarray [m]), built on access.

    There can be a thousand lobes over the whole scan each; only a plot needs them, so the
    arrays are computed when an item is read (NaN speed where the root gives no limit).
    """

    def __init__(self, omega, eps, a_lim, teeth: int, which):
        self._omega, self._eps, self._a, self._teeth = omega, eps, a_lim, teeth
        self._which = tuple((int(k), int(r)) for k, r in which)

    def __len__(self) -> int:
        return len(self._which)

    def __getitem__(self, item):
        if isinstance(item, slice):
            return [self[j] for j in range(*item.indices(len(self)))]
        k, r = self._which[item]
        n = _speeds(self._omega, self._eps[r], self._teeth, k)
        return k, np.where(np.isfinite(self._a[r]), n, np.nan), self._a[r]


def zoa_lobes(freq_hz, phi_xx, phi_yy=None, *, teeth: int, ktc: float, krc: float, diameter: float,
              ae: float, milling: str, rpm, refine: int = 8) -> Lobes:
    """Zero-order stability lobes of a milling cut (Altintas & Budak 1995).

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
    if f.ndim != 1 or len(f) < MIN_FREQUENCIES or pxx.shape != f.shape or pyy.shape != f.shape:
        raise InputError(f"the tool-point FRF needs at least {MIN_FREQUENCIES} frequencies with one value each")
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
    # A segment of lobe k whose both ends lie above the boundary on every speed lobe k can
    # reach never sets it. First the boundary from the low segments alone (an upper bound
    # of the true one), then each lobe keeps the segments that may still come under it.
    first = np.full(k_max + 1, LOW_SEGMENTS * a_crit)
    best, chatter = _envelope(grid, omega, eps, a_lim, fs, teeth, first)
    if np.max(best) > first[0]:
        with np.errstate(divide="ignore"):
            reach = 60 * omega[-1] / (teeth * 2 * np.arange(k_max + 1) * np.pi) * (1 + 1e-9)  # n_k below this
        top = np.maximum.accumulate(best) * (1 + 1e-9)
        i = np.searchsorted(grid, reach, "right") - 1
        best, chatter = _envelope(grid, omega, eps, a_lim, fs, teeth, np.where(i >= 0, top[np.maximum(i, 0)], -np.inf))
    curves = LobeCurves(omega, eps, a_lim, teeth, np.argwhere(_reached(grid, omega, eps, a_lim, teeth, k_max)))
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
                 curves=curves, warnings=tuple(warnings))


def _pockets(grid, a) -> tuple:
    """Local maxima of the boundary strictly inside the speed grid, highest first."""
    if len(grid) < 3:
        return ()
    fin = np.isfinite(a)
    i = np.flatnonzero((a[1:-1] > a[:-2]) & (a[1:-1] >= a[2:]) & fin[1:-1] & fin[:-2] & fin[2:]) + 1
    i = i[np.argsort(-a[i])]
    return tuple((float(grid[j]), float(a[j])) for j in i)


METHODS = ("auto", "zoa", "sdm")


#: Modes whose peak compliance 1/(2ζk) is below this fraction of the strongest one's (in
#: either direction) are left out of the semi-discretization: they barely move the lobes
#: and a fast weak mode would set the step.
WEAK_MODE = 0.1


def fit_modes(freq_hz, phi_xx, phi_yy, what: str = "tool-point FRF"):
    """(ModalSet x, ModalSet y or None for a rigid y, notes) fitted to the tool-point FRFs,
    without the weak modes (``WEAK_MODE``); the notes say how well the fits reproduce the
    FRFs and what was left out."""
    from taptune.machine.simulate import modal_fit

    fx = modal_fit(freq_hz, phi_xx, what=f"{what} (x)")
    fits = {"x": fx}
    if phi_yy is None or phi_yy is phi_xx or np.array_equal(phi_yy, phi_xx):
        fits["y"] = fx
    elif np.max(np.abs(phi_yy)) < 1e-6 * np.max(np.abs(phi_xx)):
        fits["y"] = None
    else:
        fits["y"] = modal_fit(freq_hz, phi_yy, what=f"{what} (y)")
    peak = max(np.max(1 / (2 * np.array(ft.modes.damping_ratio) * np.array(ft.modes.stiffness_n_m)))
               for ft in fits.values() if ft is not None)
    notes, sets = [], {}
    for d, ft in fits.items():
        if ft is None:
            notes.append(f"{d}: rigid")
            sets[d] = None
            continue
        m = ft.modes
        strong = 1 / (2 * np.array(m.damping_ratio) * np.array(m.stiffness_n_m)) >= WEAK_MODE * peak
        sets[d] = type(m)(np.array(m.freq_hz)[strong], np.array(m.damping_ratio)[strong],
                          np.array(m.stiffness_n_m)[strong])
        weak = "" if strong.all() else f", {int((~strong).sum())} weak one(s) left out"
        notes.append(f"{d}: {m.n_modes} mode(s) reproduce the FRF to {100 * ft.rel_error:.1f} %{weak}")
    return sets["x"], sets["y"], notes


def stability_lobes(freq_hz, phi_xx, phi_yy=None, *, teeth: int, ktc: float, krc: float, diameter: float,
                    ae: float, milling: str, rpm, refine: int = 8, method: str = "zoa",
                    depth_cap: float = float("inf"), modes=None) -> Lobes:
    """Stability lobes of a milling cut, zero-order or by semi-discretization.

    Parameters
    ----------
    freq_hz, phi_xx, phi_yy, teeth, ktc, krc, diameter, ae, milling, rpm, refine
        As :func:`zoa_lobes` (SI: Hz, m/N, N/m², m).
    method : {"zoa", "sdm", "auto"}
        "zoa": the zero-order approximation (fast, the average force: a preview); "sdm":
        the semi-discretization of :mod:`taptune.machine.sdm` on modes fitted to the FRFs
        (flip and Hopf lobes of intermittent cuts; InputError when the modes cannot
        reproduce an FRF); "auto": SDM, or the ZOA with a warning when no modal fit
        reproduces the FRFs, and at the lowest speeds when the SDM would take more than
        a few seconds there (``AUTO_BUDGET``; a warning names the speed). Even slotting with two teeth differs by ≈ 10 % between
        the two, so "auto" never takes the average on trust.
    depth_cap : float
        Largest depth the tool can cut [m] (its flute length); :meth:`Lobes.to_dict`
        reports no limit above it and the SDM does not search beyond it.
    modes : (ModalSet, ModalSet or None), optional
        Tool-point modes in x and y for the SDM instead of fitting them to the FRFs.

    Returns
    -------
    Lobes
        ``method`` says which was used; ``flip`` per speed; ``notes`` how well the modes
        reproduce the FRFs.
    """
    from dataclasses import replace

    if method not in METHODS:
        raise InputError(f"the lobes method must be one of {', '.join(METHODS)}, got {method!r}")
    if not (depth_cap > 0):
        raise InputError(f"the depth cap must be > 0 mm, got {depth_cap / MM:g}")
    zoa = zoa_lobes(freq_hz, phi_xx, phi_yy, teeth=teeth, ktc=ktc, krc=krc, diameter=diameter, ae=ae,
                    milling=milling, rpm=rpm, refine=refine)
    zoa = replace(zoa, depth_cap=float(depth_cap))
    if method == "zoa":
        return zoa
    from taptune.machine.sdm import AUTO_BUDGET, sdm_lobes

    if modes is None:
        f = np.asarray(freq_hz, dtype=float)
        pyy = None if phi_yy is None else np.asarray(phi_yy, dtype=complex)
        try:
            mx, my, notes = fit_modes(f, np.asarray(phi_xx, dtype=complex), pyy)
        except InputError as err:
            if method == "sdm":
                raise
            return replace(zoa, warnings=zoa.warnings + (f"{err}; zero-order lobes instead (the flip lobes of an "
                                                         "intermittent cut are missing)",))
    else:
        (mx, my), notes = modes, []
    speeds = np.asarray(rpm, dtype=float)
    order = np.argsort(zoa.rpm)

    def guide(r):
        return np.interp(r, zoa.rpm[order], np.where(np.isfinite(zoa.a_lim), zoa.a_lim, zoa.a_crit)[order])

    s = sdm_lobes(mx, my, teeth=teeth, ktc=ktc, krc=krc, diameter=diameter, ae=ae, milling=milling, rpm=speeds,
                  depth_cap=depth_cap, guide=guide, budget=None if method == "sdm" else AUTO_BUDGET)
    gap = np.isnan(s.a_lim)  # speeds left to the zero-order lobes
    a = np.where(gap, zoa.a_lim, s.a_lim)
    chatter = np.where(gap, zoa.chatter_hz, s.chatter_hz)
    flip = np.where(gap, False, s.flip)
    order = np.argsort(speeds)
    grid, best = speeds[order], a[order]
    finite = a[np.isfinite(a)]
    a_crit = float(finite.min()) if finite.size else float("inf")
    return Lobes(rpm=speeds, a_lim=a, chatter_hz=chatter, a_crit=a_crit, pockets=_pockets(grid, best),
                 curves=(), warnings=tuple(w for w in zoa.warnings + s.warnings), method="sdm", flip=flip,
                 depth_cap=float(depth_cap), modes=(mx, my), notes=tuple(notes))
