"""An independent reference for milling stability: piecewise Chebyshev collocation (spectral elements).

Written from the papers, sharing no code with :mod:`taptune.machine` (nothing here imports
it), and by a different method than taptune's semi-discretization, so that agreement
between the two means something.

The model (Insperger & Stépán 2004, Int. J. Numer. Meth. Eng. 61, section 6; Altintas
2012, *Manufacturing Automation*, ch. 3): feed along x, tooth angle φ_j measured clockwise
from the y axis, chip h_j = g_j [(x − x_τ) sin φ_j + (y − y_τ) cos φ_j] (the static feed
drops out of the stability problem), tangential and normal forces K_t a h_j and K_n a h_j,

    F_x = Σ_j −F_t cos φ_j − F_n sin φ_j,   F_y = Σ_j F_t sin φ_j − F_n cos φ_j,

so F(t) = a W(t) (r(t) − r(t − τ)), τ the tooth period. Down-milling cuts from
arccos(2a_e/D − 1) to π, up-milling from 0 to arccos(1 − 2a_e/D). The tool point is a sum
of uncoupled modes per direction (natural frequency, damping ratio, modal stiffness k:
q̈ + 2ζωq̇ + ω²q = ω²/k · F), x and y the sums of their modes.

The method (Butcher et al. 2004, Int. J. Numer. Meth. Eng. 59, "Stability of linear
time-periodic delay-differential equations via Chebyshev polynomials"; Khasawneh & Mann
2013, Commun. Nonlinear Sci. Numer. Simul. 18, spectral elements): the tooth period is split
at every instant a tooth enters or leaves the cut. Where no tooth cuts, the state moves by
the exact matrix exponential. Where teeth cut, the interval is split into elements (a
number per period of the fastest mode) and on each the solution is a polynomial of
degree ``degree`` collocated at the Chebyshev–Lobatto points: the differential equation
holds exactly at every point but the first, which is the previous element's last. The
delayed positions at those points are the positions at the same points one tooth period
earlier, so the map from (state at the period's start, positions at all collocation points
of the previous period) to the same one period later is the monodromy matrix; the cut is
stable when all its eigenvalues (Floquet multipliers) lie inside the unit circle. The
error falls exponentially with the degree (the coefficients are smooth between the
breakpoints): at a fixed element size the limit settles to 1e-6 long before the first-order
methods do (``convergence`` shows it).

The limiting depth at a speed is bracketed by a geometric scan of depth (ratio
``SCAN``) upward from a floor below every speed's limit; where |μ| has a local maximum
near 1 between scan points, the maximum is searched (golden section), so that a narrow
unstable island below a stable band is not stepped over. The bracket is then narrowed by
regula falsi on log|μ| against log depth to ``rtol``. The critical multiplier labels the chatter: real and
negative is flip (period doubling), complex is Hopf.

    limits(modes, cut, rpm) -> Limits(rpm, a_lim [m], kind ["flip"/"hopf"/"fold"/""])
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.linalg import expm, lu_factor, lu_solve
from scipy.sparse.linalg import ArpackNoConvergence, eigs

#: Geometric ratio of the depth scan that brackets the limit.
SCAN = 1.12
#: A local maximum of |μ| above this between scan points is searched for an unstable island.
PEAK = 0.95
#: A multiplier is real when |Im μ| is below this fraction of |μ|.
REAL_TOL = 1e-3


@dataclass(frozen=True)
class Mode:
    """One tool-point mode: direction ("x" or "y"), natural frequency [Hz], damping ratio, modal stiffness [N/m]."""

    direction: str
    f_hz: float
    zeta: float
    k: float


@dataclass(frozen=True)
class Cut:
    """The cut: teeth, K_t and K_n [N/m²], diameter and radial depth a_e [m], "up" or "down"."""

    teeth: int
    kt: float
    kn: float
    diameter: float
    ae: float
    milling: str

    def arc(self) -> tuple[float, float]:
        """Entry and exit angle [rad] from the y axis, clockwise."""
        r = self.ae / self.diameter
        if r >= 1.0 - 1e-12:
            return 0.0, np.pi
        if self.milling == "up":
            return 0.0, float(np.arccos(1.0 - 2.0 * r))
        return float(np.arccos(2.0 * r - 1.0)), np.pi


@dataclass(frozen=True)
class Limits:
    """Limiting depth and the kind of chatter at each speed."""

    rpm: np.ndarray
    a_lim: np.ndarray  # [m], inf where nothing up to the cap chatters
    kind: np.ndarray  # "flip", "hopf" or "fold" per speed ("" where no limit)


def frf(modes, f_hz) -> tuple[np.ndarray, np.ndarray]:
    """Direct receptances G_xx, G_yy [m/N] at ``f_hz`` (e^{iωt}: Im ≤ 0 below resonance)."""
    f = np.asarray(f_hz, dtype=float)
    out = {"x": np.zeros(f.size, complex), "y": np.zeros(f.size, complex)}
    for m in modes:
        r = f / m.f_hz
        out[m.direction] += 1.0 / (m.k * (1.0 - r * r + 2j * m.zeta * r))
    return out["x"], out["y"]


def _cheb(n: int) -> tuple[np.ndarray, np.ndarray]:
    """Chebyshev–Lobatto points on [−1, 1], ascending, and the differentiation matrix (Trefethen 2000, ch. 6)."""
    x = -np.cos(np.pi * np.arange(n + 1) / n)
    c = np.ones(n + 1)
    c[0] = c[-1] = 2.0
    c *= (-1.0) ** np.arange(n + 1)
    dx = x[:, None] - x[None, :]
    d = np.outer(c, 1.0 / c) / (dx + np.eye(n + 1))
    d -= np.diag(d.sum(axis=1))
    return x, d


def _engaged(phi_tooth0: float, cut: Cut) -> list[int]:
    """The teeth in the cut when tooth 0 is at ``phi_tooth0`` (taken inside an interval between breakpoints)."""
    st, ex = cut.arc()
    phi = np.mod(phi_tooth0 + 2 * np.pi * np.arange(cut.teeth) / cut.teeth, 2 * np.pi)
    return [int(j) for j in np.flatnonzero((phi > st) & (phi < ex))]


def _directional(phi_tooth0, teeth: list[int], cut: Cut) -> np.ndarray:
    """W(φ) [N/m² per m of depth], shape (len, 2, 2): F = a W (r − r_τ), the given teeth cutting.

    The engaged teeth are fixed per interval between breakpoints, so that W is smooth up to
    and including the interval's ends (no test of the angle against the arc at an end point).
    """
    w = np.zeros((len(phi_tooth0), 2, 2))
    for j in teeth:
        phi = phi_tooth0 + 2 * np.pi * j / cut.teeth
        s, c = np.sin(phi), np.cos(phi)
        fx = -(cut.kt * c + cut.kn * s)  # force per unit chip in x, y
        fy = cut.kt * s - cut.kn * c
        w[:, 0, 0] += fx * s
        w[:, 0, 1] += fx * c
        w[:, 1, 0] += fy * s
        w[:, 1, 1] += fy * c
    return w


class Monodromy:
    """The collocated one-tooth-period map of a cut at one speed, as a function of depth."""

    def __init__(self, modes, cut: Cut, rpm: float, *, per_period: float = 2.0, degree: int = 10):
        self.n_modes = len(modes)
        nm = self.n_modes
        wn = np.array([2 * np.pi * m.f_hz for m in modes])
        z = np.array([m.zeta for m in modes])
        k = np.array([m.k for m in modes])
        dirs = np.array([0 if m.direction == "x" else 1 for m in modes])
        n = 2 * nm
        self.n = n
        a = np.zeros((n, n))
        a[:nm, nm:] = np.eye(nm)
        a[nm:, :nm] = -np.diag(wn * wn)
        a[nm:, nm:] = -np.diag(2 * z * wn)
        self.A = a
        self.C = np.zeros((2, n))  # x, y from the modal displacements
        self.C[dirs, np.arange(nm)] = 1.0
        self.B = np.zeros((n, 2))  # modal acceleration per newton in x, y
        self.B[nm + np.arange(nm), dirs] = wn * wn / k
        spin = 2 * np.pi * rpm / 60.0  # rad/s
        tau = 2 * np.pi / (cut.teeth * spin)
        self.tau = tau
        st, ex = cut.arc()
        # Instants in [0, τ) where a tooth enters or leaves (tooth 0 enters at t = 0).
        br = [0.0, tau]
        for j in range(cut.teeth):
            for edge in (st, ex):
                t = np.mod(edge - st - 2 * np.pi * j / cut.teeth, 2 * np.pi) / spin
                if 1e-12 * tau < t < tau * (1 - 1e-12):
                    br.append(t)
        br = np.unique(np.round(np.array(br) / tau, 12)) * tau
        f_max = wn.max() / (2 * np.pi)
        s, d = _cheb(degree)
        self.pieces = []  # ("free", expm) or ("cut", [element data])
        self.n_hist = 0
        for t0, t1 in zip(br[:-1], br[1:]):
            teeth = _engaged(st + spin * 0.5 * (t0 + t1), cut)
            if not teeth:
                self.pieces.append(("free", expm(a * (t1 - t0))))
                continue
            n_el = max(1, int(np.ceil((t1 - t0) * f_max * per_period)))
            edges = np.linspace(t0, t1, n_el + 1)
            els = []
            for e0, e1 in zip(edges[:-1], edges[1:]):
                h = e1 - e0
                t = e0 + 0.5 * (s + 1) * h
                w = _directional(st + spin * t[1:], teeth, cut)  # at the collocation points (not the first)
                dh = 2.0 / h * d
                bw = np.einsum("nk,ikl->inl", self.B, w)  # (p, n, 2): B W_i
                base = np.kron(dh[1:, 1:], np.eye(n))
                bwc = np.zeros_like(base)  # block diagonal B W_i C
                bw_cols = np.zeros((degree * n, 2 * degree))  # block diagonal B W_i
                for i in range(degree):
                    blk = slice(i * n, (i + 1) * n)
                    base[blk, blk] -= a
                    bwc[blk, blk] = bw[i] @ self.C
                    bw_cols[blk, 2 * i:2 * i + 2] = bw[i]
                rhs0 = np.zeros((degree * n, n + 2 * degree))
                rhs0[:, :n] = -np.kron(dh[1:, :1], np.eye(n))
                els.append((base, rhs0, bw_cols, bwc, self.n_hist))
                self.n_hist += degree
            self.pieces.append(("cut", els))
        self.degree = degree
        self.dim = n + 2 * self.n_hist

    def matrix(self, depth: float) -> np.ndarray:
        n, p, dim = self.n, self.degree, self.dim
        y = np.zeros((n, dim))  # the current state as a linear map of the monodromy's state
        y[:, :n] = np.eye(n)
        hist = np.zeros((2 * self.n_hist, dim))
        for kind, data in self.pieces:
            if kind == "free":
                y = data @ y
                continue
            for base, rhs0, bw, bwc, off in data:
                # Σ_j D_ij y_j − (A + a B W_i C) y_i = −a B W_i r_τ,i   (i = 1..p): the solution is a
                # linear map of the element's first state (carried in y) and of the delayed
                # positions at its points (columns of the monodromy's own state).
                lhs = base - depth * bwc
                rhs = rhs0.copy()
                rhs[:, n:] = -depth * bw
                part = lu_solve(lu_factor(lhs), rhs)
                sol = part[:, :n] @ y
                sol[:, n + 2 * off:n + 2 * (off + p)] += part[:, n:]
                sol = sol.reshape(p, n, dim)
                hist[2 * off:2 * (off + p)] = np.einsum("kn,pnd->pkd", self.C, sol).reshape(2 * p, dim)
                y = sol[-1]
        return np.vstack([y, hist])

    def critical(self, depth: float) -> complex:
        """The Floquet multiplier of largest modulus at ``depth`` [m]."""
        phi = self.matrix(depth)
        if self.dim <= 150:
            mu = np.linalg.eigvals(phi)
        else:  # Arnoldi (ARPACK) for the few largest: most multipliers of a delay map are near 0
            try:
                mu = eigs(phi, k=6, which="LM", ncv=32, tol=1e-12, v0=np.ones(self.dim),
                          return_eigenvectors=False)
            except ArpackNoConvergence:
                mu = np.linalg.eigvals(phi)
        return complex(mu[np.argmax(np.abs(mu))])


def kind_of(mu: complex) -> str:
    if abs(mu.imag) <= REAL_TOL * abs(mu):
        return "flip" if mu.real < 0 else "fold"
    return "hopf"


def limit_at(mono: Monodromy, start: float, *, rtol: float = 1e-5, cap: float = 1.0) -> tuple[float, str]:
    """(limiting depth [m], kind) at one speed: the scan from ``start`` [m] brackets the
    smallest depth where |μ| reaches 1 (down while unstable, up while stable), then regula
    falsi (Illinois) on log|μ| against log a narrows the bracket to ``rtol``."""
    def g(a):
        mu = mono.critical(a)
        return np.log(abs(mu)), mu

    a = start
    ga, mu = g(a)
    if ga >= 0:
        hi, ghi, mu_hi = a, ga, mu
        while True:  # down until stable
            a /= SCAN
            if a < 1e-9:
                return 0.0, ""
            ga, mu = g(a)
            if ga < 0:
                lo, glo = a, ga
                break
            hi, ghi, mu_hi = a, ga, mu
    else:
        lo, glo = a, ga
        before = None  # the scan point before lo
        while True:
            a *= SCAN
            if a > cap:
                return np.inf, ""
            ga, mu = g(a)
            if ga >= 0:
                hi, ghi, mu_hi = a, ga, mu
                break
            if before is not None and glo > before[1] and glo > ga and glo > np.log(PEAK):
                # |μ| peaks below 1 between scan points: an island may hide between them.
                a_p, g_p, mu_p = _peak(g, before[0], a)
                if g_p >= 0:
                    hi, ghi, mu_hi = a_p, g_p, mu_p
                    if a_p < lo:
                        lo, glo = before
                    break
            before = (lo, glo)
            lo, glo = a, ga
    wl, wh, last = glo, ghi, 0  # Illinois weights: the end kept twice in a row counts half
    for _ in range(100):
        if hi / lo - 1 <= rtol:
            break
        x0, x1 = np.log(lo), np.log(hi)
        span = x1 - x0
        x = float(np.clip(x0 - wl * span / (wh - wl), x0 + 1e-3 * span, x1 - 1e-3 * span))
        a = float(np.exp(x))
        ga, mu = g(a)
        if ga >= 0:
            hi, ghi, mu_hi, wh = a, ga, mu, ga
            wl = 0.5 * wl if last == 1 else glo
            last = 1
        else:
            lo, glo, wl = a, ga, ga
            wh = 0.5 * wh if last == -1 else ghi
            last = -1
    x0, x1 = np.log(lo), np.log(hi)
    root = np.exp(x0 - glo * (x1 - x0) / (ghi - glo))
    return float(root), kind_of(mu_hi)


def _peak(g, a0: float, a1: float, rtol: float = 1e-5):
    """Golden-section search for the largest log|μ| between depths a0 and a1 (in log a): (a, log|μ|, μ)."""
    r = (np.sqrt(5) - 1) / 2
    x0, x1 = np.log(a0), np.log(a1)
    xa, xb = x1 - r * (x1 - x0), x0 + r * (x1 - x0)
    (ga, ma), (gb, mb) = g(np.exp(xa)), g(np.exp(xb))
    while x1 - x0 > rtol:
        if ga >= 0 or gb >= 0:
            break
        if ga > gb:
            x1, xb, gb, mb = xb, xa, ga, ma
            xa = x1 - r * (x1 - x0)
            ga, ma = g(np.exp(xa))
        else:
            x0, xa, ga, ma = xa, xb, gb, mb
            xb = x0 + r * (x1 - x0)
            gb, mb = g(np.exp(xb))
    return (float(np.exp(xa)), ga, ma) if ga >= gb else (float(np.exp(xb)), gb, mb)


def limits(modes, cut: Cut, rpm, *, per_period: float = 2.0, degree: int = 10, rtol: float = 1e-5,
           floor: float | None = None) -> Limits:
    """Limits at each speed of ``rpm``. Every speed's scan starts at ``floor`` [m] (default:
    0.6 × the lowest limit of a first pass in which each speed starts from its neighbour's
    limit), so that the lowest crossing is found even below an island of stability."""
    rpm = np.asarray(rpm, dtype=float)
    if floor is None:  # a coarse first pass (within ~1 % of the converged limits) for the floor
        guess = _static_scale(modes, cut)
        first = []
        for r in rpm:
            a, _ = limit_at(Monodromy(modes, cut, r, per_period=1, degree=6), guess, rtol=1e-2)
            first.append(a)
            if np.isfinite(a) and a > 0:
                guess = 0.7 * a
        floor = 0.6 * float(np.min(first))
    out = [limit_at(Monodromy(modes, cut, r, per_period=per_period, degree=degree), floor, rtol=rtol) for r in rpm]
    return Limits(rpm, np.array([a for a, _ in out]), np.array([k for _, k in out], dtype=str))


def _static_scale(modes, cut: Cut) -> float:
    """A depth well below any limit to start the first scan from [m]: 0.1 × 2kζ / K_t of the weakest mode."""
    return 0.1 * min(2 * m.k * m.zeta for m in modes) / cut.kt
