"""Milling stability by semi-discretization: the regenerative delay kept, the cut intermittent.

The zero-order lobes (lobes.py) average the cutting forces over a revolution; with few
teeth or light radial cuts the force acts in short pulses and the average misses the
period-doubling (flip) lobes and misplaces the others. Here the delay equation of the
cut (tool-point modes from :func:`taptune.machine.simulate.modal_fit`, forces as in
:mod:`taptune.machine.simulate`, feed along x)

    ẏ = A y + a B H(t) (C y(t) − C y(t − T)),   T = 60 / (N rpm),

is turned into a map over one tooth period (its monodromy matrix Φ), and the cut is
stable when every eigenvalue (Floquet multiplier) of Φ lies inside the unit circle
(Insperger & Stépán 2002, Int. J. Numer. Meth. Eng. 55; 2004, Int. J. Numer. Meth. Eng.
61; Bayly et al. 2003 for the 2-D milling form). The multiplier that leaves the circle
tells the kind of chatter: real and negative is a **flip** (period doubling, chatter at
half the tooth-passing frequency and its odd multiples), complex is a **Hopf** (chatter
at a frequency unrelated to the tooth passing).

The discretisation:

* The period splits into the active part, where some tooth cuts, and the free flight;
  the free flight is one exact modal exponential, whatever its length.
* The active part is cut into steps, ``STEPS_PER_MODE`` per period of the fastest mode
  that matters (peak compliance ≥ ``RESOLVE_SHARE`` of the largest; and at least two
  between history nodes). Over each step the modes move exactly
  (modal exponential, closed form), the cutting force of the step acts at its midpoint
  (second-order accurate, like the first-order semi-discretization's step).
* The position one period back, x(t − T), is held at Chebyshev–Lobatto nodes over the
  previous active part (``p + 1`` of them, more the more mode periods the active part
  spans) and interpolated between them: the map's size is d + 2(p + 1) (d = twice the
  number of modes), independent of the step, so fine steps stay cheap. The steps between
  two nodes are folded into one map of the modal state first, so the full state is
  carried node to node. Up to ``MAX_NODES`` nodes (wide cuts at low speed; beyond, the
  zero-order lobes, with a warning naming the speed).
* The largest multiplier: all eigenvalues of a small map, a few Arnoldi steps on a large
  one (its residual checked).
* Everything that does not depend on the depth (propagators, kicks per unit depth) is
  computed once per batch of speeds and reused by every depth the search tries; a batch
  holds speeds whose node counts lie within ``GROUP_SPREAD`` of each other (the matrix
  size of its widest cut, cost ∝ n³, against a fixed overhead per step and batch).

The limit at one speed is the smallest depth whose largest multiplier reaches 1, found
by bracketing then regula falsi on log|μ| (bracket ``DEPTH_RTOL``, the root interpolated
inside it), vectorised over the speeds. Where lobes overlap, depth can be unstable in an
island below a stable band (or a weakly unstable band, |μ| barely above 1, under a stable
one): a limit far above the guide (the zero-order limit or the neighbours') is checked at
fractions of the guide and on up towards the limit in steps of ``ISLAND_STEP``, and searched
again from below when one of those depths chatters. Where a flip lobe meets a Hopf lobe, the
band below one kind's crossing chatters by the other kind: the multipliers at the last
stable depth tell (the flip branch, −min Re μ, or a complex |μ| near 1 under a flip
crossing), and there the search walks down from the limit in steps of CHECK_RATIO while
that branch stays near the circle or |μ| grows downward; a branch that rises and falls
again along the walk is searched for its top (parabola in log depth). Large jobs are
split into speed ranges of about equal time run in forked processes (``workers``, from the
main thread only; the ranges overlap by ``SEAM_OVERLAP``, each keeps its side of a seam and its
computed samples across it).
SDM speeds are sampled uniformly in the tooth period (``SAMPLES_PER_LOBE`` per lobe of the
fastest mode), between ``REL_SPACING_MIN`` and ``REL_SPACING_MAX`` apart in relative speed
(flip lobes are narrow), searched coarse first then midpoints (each from its neighbours'
limits), refined beside local extrema, narrowed down where the limit jumps between
neighbours (``JUMP_RATIO``; the grid across a jump takes the lower side), and interpolated
onto the requested grid (linear in the tooth period). Where lobes are narrower than the speed
window a machinist can hold (``DENSE_WINDOW``), they are sampled no closer than
``REL_SPACING_DENSE``, each local minimum gets ``DENSE_ROUNDS`` rounds of samples beside it
(a lobe's bottom is narrower than that spacing), and the limit reported is the lowest over
that window; there a sample that is stable at the highest limit computed nearby (or at the
local minimum's depth) cannot lower that lowest and is settled by that one evaluation,
unless it could hold a window's lowest itself (then it is searched: ``TIGHTEN_ROUNDS``).
``budget`` bounds the work (:func:`_cost`) from the fastest speed down (``AUTO_BUDGET`` for
``method="auto"``); slower speeds are left to the zero-order lobes with a warning naming
the speed.

Signatures::

    sdm_lobes(modes_x, modes_y, *, teeth, ktc, krc, diameter, ae, milling, rpm,
              depth_cap=inf, guide=None, workers=2, budget=None) -> SdmLobes
    sdm_growth(modes_x, modes_y, *, teeth, ktc, krc, diameter, ae, milling, rpm, depth,
               steps_per_mode=None, nodes=None) -> (|μ|max, μ)     # one speed, many depths
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from taptune.errors import InputError, TaptuneError
from taptune.machine.engagement import engagement_angles
from taptune.workers import ignore_interrupt

#: Steps per period of the fastest mode in the active part of a tooth period.
STEPS_PER_MODE = 24
#: Modes below this share of the largest peak compliance do not set the step (``_f_resolve``).
RESOLVE_SHARE = 0.1
#: History nodes: this many, plus NODES_PER_PERIOD per period of the fastest mode in the active part.
MIN_NODES = 8
NODES_PER_PERIOD = 3.5
#: Above this many nodes the speed is left to the zero-order lobes (a warning says where).
MAX_NODES = 140
#: Width of the final depth bracket (relative); the limit is interpolated inside it (log|μ| is
#: smooth in log a away from lobe crossings; at a crossing the error stays inside the bracket).
DEPTH_RTOL = 2e-2
#: Speed sampling: per lobe of the fastest mode, and the bounds of the relative spacing.
SAMPLES_PER_LOBE = 16
REL_SPACING_MIN = 0.0035
REL_SPACING_MAX = 0.005
REL_SPACING_DENSE = 0.01
#: Lobes narrower than this relative speed window (±1.5 %) are not resolved point by point.
DENSE_WINDOW = 0.015
#: Every COARSE-th sampled speed is searched from the guide, the others from their neighbours.
COARSE = 4
#: Rounds of extra samples beside each local minimum and maximum of the sampled limit.
REFINE_ROUNDS = 2
#: Neighbouring limits further apart than this ratio are a jump (a band that ends between them):
#: halved JUMP_ROUNDS times down to JUMP_WIDTH (relative speed); the grid between takes the lower.
JUMP_RATIO = 1.25
JUMP_ROUNDS = 4
JUMP_WIDTH = 0.0005
#: Each gap between samples is checked at its middle at DIP_RATIO × the lower side's limit (one
#: evaluation); where that chatters, a dip lies between them and it gets a sample.
DIP_RATIO = 0.97
#: Rounds of samples beside each local minimum where lobes are denser than the window.
DENSE_ROUNDS = 2
#: … where the samples are at most REL_SPACING_DENSE apart and at least this many per lobe of
#: the most compliant mode (whose lobes are the lowest).
DENSE_PER_LOBE = 2
#: Rounds (after the dense rounds) in which the samples settled from below that could hold a
#: window's lowest are searched (:func:`_window_setters`; one is enough: what is known for
#: sure only goes down, and the settled samples only get fewer).
TIGHTEN_ROUNDS = 1
#: A batch of speeds spans node counts up to this ratio (fewer, larger batches: less overhead per step).
GROUP_SPREAD = 1.25
#: Work (units of :func:`_cost`) ``stability_lobes(method="auto")`` gives the semi-discretization (a few s of one core).
AUTO_BUDGET = 1.0e7
#: Work (relative units of :func:`_cost`) above which the speeds are shared between processes.
PARALLEL_WORK = 2e5
#: Limits above this multiple of the guide (zero-order or neighbours' limit) are checked for an island below.
ISLAND_RATIO = 1.3
#: … at these multiples of the guide (flip lobes dip to ~0.6 of the zero-order limit), then up
#: towards the limit in steps of ISLAND_STEP (a weakly unstable band, |μ| ≤ 1.04, can lie between
#: the guide and a limit several times higher).
ISLAND_LEVELS = (0.55, 0.75, 1.0)
ISLAND_STEP = 1.25
ISLAND_HALVINGS = 2
#: A Hopf limit is checked for a flip band below it when a multiplier at its last stable depth
#: reaches within CHECK_NEAR of −1 along the negative real axis, a flip limit for a Hopf band
#: when a complex multiplier there lies within CHECK_NEAR of the unit circle …
CHECK_NEAR = 0.1
#: … stepping down by CHECK_RATIO while that multiplier stays within WALK_NEAR (the first
#: CHECK_FIRST steps) or grows, or |μ| grows downward, at most CHECK_STEPS times (a limit found
#: again lower is checked again, CHECK_PASSES rounds).
WALK_NEAR = 0.2
CHECK_FIRST = 2
CHECK_RATIO = 0.92
CHECK_STEPS = 9
CHECK_PASSES = 2
#: A branch that rose and fell again along the walk, peaking within HUMP_NEAR of the circle, is
#: searched for its top (parabola in log depth, HUMP_ROUNDS evaluations at most).
HUMP_NEAR = 0.05
HUMP_ROUNDS = 2
#: Monodromy matrices of at least this size get their largest multiplier from ARNOLDI_STEPS
#: Arnoldi steps (relative residual below ARNOLDI_TOL, else from ARNOLDI_MORE steps, else from all eigenvalues).
ARNOLDI_MIN = 32
ARNOLDI_STEPS = 16
#: … and ARNOLDI_MORE steps where that residual is too large.
ARNOLDI_MORE = 28
ARNOLDI_TOL = 1e-7
#: Speeds per batch of monodromy matrices (bounds the temporary arrays).
BATCH = 256


@dataclass(frozen=True)
class SdmLobes:
    """The semi-discretization boundary on a speed grid (SI: m).

    ``a_lim`` [m] per speed (inf where no depth up to ``depth_cap`` chatters),
    ``flip`` True where the critical multiplier is real and negative (period doubling),
    ``chatter_hz`` the dominant chatter frequency on the boundary (from the critical
    multiplier's angle, folded to the band of the modes), ``sample_rpm``/``sample_a``
    the speeds actually computed and their limits, ``warnings``.
    """

    rpm: np.ndarray = field(repr=False)
    a_lim: np.ndarray = field(repr=False)
    flip: np.ndarray = field(repr=False)
    chatter_hz: np.ndarray = field(repr=False)
    sample_rpm: np.ndarray = field(repr=False)
    sample_a: np.ndarray = field(repr=False)
    warnings: tuple = ()


def _modal(modes_x, modes_y):
    """(direction, ω_n, ζ, k) per mode, x first (modes_y None: rigid y)."""
    from taptune.machine.simulate import _mode_columns

    return _mode_columns(modes_x, modes_y)


def _geometry(teeth: int, ktc: float, krc: float, diameter: float, ae: float, milling: str):
    """(φ_st, φ_ex, active fraction of the tooth period, arc per tooth pitch)."""
    st, ex = engagement_angles(ae, diameter, milling)
    pitch = 2 * np.pi / teeth
    return st, ex, min(ex - st, pitch) / pitch


def _cutting_matrix(phase, teeth: int, ktc: float, krc: float, st: float, ex: float) -> np.ndarray:
    """H(φ) = Σ_j g_j u_j w_jᵀ [N/m² per unit depth], shape phase.shape + (2, 2); φ of tooth 0."""
    ang = phase[..., None] + 2 * np.pi * np.arange(teeth) / teeth
    ang = np.mod(ang, 2 * np.pi)
    g = (ang >= st - 1e-12) & (ang <= ex + 1e-12)
    s, c = np.sin(ang) * g, np.cos(ang) * g
    # u = (−(K_tc cos φ + K_rc sin φ), K_tc sin φ − K_rc cos φ), w = (sin φ, cos φ)
    ux, uy = -(ktc * c + krc * s), ktc * s - krc * c
    h = np.empty(phase.shape + (2, 2))
    h[..., 0, 0] = np.sum(ux * s, -1)
    h[..., 0, 1] = np.sum(ux * c, -1)
    h[..., 1, 0] = np.sum(uy * s, -1)
    h[..., 1, 1] = np.sum(uy * c, -1)
    return h


def _mode_propagator(wn, z, dt):
    """Exact free motion of each mode over dt: (e00, e01, e10, e11), each shape dt.shape + (M,)."""
    dt = np.asarray(dt, dtype=float)[..., None]
    wd = wn * np.sqrt(1 - z * z)
    decay = np.exp(-z * wn * dt)
    c, s = np.cos(wd * dt), np.sin(wd * dt)
    e00 = decay * (c + z * wn / wd * s)
    e01 = decay * s / wd
    e10 = -decay * wn * wn / wd * s
    e11 = decay * (c - z * wn / wd * s)
    return e00, e01, e10, e11


def _propagate(e, q, v):
    """Apply a mode propagator (e00, e01, e10, e11), each (b, M, 1), to modal rows q, v (b, M, n)."""
    e00, e01, e10, e11 = e
    q2 = e00 * q
    q2 += e01 * v
    v *= e11
    v += e10 * q
    return q2, v


@dataclass(frozen=True)
class _Plan:
    """Time grid of one batch (shared by its speeds, in fractions of the active part)."""

    nodes: np.ndarray  # Chebyshev–Lobatto node fractions, (p+1,)
    edges: np.ndarray  # step edges as fractions, (s+1,), containing every node
    node_step: np.ndarray  # step edge index of each node
    interp: np.ndarray  # Lagrange rows at the step midpoints, (s, p+1)


def _lagrange(nodes, t) -> np.ndarray:
    """Barycentric Lagrange interpolation rows (len(t), len(nodes)) on Chebyshev–Lobatto
    ``nodes`` (weights (−1)^j, halved at both ends: Berrut & Trefethen 2004, SIAM Rev. 46)."""
    w = (-1.0) ** np.arange(len(nodes))
    w[[0, -1]] *= 0.5
    d = t[:, None] - nodes[None, :]
    exact = np.isclose(d, 0.0, atol=1e-15)
    d = np.where(exact, 1.0, d)
    r = w / d
    r = r / r.sum(axis=1, keepdims=True)
    hit = exact.any(axis=1)
    r[hit] = exact[hit].astype(float)
    return r


def _plan(p: int, steps_between) -> _Plan:
    nodes = 0.5 * (1 - np.cos(np.pi * np.arange(p + 1) / p))
    edges = [0.0]
    node_step = [0]
    for k in range(p):
        q = int(steps_between[k])
        edges += list(nodes[k] + (nodes[k + 1] - nodes[k]) * np.arange(1, q + 1) / q)
        node_step.append(len(edges) - 1)
    edges = np.array(edges)
    mid = 0.5 * (edges[1:] + edges[:-1])
    return _Plan(nodes, edges, np.array(node_step), _lagrange(nodes, mid))


def _peak(cols) -> np.ndarray:
    """Peak compliance 1/(2ζk) of each mode [m/N]."""
    _, _, z, k = cols
    return 1.0 / (2 * z * k)


def _f_resolve(cols) -> float:
    """The frequency the steps and history nodes resolve [Hz]: the fastest mode whose peak
    compliance 1/(2ζk) is at least ``RESOLVE_SHARE`` of the most compliant one's (a faster,
    stiffer mode still moves exactly between kicks; it only sees coarser kicks)."""
    peak = _peak(cols)
    return float(cols[1][peak >= RESOLVE_SHARE * peak.max()].max() / (2 * np.pi))


def _f_dominant(cols) -> float:
    """The frequency [Hz] of the most compliant mode: its lobes are the lowest."""
    return float(cols[1][np.argmax(_peak(cols))] / (2 * np.pi))


def _nodes(periods):
    """History nodes (p) for an active part spanning ``periods`` periods of the resolved mode."""
    return np.ceil(MIN_NODES + NODES_PER_PERIOD * periods)


def _resolution(active_s, f_max: float, steps_per_mode: float | None, nodes: int | None):
    """(p, steps between successive nodes) for an active part of ``active_s`` seconds."""
    periods = active_s * f_max
    p = int(nodes) if nodes else int(np.clip(_nodes(periods), MIN_NODES, 10**6))
    frac = np.diff(0.5 * (1 - np.cos(np.pi * np.arange(p + 1) / p)))
    per_mode = STEPS_PER_MODE if steps_per_mode is None else steps_per_mode
    return p, np.maximum(2, np.ceil(frac * periods * per_mode)).astype(int)


@dataclass(frozen=True)
class _Steps:
    """The depth-independent part of the monodromy of a batch of speeds (one plan): the
    propagators between kicks and the kick per unit depth, for every step at once (step
    axis first, so that each step reads contiguous memory)."""

    first: tuple  # propagator to the first step's midpoint, 4 × (b, M, 1)
    between: tuple  # from step i's midpoint to step i+1's (the last: to the period's end), 4 × (s, b, M, 1)
    to_edge: tuple  # from step i's midpoint to its end (the history nodes), (e00, e01) × (s, b, M, 1)
    kq: np.ndarray  # velocity kick per unit depth from the modal displacements, (s, b, M, M) [1/(m s)]
    kh: np.ndarray  # … from the delayed x and y, (s, b, M, 2)
    sel_t: np.ndarray  # x and y from the modal displacements, (2, M)

    def take(self, idx) -> "_Steps":
        return _Steps(tuple(x[idx] for x in self.first), tuple(x[:, idx] for x in self.between),
                      tuple(x[:, idx] for x in self.to_edge), self.kq[:, idx], self.kh[:, idx], self.sel_t)


def _steps(cols, geom, teeth, ktc, krc, tau, plan: _Plan) -> _Steps:
    """Precompute :class:`_Steps` for tooth periods ``tau`` (b,)."""
    d, wn, z, k = cols
    st, ex, frac = geom
    nm = len(wn)
    active = frac * tau  # seconds
    h = np.diff(plan.edges)[None, :] * active[:, None]  # (b, s)
    tmid = 0.5 * (plan.edges[1:] + plan.edges[:-1])[None, :] * active[:, None]
    omega = 2 * np.pi / (teeth * tau)  # rad/s of the spindle
    hm = _cutting_matrix(st + omega[:, None] * tmid, teeth, ktc, krc, st, ex)  # (b, s, 2, 2)
    sel = np.zeros((nm, 2))
    sel[np.arange(nm), d] = 1.0
    # modal acceleration per newton, each mode from the force of its own direction
    kh = np.moveaxis(hm, 1, 0)[:, :, d, :] * ((wn * wn / k)[:, None] * h.T[..., None, None])
    free = (1 - frac) * tau
    gaps = 0.5 * h
    gaps[:, :-1] += 0.5 * h[:, 1:]
    gaps[:, -1] += free
    col = lambda e: tuple(np.ascontiguousarray(np.moveaxis(x, 1, 0)[..., None]) for x in e)  # noqa: E731
    return _Steps(tuple(x[..., None] for x in _mode_propagator(wn, z, 0.5 * h[:, 0])),
                  col(_mode_propagator(wn, z, gaps)), col(_mode_propagator(wn, z, 0.5 * h)[:2]),
                  np.ascontiguousarray(kh @ sel.T), np.ascontiguousarray(kh), sel.T.copy())


def _monodromy(steps: _Steps, depth, plan: _Plan) -> np.ndarray:
    """Monodromy matrices of a batch at depths ``depth`` (b,) → (b, n, n).

    State z = (q, v of every mode, x then y at the p + 1 nodes of the previous active part).
    Each step: exact free motion to its midpoint, the cutting impulse of the
    step, exact free motion on (to the next midpoint, or through the free flight to the
    period's end). The steps between two history nodes are first folded into one map of the
    modal state (and the delayed positions' impulses into one matrix), so the full state is
    carried node to node, not step to step.
    """
    s, b, nm, _ = steps.kq.shape
    p1 = len(plan.nodes)
    m2 = 2 * nm
    n = m2 + 2 * p1
    a = np.asarray(depth, dtype=float)[:, None, None]
    ii = np.arange(nm)
    akq = steps.kq * a  # velocity kick per modal displacement, (s, b, M, M)
    src = -steps.kh * a  # … per delayed x, y, (s, b, M, 2)
    e00, e01, e10, e11 = (x[..., 0][..., None, :] for x in steps.between)  # row scalings, (s, b, 1, M)

    # Backward through each node interval: (wq, wv) map the state after kick i to the state
    # after the interval's last kick (their q and v columns); g_i = wv · (impulse of step i).
    # Intervals are longest mid-way (Chebyshev nodes), so those still stepping form one slice.
    ns = plan.node_step
    length = np.diff(ns)
    last = ns[1:] - 1
    wq = np.zeros((p1 - 1, b, m2, nm))
    wv = np.zeros((p1 - 1, b, m2, nm))
    wq[:, :, ii, ii] = 1.0
    wv[:, :, nm + ii, ii] = 1.0
    g = np.empty((s, b, m2, 2))  # step-major while written (contiguous), turned step-last below
    for t in range(int(length.max())):
        live = np.flatnonzero(length > t)
        if live[-1] - live[0] + 1 == live.size:
            live = slice(live[0], live[-1] + 1)
        i = last[live] - t
        if t:
            q, v = wq[live], wv[live]
            q += v @ akq[i + 1]  # the kick of step i + 1
            f00, f01, f10, f11 = e00[i], e01[i], e10[i], e11[i]  # then free motion back to step i
            wq[live], wv[live] = q * f00 + v * f10, q * f01 + v * f11
        g[i] = wv[live] @ src[i]
    # State after an interval's last kick (the start, for the first) → after the next's last kick.
    wq += wv @ akq[ns[:-1]]
    j = last[:-1]
    first = tuple(x[..., 0][:, None, :] for x in steps.first)
    f00, f01, f10, f11 = (np.concatenate([f[None], e[j]]) for f, e in zip(first, (e00, e01, e10, e11)))
    fold = np.concatenate([wq * f00 + wv * f10, wq * f01 + wv * f11], axis=-1)  # (p, b, 2M, 2M)
    # Rows reading x, y at each interval's end node from the modal state.
    te0, te1 = steps.to_edge
    read = np.concatenate([te0[last][..., 0][..., None, :] * steps.sel_t, te1[last][..., 0][..., None, :] * steps.sel_t],
                          axis=-1)  # (p, b, 2, 2M)
    # Rows (speed, modal row, direction), steps along: each interval's impulses are one product.
    g = np.ascontiguousarray(g.reshape(s, b * m2 * 2).T)
    z = np.zeros((b, m2, n))
    z[:, ii, ii] = 1.0
    z[:, nm + ii, nm + ii] = 1.0
    spare = np.empty_like(z)
    phi = np.empty((b, n, n))
    hist = phi[:, m2:].reshape(b, 2, p1, n)  # x, y at each node (the history block: direction-major)
    hist[:, :, 0] = 0.0
    hist[:, :, 0, :nm] = steps.sel_t
    for c in range(p1 - 1):
        lo, hi = ns[c], ns[c + 1]
        np.matmul(fold[c], z, out=spare)
        z, spare = spare, z
        # Σ_i g_i ⊗ (interpolation row i): the delayed positions' impulses of the interval.
        z[:, :, m2:] += (g[:, lo:hi] @ plan.interp[lo:hi]).reshape(b, m2, 2 * p1)
        np.matmul(read[c], z, out=hist[:, :, c + 1])
    phi[:, :nm], phi[:, nm:m2] = _propagate(tuple(x[-1] for x in steps.between), z[:, :nm], z[:, nm:].copy())
    return phi


def _critical(phi, branches: bool = False):
    """(largest |μ|, that μ) of each monodromy matrix: all eigenvalues of small matrices, the
    dominant Ritz value of ``ARNOLDI_STEPS`` Arnoldi steps for large ones (the history's
    multipliers crowd near zero, the few near the unit circle converge first); a Ritz value
    whose residual is above ``ARNOLDI_TOL`` is recomputed from ``ARNOLDI_MORE`` steps, then
    from all eigenvalues.
    ``branches``: also, from the same eigenvalues (Ritz values), how far the flip branch
    reaches along the negative real axis (−min Re μ: continuous in depth, also where two real
    multipliers meet and turn into a complex pair) and the largest |μ| that is not real and
    negative (the Hopf branch)."""
    bad = ~np.isfinite(phi.sum(axis=(-2, -1)))  # overflowed far above any limit: unstable
    if bad.any():
        out = _critical(np.where(bad[:, None, None], 0.0, phi), branches)
        for x in out:
            x[bad] = np.inf
        return out
    if phi.shape[-1] < ARNOLDI_MIN:
        ev = np.linalg.eigvals(phi)
        rho, mu = _largest(ev)
        return (rho, mu, *_branches(ev)) if branches else (rho, mu)
    mu, res, ev = _arnoldi(phi, ARNOLDI_STEPS)
    bad = ~(res < ARNOLDI_TOL)
    if bad.any():  # a longer Krylov space for the few that have not converged
        ev = np.pad(ev, ((0, 0), (0, ARNOLDI_MORE - ev.shape[-1])))
        mu[bad], res[bad], ev[bad] = _arnoldi(phi[bad], ARNOLDI_MORE)
        bad &= ~(res < ARNOLDI_TOL)
    if bad.any():
        ev = ev if ev.shape[-1] >= phi.shape[-1] else np.pad(ev, ((0, 0), (0, phi.shape[-1] - ev.shape[-1])))
        ev[bad] = np.linalg.eigvals(phi[bad])
        mu[bad] = _largest(ev[bad])[1]
    return (np.abs(mu), mu, *_branches(ev)) if branches else (np.abs(mu), mu)


def _branches(ev) -> tuple[np.ndarray, np.ndarray]:
    """(−min Re μ, largest |μ| not real and negative) of each row of eigenvalues."""
    return -ev.real.min(axis=-1), np.max(np.where(_is_flip(ev), 0.0, np.abs(ev)), axis=-1)


def _largest(mu) -> tuple[np.ndarray, np.ndarray]:
    i = np.argmax(np.abs(mu), axis=-1)
    top = np.take_along_axis(mu, i[..., None], -1)[..., 0]
    return np.abs(top), top


def _arnoldi(phi, m: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Dominant Ritz value of ``m`` Arnoldi steps on each matrix (b, n, n), its relative
    residual |h_{m+1,m} y_m| / |μ| (Saad 2011, Numerical Methods for Large Eigenvalue
    Problems, § 6.2) and all Ritz values (b, m); classical Gram–Schmidt done twice keeps the
    basis orthogonal."""
    b, n, _ = phi.shape
    m = min(m, n - 1)
    basis = np.zeros((b, m + 1, n))
    hess = np.zeros((b, m + 1, m))
    start = np.random.default_rng(0).standard_normal(n)
    basis[:, 0] = start / np.linalg.norm(start)
    for j in range(m):
        w = (phi @ basis[:, j, :, None])[..., 0]
        for _ in range(2):
            h = (basis[:, :j + 1] @ w[..., None])[..., 0]
            w -= (h[:, None, :] @ basis[:, :j + 1])[:, 0]
            hess[:, :j + 1, j] += h
        norm = np.linalg.norm(w, axis=1)
        hess[:, j + 1, j] = norm
        basis[:, j + 1] = w / np.where(norm > 0, norm, 1.0)[:, None]
    small = hess[:, :m]
    ritz = np.linalg.eigvals(small)
    mu = ritz[np.arange(b), np.argmax(np.abs(ritz), axis=-1)]
    # Its Ritz vector by one step of inverse iteration (cheaper than all eigenvectors).
    try:
        y = np.linalg.solve(small - (mu * (1 + 1e-10))[:, None, None] * np.eye(m), np.ones((b, m, 1), complex))[..., 0]
        y /= np.linalg.norm(y, axis=1, keepdims=True)
    except np.linalg.LinAlgError:
        ritz, vec = np.linalg.eig(small)
        i = np.argmax(np.abs(ritz), axis=-1)
        mu, y = ritz[np.arange(b), i], vec[np.arange(b), :, i]
    res = np.abs(hess[:, m, m - 1] * y[:, m - 1]) / np.maximum(np.abs(mu), 1e-300)
    return mu, res, ritz


def _check_teeth(teeth) -> None:
    if isinstance(teeth, bool) or int(teeth) != teeth or teeth < 1:
        raise InputError(f"the number of teeth must be a whole number >= 1, got {teeth!r}")


def sdm_growth(modes_x, modes_y, *, teeth: int, ktc: float, krc: float, diameter: float, ae: float, milling: str,
               rpm: float, depth, steps_per_mode: float | None = None, nodes: int | None = None):
    """Largest Floquet multiplier |μ| and μ at one speed for each depth [m] (array)."""
    _check_teeth(teeth)
    if not (np.isfinite(rpm) and rpm > 0):
        raise InputError(f"the spindle speed must be finite and > 0 rpm, got {rpm!r}")
    cols = _modal(modes_x, modes_y)
    geom = _geometry(teeth, ktc, krc, diameter, ae, milling)
    a = np.atleast_1d(np.asarray(depth, dtype=float))
    tau = 60.0 / (rpm * teeth)
    p, between = _resolution(geom[2] * tau, _f_resolve(cols), steps_per_mode, nodes)
    plan = _plan(p, between)
    phi = _monodromy(_steps(cols, geom, teeth, ktc, krc, np.full(a.size, tau), plan), a, plan)
    return _critical(phi)


def _is_dense(tau, f_max: float):
    """Whether the lobes of a mode at ``f_max`` [Hz] are narrower than the window a machinist can
    hold at tooth period ``tau`` [s] (a lobe spans 1/(τ f) of the speed)."""
    return 1.0 / (f_max * tau) < 2 * DENSE_WINDOW


def _sample_speeds(rpm_lo: float, rpm_hi: float, teeth: int, f_max: float,
                   f_dom: float | None = None) -> tuple[np.ndarray, np.ndarray]:
    """SDM speeds (ascending) and whether each lies where the lobes are too dense to resolve
    (there DENSE_PER_LOBE samples per lobe of the most compliant mode at ``f_dom`` [Hz], at
    most REL_SPACING_DENSE apart)."""
    tau_lo, tau_hi = 60.0 / (rpm_hi * teeth), 60.0 / (rpm_lo * teeth)
    taus = [tau_lo]
    dense = [bool(_is_dense(tau_lo, f_max))]
    while taus[-1] < tau_hi:
        t = taus[-1]
        lobe = 1.0 / (SAMPLES_PER_LOBE * f_max)
        step = float(np.clip(lobe, REL_SPACING_MIN * t, REL_SPACING_MAX * t))
        is_dense = _is_dense(t, f_max)
        if is_dense:
            step = max(step, min(REL_SPACING_DENSE * t, 1.0 / (DENSE_PER_LOBE * f_dom)) if f_dom else REL_SPACING_DENSE * t)
        taus.append(min(t + step, tau_hi))
        dense.append(_is_dense(taus[-1], f_max))
    taus = np.array(taus)
    return 60.0 / (teeth * taus[::-1]), np.array(dense[::-1])


def sdm_lobes(modes_x, modes_y, *, teeth: int, ktc: float, krc: float, diameter: float, ae: float, milling: str,
              rpm, depth_cap: float = np.inf, guide=None, workers: int = 2, budget: float | None = None) -> SdmLobes:
    """Semi-discretization lobes on the speed grid ``rpm`` (module docstring).

    Parameters
    ----------
    modes_x, modes_y : ModalSet
        Tool-point modes in x (feed) and y (None: rigid).
    teeth, ktc, krc, diameter, ae, milling
        The cut (SI: N/m², m).
    rpm : array_like
        Spindle speeds [rpm], > 0.
    depth_cap : float
        Depths above this [m] are not searched (the flute length); a speed stable up to it
        gets inf.
    guide : callable, optional
        rpm array → a first guess of the limit [m] (e.g. the zero-order lobes); speeds
        the search starts from it, else from the static limit of the softest mode.
    workers : int
        Processes to share the speeds between (forked; 1: this process only). Used only
        when the work is large enough to pay for the start.
    budget : float, optional
        Work (units of :func:`_cost`; ``AUTO_BUDGET`` ≈ 3 s of one core) the speeds may take,
        from the fastest down; slower speeds are left to the zero-order lobes with a warning
        naming the speed. None: every speed up to ``MAX_NODES`` history nodes.

    Returns
    -------
    SdmLobes
    """
    _check_teeth(teeth)
    speeds = np.asarray(rpm, dtype=float)
    if speeds.ndim != 1 or speeds.size == 0 or np.any(~(speeds > 0)) or np.any(~np.isfinite(speeds)):
        raise InputError("the spindle speeds must be finite and > 0 rpm")
    if not (ktc > 0 and krc >= 0):
        raise InputError("K_tc must be > 0 and K_rc >= 0")
    cut = dict(teeth=teeth, ktc=ktc, krc=krc, diameter=diameter, ae=ae, milling=milling, depth_cap=depth_cap)
    budget = np.inf if budget is None else float(budget)
    if _can_fork(workers, speeds):
        samples, work, cutoff = _budgeted_work(modes_x, modes_y, speeds, cut, budget)
        if work.sum() >= PARALLEL_WORK:  # the work pays for the processes' start (~0.1 s)
            return _on_grid(speeds, *_sdm_parts(modes_x, modes_y, speeds, guide, cutoff, cut, workers, samples, work))
    return _on_grid(speeds, *_sdm_samples(modes_x, modes_y, rpm=speeds, guide=guide, budget=budget, **cut))


#: The speed ranges of :func:`_sdm_parts` overlap by this much (relative) on either side of a seam,
#: and are cut where their work, SPLIT_FIXED + (map size)² per sample, is equal.
SEAM_OVERLAP = 0.04
SPLIT_FIXED = 6000.0
_PARTS = None  # what forked part processes compute (inherited, not pickled: the guide is any callable)


def _sdm_parts(modes_x, modes_y, speeds, guide, cutoff, cut, workers, samples, work):
    """:func:`_sdm_samples` in ``workers`` forked processes, each on a speed range of equal
    time (the whole range's ``samples``, their ``work`` and the budget's ``cutoff`` speed, from
    :func:`_budgeted_work`) and overlapping its
    neighbours by SEAM_OVERLAP; each side of a seam keeps its own samples, and the samples each
    computed across it. One fork and no
    exchange between the parts: the phases of one range (neighbours guess each other's
    limits, islands, jumps, lobe bottoms) run without waiting for the others."""
    global _PARTS
    lo, hi = float(speeds.min()), float(speeds.max())
    cols = _modal(modes_x, modes_y)
    # Time per sample ≈ a fixed part (the search's Python, small arrays) + ∝ the map's size²
    # (measured: 0.2 ms an evaluation at n = 38, 2.9 ms at n = 246).
    p = _nodes(_periods(cols, samples, cut))
    cum = np.cumsum(np.where(work > 0, (2 * len(cols[1]) + 2 * (p + 1)) ** 2 + SPLIT_FIXED, 0.0))
    seams = [float(samples[min(np.searchsorted(cum, cum[-1] * k / workers), samples.size - 1)]) for k in range(1, workers)]
    edges = [lo] + seams + [hi]
    parts = []
    for k in range(workers):
        a, b = edges[k] * (1 - SEAM_OVERLAP if k else 1), edges[k + 1] * (1 + SEAM_OVERLAP if k < workers - 1 else 1)
        # (each samples its whole range: a grid with a gap at the seam still has its windows)
        parts.append((speeds[(speeds >= a) & (speeds <= b)], cutoff, (a, b)))
    _PARTS = (modes_x, modes_y, guide, cut, parts)
    try:
        out = _forked(_sdm_part, workers)
    finally:
        _PARTS = None
    # Each part's own side of the seams, and its computed samples across them (a lobe's narrow
    # bottom just across a seam, found by one part's refinement, is kept).
    keep = [((out[k][0] >= edges[k] if k else out[k][0] > -1) & (out[k][0] < edges[k + 1] if k < workers - 1 else True))
            | (out[k][2] & out[k][3]) for k in range(workers)]
    merged = [np.concatenate([o[i][m] for o, m in zip(out, keep)]) for i in range(7)]
    order = np.lexsort((merged[4], merged[0]))  # by speed; a speed both computed: the lower limit
    first = np.concatenate([[True], np.diff(merged[0][order]) > 0])
    merged = [x[order][first] for x in merged]
    warnings = tuple(dict.fromkeys(w for o in out for w in o[7]))
    return (*merged, warnings)


def _forked(fn, n: int) -> list:
    """``[fn(0), …, fn(n − 1)]``, each in a forked process of its own that sends its result
    (or its exception) through a pipe of its own.

    Plain processes, not a pool: on Ctrl-C (which the children leave to this process) or an
    error they are stopped at once, and with no queue shared between them a child stopped
    mid-message cannot leave a lock or half a message that this process waits on for ever.
    """
    import multiprocessing

    ctx = multiprocessing.get_context("fork")
    running = []
    settled = False
    try:
        for k in range(n):
            receive, send = ctx.Pipe(duplex=False)
            child = ctx.Process(target=_send_result, args=(fn, k, send), daemon=True)
            child.start()
            send.close()
            running.append((child, receive))
        out = []
        for child, receive in running:
            try:
                ok, value = receive.recv()
            except EOFError:
                child.join()
                # Killed (out of memory, say): one line, not a traceback.
                raise TaptuneError(f"a semi-discretization process ended without its result "
                                   f"(exit code {child.exitcode})") from None
            if not ok:
                raise value
            out.append(value)
        settled = True
        return out
    finally:
        for child, receive in running:
            if not settled and child.is_alive():
                child.terminate()
            child.join()
            receive.close()


def _send_result(fn, k: int, send) -> None:
    """Body of a :func:`_forked` child: (True, fn(k)) or (False, its exception) into ``send``."""
    ignore_interrupt()
    try:
        result = (True, fn(k))
    except Exception as err:  # noqa: BLE001 - raised again in the parent
        result = (False, err)
    send.send(result)
    send.close()


def _sdm_part(k: int):
    modes_x, modes_y, guide, cut, parts = _PARTS
    part, cutoff, span = parts[k]
    if part.size == 0:
        return tuple(np.zeros(0, t) for t in (float, bool, bool, bool, float, bool, float)) + ((),)
    return _sdm_samples(modes_x, modes_y, rpm=part, guide=guide, cutoff_rpm=cutoff, span=span,
                        ends=(k == 0, k == len(parts) - 1), **cut)


def _cost(modes_x, modes_y, samples, cut) -> np.ndarray:
    """Relative work per sampled speed: steps × modal rows × matrix size, plus the multiplier's
    (0 where the ZOA takes over)."""
    cols = _modal(modes_x, modes_y)
    periods = _periods(cols, samples, cut)
    p = _nodes(periods)
    n = 2 * len(cols[1]) + 2 * (p + 1)
    steps = np.maximum(2 * p, STEPS_PER_MODE * periods)
    eig = np.where(n < ARNOLDI_MIN, n ** 3 / 20, ARNOLDI_STEPS * n ** 2 / 4)
    return np.where(p <= MAX_NODES, steps * n * (len(cols[1]) / 6) ** 2 + eig, 0.0)


def _periods(cols, samples, cut) -> np.ndarray:
    """Periods of the resolved mode within one tooth's active part at each speed [rpm]."""
    geom = _geometry(cut["teeth"], cut["ktc"], cut["krc"], cut["diameter"], cut["ae"], cut["milling"])
    return geom[2] * 60.0 / (cut["teeth"] * samples) * _f_resolve(cols)


def _can_fork(workers: int, speeds) -> bool:
    """Whether speeds may go to ``workers`` forked processes (:func:`_sdm_parts`): only from the
    main thread (a fork from a thread of the app could copy a lock another thread holds) of a
    process that may have children."""
    import multiprocessing
    import threading

    if workers < 2 or speeds.max() / speeds.min() < 1.2 or "fork" not in multiprocessing.get_all_start_methods():
        return False
    if threading.current_thread() is not threading.main_thread():
        return False
    # A worker of a pool (taptune batch) is daemonic and may have no children; its pool
    # already keeps the cores busy.
    return not multiprocessing.current_process().daemon


def _budgeted_work(modes_x, modes_y, speeds, cut, budget):
    """The whole range's sample speeds, their work (:func:`_cost`), 0 where ``budget`` (spent
    from the fastest down) leaves them to the zero-order lobes, and the slowest speed the
    budget keeps (0: it keeps every speed)."""
    cols = _modal(modes_x, modes_y)
    f_max = cols[1].max() / (2 * np.pi)
    lo, hi = _sampled_range(float(speeds.min()), float(speeds.max()), cut["teeth"], f_max)
    samples, _ = _sample_speeds(lo, hi, cut["teeth"], f_max, _f_dominant(cols))
    work = _cost(modes_x, modes_y, samples, cut)
    kept = np.where(np.cumsum(work[::-1])[::-1] <= budget, work, 0.0)
    cut_off = (work > 0) & (kept == 0)
    return samples, kept, float(samples[kept > 0].min()) if cut_off.any() and (kept > 0).any() else 0.0


def _sampled_range(lo: float, hi: float, teeth: int, f_max: float, ends=(True, True)) -> tuple[float, float]:
    """The speeds [rpm] sampled for the grid ``lo``–``hi``: where lobes are denser than the
    window, the lowest within ±DENSE_WINDOW of the grid's end speeds (or of a speed alone)
    lies beyond them as often as not, so the samples go on past (``ends``: which ends are the
    grid's, not a seam between parts)."""
    lo *= (1 - DENSE_WINDOW) if ends[0] and _is_dense(60.0 / (teeth * lo), f_max) else 1.0
    hi *= (1 + DENSE_WINDOW) if ends[1] and _is_dense(60.0 * (1 + DENSE_WINDOW) / (teeth * hi), f_max) else 1.0
    return lo, hi


def _sdm_samples(modes_x, modes_y, *, teeth, ktc, krc, diameter, ae, milling, rpm, depth_cap, guide,
                 budget=np.inf, cutoff_rpm=0.0, span=None, ends=(True, True)):
    """The sampled limits of :func:`sdm_lobes` (``rpm`` checked): (sample speeds, dense, ok,
    shown, limits, flip, chatter frequencies, warnings), for :func:`_on_grid`; ``shown`` is
    False for the samples below the budget's cut-off that only the window above it needs."""
    speeds = np.asarray(rpm, dtype=float)
    cols = _modal(modes_x, modes_y)
    geom = _geometry(teeth, ktc, krc, diameter, ae, milling)
    f_max = cols[1].max() / (2 * np.pi)
    f_res = _f_resolve(cols)
    lo, hi = span if span else (float(speeds.min()), float(speeds.max()))
    lo, hi = _sampled_range(lo, hi, teeth, f_max, ends)
    if hi / lo - 1 < 1e-9:
        samples, dense = np.array([lo]), np.array([False])
    else:
        samples, dense = _sample_speeds(lo, hi, teeth, f_max, _f_dominant(cols))
        if samples.size > speeds.size and not dense.any():  # never more work than the grid itself
            samples = np.unique(speeds)  # (where lobes are denser than the window, its lowest needs them all)
            dense = np.zeros(samples.size, bool)
        if samples[0] < cutoff_rpm < samples[-1] and cutoff_rpm not in samples:
            # a part of a range computed in parts: the whole range's cut-off is a sample, where
            # one process has it (the speeds shown start there)
            samples = np.sort(np.append(samples, cutoff_rpm))
            dense = _is_dense(60.0 / (teeth * samples), f_max)
    tau = 60.0 / (teeth * samples)
    periods = geom[2] * tau * f_res
    ok = _nodes(periods) <= MAX_NODES
    warnings = []
    cut = dict(teeth=teeth, ktc=ktc, krc=krc, diameter=diameter, ae=ae, milling=milling)
    work = np.cumsum(_cost(modes_x, modes_y, samples, cut)[::-1])[::-1]  # from the fastest down
    # (a part of a range computed in parts takes the whole range's cut-off speed)
    over = ok & ((work > budget) | (samples < cutoff_rpm))
    cutoff = 0.0  # the speeds shown start here
    if over.any():
        ok &= ~over
        if ok.any():  # the window of the slowest speeds kept reaches below them
            cutoff = cutoff_rpm or samples[ok].min()
            ok |= over & dense & (samples >= cutoff * (1 - DENSE_WINDOW))
        warnings.append(f"below {cutoff_rpm or cutoff or samples[over].max():.0f} rpm the semi-discretization would "
                        "take more than a few seconds (`--method sdm` computes it); the zero-order lobes are used there")
    elif not ok.all():
        slow = samples[~ok]
        warnings.append(f"below {slow.max():.0f} rpm the cut spans too many vibration periods for the "
                        f"semi-discretization's history ({MAX_NODES} nodes); the zero-order lobes are used there")
    if guide is not None:
        start = np.asarray(guide(samples), dtype=float)
    else:
        start = np.full(samples.size, np.nan)
    k_min = np.min(cols[3])
    fallback = 2 * k_min * np.min(cols[2]) / ktc  # a static-like scale [m]
    start = np.where(np.isfinite(start) & (start > 0), start, fallback)
    run = (cols, geom, teeth, ktc, krc, f_res, depth_cap)
    # Every COARSE-th speed from the guide, the others from their neighbours' limits (a
    # tight first bracket: about half the evaluations).
    # (counted from the fastest speed: a range computed in parts picks the same ones)
    pos = samples.size - 1 - np.arange(samples.size)
    coarse = pos % COARSE == 0
    coarse[0] = True
    a_s = np.full(samples.size, np.inf)
    flip_s = np.zeros(samples.size, bool)
    chat_s = np.full(samples.size, np.nan)
    a_s[coarse], flip_s[coarse], chat_s[coarse] = _limits(run, tau[coarse], start[coarse], ok[coarse])
    rest = ~coarse
    known = coarse & ok & np.isfinite(a_s)
    screened, below = _screen_dense(run, samples, tau, dense & rest & ok, known, a_s, flip_s, chat_s)
    rest &= ~screened
    settled = screened.copy()  # limits known only from below (stable there)
    # The others level by level, each from the nearest limits known (the midpoints first): a
    # neighbour twice as close guesses about four times better, and a close guess is bracketed
    # in two evaluations.
    stride = COARSE
    while stride > 1 and rest.any():
        stride //= 2
        now = rest & (pos % stride == 0)
        if not now.any():
            continue
        warm = known.sum() >= 2
        guess = (np.interp(tau[now], tau[known][::-1], a_s[known][::-1]) if warm else start[now])
        guess = np.where(np.isfinite(below[now]), below[now], guess)
        a_s[now], flip_s[now], chat_s[now] = _limits(run, tau[now], guess, ok[now], warm=warm)
        rest &= ~now
        known |= now & ok & np.isfinite(a_s)
    # Islands are looked for under the lower of the guide and the neighbours' limits.
    guide_at = (lambda r: np.asarray(guide(r), dtype=float)) if guide is not None else (lambda r: np.full(r.size, np.inf))
    _islands(run, tau, a_s, flip_s, chat_s, np.minimum(guide_at(samples), _neighbour_min(a_s)), ok & ~screened)
    # The lowest points of the lobes (the critical depth lies there) and the pocket tops
    # are narrow: each local extremum of the samples gets two more rounds of samples beside it.
    # Then where the limit jumps between neighbours (a band that ends), the jump is narrowed
    # down by halving (the grid between takes the lower side, _on_grid). Where the lobes are
    # denser than the window (the lowest in it is reported) a lobe's bottom can fall between
    # samples 1 % apart: each local minimum gets DENSE_ROUNDS rounds of samples beside it.
    # A sample settled from below (its limit known to be at least that) that gives a window its
    # lowest makes the window read shallower than it is (up to 30 % on a lobe's flank where
    # lobes just got denser than the window), and a run of them looks like a lobe's bottom to
    # the dense rounds: those are searched before the dense rounds and after them.
    rounds = (["extrema"] * REFINE_ROUNDS + ["jumps"] * JUMP_ROUNDS + ["dips", "extrema", "tighten"]
              + ["dense"] * DENSE_ROUNDS + ["tighten"] * TIGHTEN_ROUNDS)
    grid = speeds[_is_dense(60.0 / (teeth * speeds), f_max)]
    for kind in rounds:
        fin = np.where(np.isfinite(a_s), a_s, np.inf)
        inner = np.arange(1, samples.size - 1)
        if kind == "extrema":
            ext = inner[((fin[inner] < fin[inner - 1]) & (fin[inner] <= fin[inner + 1]))
                        | ((fin[inner] > fin[inner - 1]) & (fin[inner] >= fin[inner + 1]) & np.isfinite(fin[inner]))]
            ext = ext[ok[ext] & ~dense[ext]]
            new = np.concatenate([0.5 * (samples[ext - 1] + samples[ext]), 0.5 * (samples[ext] + samples[ext + 1])])
        elif kind == "jumps":
            jump = np.flatnonzero(_jumps(samples, fin) & ok[:-1] & ok[1:] & ~dense[:-1] & ~dense[1:]
                                  & (samples[1:] / samples[:-1] - 1 > JUMP_WIDTH))
            new = 0.5 * (samples[jump] + samples[jump + 1])
        elif kind == "dips":  # a narrow dip between two samples that both sit above it
            gap = np.flatnonzero(ok[:-1] & ok[1:] & np.isfinite(fin[:-1]) & np.isfinite(fin[1:]))
            mid = 0.5 * (samples[gap] + samples[gap + 1])
            deep = DIP_RATIO * np.minimum(fin[gap], fin[gap + 1])
            new = mid[_growth(run, 60.0 / (teeth * mid), deep) >= 1.0] if gap.size else mid
        elif kind == "dense":
            # (an end sample lower than its one neighbour counts: the samples reach a window past
            # the grid's ends, so a lobe's bottom between the last two may lie in a window)
            pad = np.concatenate([[np.inf], fin, [np.inf]])
            low = np.flatnonzero(dense & ok & np.isfinite(fin) & (fin <= pad[:-2]) & (fin <= pad[2:]))
            new = np.concatenate([0.5 * (samples[low[low > 0] - 1] + samples[low[low > 0]]),
                                  0.5 * (samples[low[low < samples.size - 1]] + samples[low[low < samples.size - 1] + 1])])
        else:
            redo = _window_setters(samples, a_s, ok, settled, grid) if grid.size else np.zeros(0, int)
            new = np.zeros(0)
            if redo.size:
                known = ok & ~settled & np.isfinite(a_s)
                guess = a_s[redo]
                if known.sum() >= 2:  # (at least its lower bound)
                    guess = np.fmax(guess, np.interp(tau[redo], tau[known][::-1], a_s[known][::-1]))
                sub = _limits(run, tau[redo], guess, np.ones(redo.size, bool), warm=True)
                _islands(run, tau[redo], *sub, np.minimum(guide_at(samples[redo]), a_s[redo]), np.ones(redo.size, bool))
                a_s[redo], flip_s[redo], chat_s[redo] = sub
                settled[redo] = False
            fin = np.where(np.isfinite(a_s), a_s, np.inf)
        new = np.setdiff1d(new, samples)
        if new.size == 0:
            continue
        tau_n = 60.0 / (teeth * new)
        at = np.searchsorted(samples, new)
        left, right = np.clip(at - 1, 0, None), np.clip(at, None, samples.size - 1)
        low_side = np.where(fin[left] <= fin[right], left, right)  # the lower neighbour
        near = fin[low_side]
        a_n = np.full(new.size, np.inf)
        f_n = np.zeros(new.size, bool)
        c_n = np.full(new.size, np.nan)
        todo = np.ones(new.size, bool)
        if kind == "extrema":
            guess = np.interp(new, samples, np.where(np.isfinite(a_s), a_s, np.nan))
        else:  # from the lower side: its band may go on past the middle
            guess = near
        guess = np.where(np.isfinite(guess), guess, start[0])
        if kind == "dense":
            # Only a sample below the lobe's lowest so far can lower a window's lowest: one
            # evaluation there settles the others (their limit is at least that depth).
            calm = _growth(run, tau_n, guess) < 1.0
            a_n[calm], f_n[calm], c_n[calm] = guess[calm], flip_s[low_side][calm], chat_s[low_side][calm]
            settled_n, todo = calm, ~calm
        else:
            settled_n = np.zeros(new.size, bool)
        if todo.any():
            sub = _limits(run, tau_n[todo], guess[todo], np.ones(todo.sum(), bool), warm=True)
            _islands(run, tau_n[todo], *sub, np.minimum(guide_at(new), near)[todo], np.ones(todo.sum(), bool))
            a_n[todo], f_n[todo], c_n[todo] = sub
        samples, order = np.unique(np.concatenate([samples, new]), return_index=True)
        cat = lambda x, y: np.concatenate([x, y])[order]  # noqa: E731
        a_s, flip_s, chat_s = cat(a_s, a_n), cat(flip_s, f_n), cat(chat_s, c_n)
        dense = cat(dense, _is_dense(tau_n, f_max))
        ok = cat(ok, np.ones(new.size, bool))
        settled = cat(settled, settled_n)
        tau = 60.0 / (teeth * samples)
        start = cat(start, guess)
    return samples, dense, ok, samples >= cutoff, a_s, flip_s, chat_s, tuple(warnings)


def _window_setters(samples, a_s, ok, settled, grid) -> np.ndarray:
    """The samples ``settled`` from below (their limit known to be at least ``a_s``) that could
    hold the lowest of the windows (±DENSE_WINDOW) of the dense speeds ``grid`` [rpm]: those
    under the lowest known for sure in a window (a computed sample's, or the line between two
    at its edge; where that line runs from a settled sample, that sample too)."""
    use = ok if ok.any() else np.ones(ok.size, bool)
    fin = np.where(ok & np.isfinite(a_s), a_s, np.inf)
    lo_w, hi_w, edges = _windows(samples, grid)
    value, below, above, _ = _line(samples, a_s, use, edges)
    redo = []
    for i in range(grid.size):
        inside = np.arange(lo_w[i], hi_w[i])
        ends = [(value[k, i], below[k, i], above[k, i]) for k in range(2) if below[k, i] >= 0]
        sure = min([fin[inside][~settled[inside]].min(initial=np.inf)]
                   + [v for v, b, a in ends if not (settled[b] or settled[a])])
        redo += list(inside[settled[inside] & (fin[inside] < sure)])
        redo += [j for v, b, a in ends if v < sure for j in (b, a)]
    redo = np.unique(np.array(redo, dtype=int))
    return redo[settled[redo]]


def _windows(samples, grid):
    """The samples within ±DENSE_WINDOW of each speed of ``grid`` [rpm] (from, to: index
    ranges) and the windows' edges [rpm], shape (2, grid.size)."""
    edges = np.stack([grid * (1 - DENSE_WINDOW), grid * (1 + DENSE_WINDOW)])
    return np.searchsorted(samples, edges[0], "left"), np.searchsorted(samples, edges[1], "right"), edges


def _line(samples, a_s, use, at):
    """Limits at speeds ``at`` [rpm] from the samples ``use``: linear in the tooth period between
    them; across a jump the line would claim depths only the upper side has: the lower side
    there. Returns (limits, the sample below and the sample above each, whether they jump)."""
    idx = np.flatnonzero(use)
    s_use, a_use = samples[idx], a_s[idx]
    finite = np.isfinite(a_use)
    cap = a_use[finite].max() * 1e3 if finite.any() else 1.0
    out = np.interp(1.0 / at, 1.0 / s_use[::-1], np.where(finite, a_use, cap)[::-1])
    if idx.size < 2:
        none = np.full(np.shape(at), -1)
        return out, none, none, np.zeros(np.shape(at), bool)
    f_use = np.where(finite, a_use, np.inf)
    gap = np.clip(np.searchsorted(s_use, at) - 1, 0, idx.size - 2)
    at_jump = _jumps(s_use, f_use)[gap] & (at > s_use[gap]) & (at < s_use[gap + 1])
    return np.where(at_jump, np.minimum(f_use[gap], f_use[gap + 1]), out), idx[gap], idx[gap + 1], at_jump


def _vertex(x0, x1, x2, y0, y1, y2):
    """x of the vertex of the parabola through three points per column, kept inside (x0, x2)
    (the middle of the wider side where the parabola has no vertex there)."""
    with np.errstate(all="ignore"):
        den = (x0 - x1) * (y1 - y2) - (x1 - x2) * (y0 - y1)
        x = x1 - 0.5 * ((x0 - x1) ** 2 * (y1 - y2) - (x1 - x2) ** 2 * (y0 - y1)) / den
        lo, hi = np.minimum(x0, x2), np.maximum(x0, x2)
        fallback = 0.5 * (x1 + np.where(np.abs(x1 - x0) > np.abs(x2 - x1), x0, x2))
        return np.where(np.isfinite(x) & (x > lo) & (x < hi) & (den != 0), x, fallback)


def _jumps(samples, fin) -> np.ndarray:
    """Whether the limit jumps between neighbouring samples (ratio above JUMP_RATIO; inf: no
    depth chatters), per gap (samples.size − 1)."""
    lo, hi = np.minimum(fin[:-1], fin[1:]), np.maximum(fin[:-1], fin[1:])
    with np.errstate(invalid="ignore"):
        return np.isfinite(lo) & (hi > JUMP_RATIO * lo)


def _screen_dense(run, samples, tau, cand, known, a_s, flip_s, chat_s):
    """Where lobes are denser than the window a machinist can hold, the limit reported is the
    lowest sample within ±DENSE_WINDOW; a sample stable at the highest computed limit within
    twice that window cannot lower any window's lowest, so one evaluation there settles it:
    it takes that limit (and its chatter kind). Returns (settled samples, the depth each
    unsettled candidate chattered at: a start just above its limit; NaN elsewhere); fills
    ``a_s``, ``flip_s``, ``chat_s`` of the settled ones in place."""
    settled = np.zeros(samples.size, bool)
    below = np.full(samples.size, np.nan)
    idx = np.flatnonzero(cand)
    ref = np.flatnonzero(known)
    if idx.size == 0 or ref.size == 0:
        return settled, below
    lo = np.searchsorted(samples[ref], samples[idx] * (1 - 2 * DENSE_WINDOW), "left")
    hi = np.searchsorted(samples[ref], samples[idx] * (1 + 2 * DENSE_WINDOW), "right")
    top = np.array([ref[a + np.argmax(a_s[ref[a:b]])] if b > a else -1 for a, b in zip(lo, hi)])
    idx, top = idx[top >= 0], top[top >= 0]
    if idx.size == 0:
        return settled, below
    calm = _growth(run, tau[idx], a_s[top]) < 1.0
    j, t = idx[calm], top[calm]
    a_s[j], flip_s[j], chat_s[j] = a_s[t], flip_s[t], chat_s[t]
    settled[j] = True
    below[idx[~calm]] = a_s[top[~calm]]
    return settled, below


def _limits(run, tau, start, ok, warm: bool = False):
    """Limit, flip flag and chatter frequency at each tooth period ``tau`` where ``ok``
    (``warm``: ``start`` is a close guess, :func:`_search`)."""
    cols, geom, teeth, ktc, krc, f_max, depth_cap = run
    a_s = np.full(tau.size, np.inf)
    flip_s = np.zeros(tau.size, bool)
    chat_s = np.full(tau.size, np.nan)
    batches = _batches(run, tau, np.flatnonzero(ok))
    jobs = [(cols, geom, teeth, ktc, krc, tau[c], start[c], depth_cap, plan, warm) for c, plan in batches]
    for (chunk, _), out in zip(batches, (_search(*j) for j in jobs)):
        a_s[chunk], flip_s[chunk], chat_s[chunk] = out
    return a_s, flip_s, chat_s


def _neighbour_min(a) -> np.ndarray:
    """The lower of each sample's two neighbours' limits (inf beyond the ends)."""
    pad = np.concatenate([[np.inf], np.where(np.isfinite(a), a, np.inf), [np.inf]])
    return np.minimum(pad[:-2], pad[2:])


def _islands(run, tau, a_s, flip_s, chat_s, guide_a, ok) -> None:
    """Where lobes overlap, depth can chatter in an island below a stable band, and a search
    started from a neighbour's limit brackets only the crossing nearest to it. Limits above
    ISLAND_RATIO × the guide (the lower of the zero-order limit and the neighbouring samples'
    limits; a speed stable up to the depth cap counts as limited there) are checked at
    ISLAND_LEVELS × the guide and on up to the limit in steps of ISLAND_STEP, more finely where
    |μ| on that ladder comes near 1. Where one chatters, the limit is searched again downward
    from the lowest (in place)."""
    depth_cap = run[6]
    g = np.where(np.isfinite(guide_a) & (guide_a > 0), guide_a, np.nan)
    top = np.where(np.isfinite(a_s), a_s, depth_cap)
    check = np.flatnonzero(ok & np.isfinite(top) & np.isfinite(g) & (top > ISLAND_RATIO * g))
    if check.size == 0:
        return
    rungs = np.ceil(np.log(top[check] / (ISLAND_LEVELS[-1] * g[check])) / np.log(ISLAND_STEP)).astype(int) - 1
    levels = np.concatenate([ISLAND_LEVELS, ISLAND_LEVELS[-1] * ISLAND_STEP ** np.arange(1, max(rungs.max(), 0) + 1)])
    count = len(ISLAND_LEVELS) + np.maximum(rungs, 0)
    use = np.arange(levels.size)[None, :] < count[:, None]  # (check, levels)
    row, col = np.nonzero(use)
    rho = np.full(use.shape, np.nan)
    rho[row, col] = _growth(run, tau[check[row]], g[check[row]] * levels[col])
    lowest = np.where((rho >= 1.0).any(axis=1), levels[np.argmax(rho >= 1.0, axis=1)] * g[check], np.nan)
    # Where |μ| on the ladder comes within HUMP_NEAR of 1, a narrow band may lie between two
    # rungs: their geometric middles are tried, ISLAND_HALVINGS times (25 % → 6 % steps there).
    pts = [list(zip(g[check[i]] * levels[use[i]], rho[i, use[i]])) for i in range(check.size)]
    for _ in range(ISLAND_HALVINGS):
        rows, mids = [], []
        for i in np.flatnonzero(np.isnan(lowest)):
            p = sorted(pts[i])
            for (d0, r0), (d1, r1) in zip(p[:-1], p[1:]):
                if max(r0, r1) >= 1 - HUMP_NEAR:
                    rows.append(i)
                    mids.append(np.sqrt(d0 * d1))
        if not rows:
            break
        rows, mids = np.array(rows), np.array(mids)
        r_mid = _growth(run, tau[check[rows]], mids)
        for i, d, r in zip(rows, mids, r_mid):
            pts[i].append((d, r))
            if r >= 1.0:
                lowest[i] = np.fmin(lowest[i], d)
    redo = np.isfinite(lowest)
    if redo.any():
        idx = check[redo]
        a_s[idx], flip_s[idx], chat_s[idx] = _limits(run, tau[idx], lowest[redo], np.ones(idx.size, bool), warm=True)


def _batches(run, tau, idx):
    """Batches of similar node count (GROUP_SPREAD) among the speeds ``idx``: [(indices, plan)]."""
    cols, geom, teeth, ktc, krc, f_max, depth_cap = run
    periods = geom[2] * tau * f_max
    order = idx[np.argsort(periods[idx], kind="stable")]
    out = []
    while order.size:
        nodes = MIN_NODES + NODES_PER_PERIOD * periods[order]  # (unrounded: the spread between cuts)
        take = max(1, min(int(np.searchsorted(nodes, GROUP_SPREAD * nodes[0], "right")), BATCH))
        chunk, order = order[:take], order[take:]
        out.append((chunk, _plan(*_resolution(geom[2] * tau[chunk].max(), f_max, None, None))))
    return out


def _growth(run, tau, depth) -> np.ndarray:
    """Largest |μ| at tooth periods ``tau`` and depths ``depth`` (one each)."""
    cols, geom, teeth, ktc, krc, f_max, depth_cap = run
    rho = np.empty(tau.size)
    batches = _batches(run, tau, np.arange(tau.size))
    jobs = [(cols, geom, teeth, ktc, krc, tau[c], depth[c], plan) for c, plan in batches]
    for (chunk, _), out in zip(batches, (_growth_batch(*j) for j in jobs)):
        rho[chunk] = out
    return rho


def _growth_batch(cols, geom, teeth, ktc, krc, tau, depth, plan) -> np.ndarray:
    # (a speed tried at several depths, as on the islands' ladder, needs its steps once)
    once, where = np.unique(tau, return_inverse=True)
    steps = _steps(cols, geom, teeth, ktc, krc, once, plan)
    return _critical(_monodromy(steps if np.array_equal(once, tau) else steps.take(where), depth, plan))[0]


def _bracket(steps: _Steps, plan: _Plan, start, depth_cap, warm: bool):
    """Bracket and regula falsi of :func:`_search`: (lo, hi, log|μ| at each, μ at hi, and at lo
    the flip and Hopf branches of :func:`_critical`)."""
    b = start.size
    lo = np.zeros(b)  # largest depth known stable
    hi = np.full(b, np.inf)  # smallest known unstable
    glo = np.full(b, np.nan)  # log|μ| at lo (NaN: at zero depth, not evaluated)
    ghi = np.full(b, np.nan)
    mu_hi = np.full(b, np.nan + 0j)
    neg = np.full(b, np.nan)
    cplx = np.full(b, np.nan)
    # Warm: the first two trials straddle the guess by one final bracket's width.
    grow = np.full(b, 1 + 0.98 * DEPTH_RTOL if warm else 2.0)
    # (a warm start stays where it is under the cap: from half the cap the growing steps
    # could jump over a band between there and the start)
    trial = np.minimum((1 - 0.49 * DEPTH_RTOL if warm else 0.7) * start,
                       (1 - DEPTH_RTOL if warm else 0.5) * depth_cap if np.isfinite(depth_cap) else np.inf)
    done = np.zeros(b, bool)
    side = np.zeros(b, int)  # Illinois: which end was kept last time
    for _ in range(60):
        act = np.flatnonzero(~done)
        if act.size == 0:
            break
        rho, mu, ng, cx = _critical(_monodromy(steps.take(act), trial[act], plan), branches=True)
        g = np.log(rho)
        unstable = g >= 0
        for sel, is_unst in ((act[unstable], True), (act[~unstable], False)):
            gs = g[unstable] if is_unst else g[~unstable]
            if is_unst:
                hi[sel], ghi[sel], mu_hi[sel] = trial[sel], gs, mu[unstable]
            else:
                lo[sel], glo[sel], neg[sel], cplx[sel] = trial[sel], gs, ng[~unstable], cx[~unstable]
        # Next trial depth.
        nxt = trial.copy()
        for j in act:
            if not np.isfinite(hi[j]):
                if lo[j] >= depth_cap * (1 - 1e-9):
                    done[j] = True
                    continue
                nxt[j] = min(grow[j] * max(lo[j], trial[j]), depth_cap)
                grow[j] = grow[j] ** 2
                continue
            if lo[j] == 0 and np.isnan(glo[j]):
                nxt[j] = hi[j] / grow[j]
                grow[j] = grow[j] ** 2
                continue
            if hi[j] / lo[j] - 1 < DEPTH_RTOL:
                done[j] = True
                continue
            # Regula falsi in (log a, log|μ|), Illinois-weighted, kept inside the bracket.
            wl, wh = glo[j], ghi[j]
            if side[j] == 1:
                wl = 0.5 * wl
            elif side[j] == -1:
                wh = 0.5 * wh
            x0, x1 = np.log(lo[j]), np.log(hi[j])
            x = x0 - wl * (x1 - x0) / (wh - wl) if wh != wl else 0.5 * (x0 + x1)
            span = x1 - x0
            x = float(np.clip(x, x0 + 0.02 * span, x1 - 0.02 * span))
            # The root predicted next to the last trial: step just across it to close the bracket.
            xt = np.log(trial[j])
            tol = np.log1p(DEPTH_RTOL)
            if abs(x - xt) < 0.3 * tol and span > tol:
                x = float(np.clip(xt + np.sign(x - xt) * 0.8 * tol, x0 + 0.02 * span, x1 - 0.02 * span))
            nxt[j] = np.exp(x)
            side[j] = 1 if trial[j] == hi[j] else -1
        trial = nxt
    return lo, hi, glo, ghi, mu_hi, neg, cplx


def _search(cols, geom, teeth, ktc, krc, tau, start, depth_cap, plan, warm: bool = False):
    """Limiting depth per speed: bracket from ``start`` by growing factors (2, 4, 16 … cold; 1.04,
    1.08, 1.17 … ``warm``, when ``start`` is a neighbour's limit), then regula falsi on log|μ|
    (:func:`_bracket`). Where lobes meet, one kind can leave a short unstable band below the
    other's crossing that the bracket stepped over: a Hopf limit whose last stable depth still
    has a multiplier within CHECK_NEAR of −1 along the negative real axis (the flip branch,
    which left and re-entered the unit circle, or is about to turn complex), or a flip limit
    with a complex multiplier within CHECK_NEAR of the circle there, is checked below that
    depth, in steps of CHECK_RATIO while that multiplier stays within WALK_NEAR (first steps) or
    grows, or |μ| grows downward, and searched again downward from the first depth that
    chatters (about +10-20 % evaluations)."""
    b = tau.size
    steps = _steps(cols, geom, teeth, ktc, krc, tau, plan)
    lo, hi, glo, ghi, mu_hi, neg, cplx = _bracket(steps, plan, start, depth_cap, warm)
    for _ in range(CHECK_PASSES):
        flip = _is_flip(mu_hi)
        other = np.where(flip, cplx, neg)  # the other kind's branch at the last stable depth
        act = np.flatnonzero(np.isfinite(hi) & (other >= 1 - CHECK_NEAR))
        depth, last, last_br = lo[act], np.exp(glo[act]), other[act]
        found = np.full(b, np.nan)  # the highest checked depth that chatters
        # The walk's last three (log depth, branch) points: where the branch rose and fell
        # again near the circle, its hump may peak above 1 between two steps.
        x1, v1 = np.log(depth), last_br
        x2, v2 = np.full(act.size, np.nan), np.full(act.size, np.nan)
        humps = []
        for k in range(CHECK_STEPS):
            if act.size == 0:
                break
            depth = depth * CHECK_RATIO
            rho, _, ng, cx = _critical(_monodromy(steps.take(act), depth, plan), branches=True)
            found[act[rho >= 1.0]] = depth[rho >= 1.0]
            # Walk on down while the other kind's multiplier stays near the circle (for the
            # first CHECK_FIRST steps) or moves towards it, or |μ| grows downward (a hump below).
            br = np.where(flip[act], cx, ng)
            keep = (rho < 1.0) & (((k < CHECK_FIRST) & (br >= 1 - WALK_NEAR)) | (br > last_br) | (rho > last))
            hump = (rho < 1.0) & ~keep & (v1 > v2) & (v1 > br) & (v1 >= 1 - HUMP_NEAR)
            if hump.any():
                humps.append((act[hump], np.stack([x2[hump], x1[hump], np.log(depth[hump])]),
                              np.stack([v2[hump], v1[hump], br[hump]])))
            x2, v2, x1, v1 = x1[keep], v1[keep], np.log(depth[keep]), br[keep]
            act, depth, last, last_br = act[keep], depth[keep], rho[keep], br[keep]
        for idx, xs, vs in humps:
            top = _hump_top(steps.take(idx), plan, xs, vs, flip[idx])
            found[idx] = np.where(np.isnan(found[idx]), top, found[idx])
        idx = np.flatnonzero(np.isfinite(found))
        if idx.size == 0:
            break
        out = _bracket(steps.take(idx), plan, found[idx], depth_cap, True)
        for arr, new in zip((lo, hi, glo, ghi, mu_hi, neg, cplx), out):
            arr[idx] = new
    # Inside the final bracket: the root of log|μ| interpolated linearly in log a (the bracket's
    # geometric mean where a side's value is missing).
    with np.errstate(all="ignore"):
        xl, xh = np.log(np.maximum(lo, 1e-300)), np.log(hi)
        x = xl - glo * (xh - xl) / (ghi - glo)
        x = np.where(np.isfinite(x) & (x >= xl) & (x <= xh), x, 0.5 * (xl + xh))
        out = np.where(np.isfinite(hi), np.exp(x), np.inf)
    out = np.where(np.isfinite(hi) & (lo == 0), hi, out)
    flip = np.isfinite(hi) & _is_flip(mu_hi)
    # Chatter frequency: the multiplier's angle θ gives f = (θ/2π + k)/T; the k nearest a mode is kept.
    theta = np.abs(np.angle(mu_hi))
    chatter = np.full(tau.size, np.nan)
    fin = np.isfinite(hi)
    if fin.any():
        fm = cols[1] / (2 * np.pi)
        t = tau[fin][:, None]
        kk = np.arange(0, 400)[None, :]
        th = theta[fin][:, None] / (2 * np.pi)
        cand = np.concatenate([(kk + th) / t, (kk + 1 - th) / t], axis=1)  # (f, 800) [Hz]
        dist = np.min(np.abs(cand[:, :, None] - fm[None, None, :]) / fm[None, None, :], axis=2)
        chatter[fin] = cand[np.arange(cand.shape[0]), np.argmin(dist, axis=1)]
    return out, flip, chatter


def _hump_top(steps: _Steps, plan: _Plan, xs, vs, flip) -> np.ndarray:
    """Depths [m] where a branch's hump, sampled at three log depths ``xs`` (3, h) with values
    ``vs`` (the middle one highest), chatters at its top (NaN where it stays stable): the
    parabola's vertex, refined HUMP_ROUNDS times through the best three points."""
    out = np.full(xs.shape[1], np.nan)
    act = np.arange(xs.shape[1])
    for _ in range(HUMP_ROUNDS):
        x = _vertex(*xs, *vs)
        rho, _, ng, cx = _critical(_monodromy(steps.take(act), np.exp(x), plan), branches=True)
        y = np.where(flip[act], cx, ng)
        hit = rho >= 1.0
        out[act[hit]] = np.exp(x[hit])
        # Keep the three points around the highest.
        pts_x = np.vstack([xs, x])
        pts_y = np.vstack([vs, y])
        order = np.argsort(pts_x, axis=0)
        pts_x, pts_y = np.take_along_axis(pts_x, order, 0), np.take_along_axis(pts_y, order, 0)
        best = np.clip(np.argmax(pts_y, axis=0), 1, 2)
        cols = np.arange(act.size)
        xs = np.stack([pts_x[best - 1, cols], pts_x[best, cols], pts_x[best + 1, cols]])
        vs = np.stack([pts_y[best - 1, cols], pts_y[best, cols], pts_y[best + 1, cols]])
        more = ~hit & (vs[1] >= 1 - HUMP_NEAR)
        act, xs, vs = act[more], xs[:, more], vs[:, more]
        if act.size == 0:
            break
    return out


def _is_flip(mu) -> np.ndarray:
    """Whether multipliers are real and negative (period doubling)."""
    return (mu.real < 0) & (np.abs(mu.imag) <= 1e-3 * np.abs(mu))


def _on_grid(speeds, samples, dense, ok, shown, a_s, flip_s, chat_s, warnings) -> SdmLobes:
    """Sampled limits onto the requested grid: linear in the tooth period; over the dense
    part the lowest limit within ±DENSE_WINDOW; NaN below the ``shown`` samples (left to the
    zero-order lobes)."""
    order = np.argsort(speeds)
    grid = speeds[order]
    if samples.size == 1:
        a = np.full(grid.size, a_s[0] if ok[0] else np.nan)
        fl = np.full(grid.size, flip_s[0])
        ch = np.full(grid.size, chat_s[0])
    else:
        use = ok if ok.any() else np.ones(ok.size, bool)  # speeds left to the ZOA take no part

        def line(at):
            return _line(samples, a_s, use, at)[0]

        a = line(grid)
        near = np.clip(np.searchsorted(samples, grid), 0, samples.size - 1)
        left = np.clip(near - 1, 0, samples.size - 1)
        near = np.where(np.abs(samples[left] - grid) < np.abs(samples[near] - grid), left, near)
        fl, ch = flip_s[near], chat_s[near]
        ch = np.where(fl, ch * grid / samples[near], ch)  # a flip chatters at (k + ½) f_T of its own speed
        inf_near = ~np.isfinite(a_s[near])
        a = np.where(inf_near, np.inf, a)
        if dense.any():
            lo_w, hi_w, ends = _windows(samples, grid)
            # On a steep flank the lowest lies at the window's edge, between samples.
            edges = line(ends).min(axis=0)
            in_dense = dense[near]
            lo_w = np.minimum(lo_w, samples.size - 1)
            for i in np.flatnonzero(in_dense):  # the lowest in the window, with its kind and frequency
                j = lo_w[i] + int(np.argmin(a_s[lo_w[i]: max(hi_w[i], lo_w[i] + 1)]))
                a[i], fl[i] = min(a_s[j], edges[i]), flip_s[j]
                ch[i] = chat_s[j] * grid[i] / samples[j] if flip_s[j] else chat_s[j]
        a = np.where(ok[near] & (grid >= samples[ok & shown].min() if (ok & shown).any() else False), a,
                     np.nan)  # left to the ZOA
    out_a, out_f, out_c = np.empty(grid.size), np.empty(grid.size, bool), np.empty(grid.size)
    out_a[order], out_f[order], out_c[order] = a, fl, ch
    return SdmLobes(rpm=speeds, a_lim=out_a, flip=out_f, chatter_hz=out_c, sample_rpm=samples, sample_a=a_s,
                    warnings=warnings)
