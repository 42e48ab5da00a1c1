"""Time-domain milling with the regenerative delay, and modal fits of tool-point FRFs.

The tool point moves in x (feed) and y; each direction is a sum of uncoupled modes
(:class:`ModalSet`), receptance per direction (e^{iωt} convention, Im ≤ 0 below resonance)

    G(ω) = Σ_i (1/k_i) ω_i² / (ω_i² − ω² + 2iζ_i ω_i ω)     [m/N].

Cutting forces are linear in the chip thickness (Altintas 2012, *Manufacturing
Automation*, ch. 3; the same conventions as the zero-order lobes in lobes.py): tooth j at
angle φ_j (from the y axis, clockwise, feed along x) cuts

    h_j = f_t sin φ_j + (x(t) − x(t−τ)) sin φ_j + (y(t) − y(t−τ)) cos φ_j,
    F_t = a (K_tc h_j + K_te),  F_r = a (K_rc h_j + K_re),
    F_x = −F_t cos φ_j − F_r sin φ_j,  F_y = F_t sin φ_j − F_r cos φ_j,

with τ = 60 / (N rpm) the tooth period. With ``contact_loss`` (default) a tooth whose chip
thickness is negative leaves the cut (no force); the surface it meets next is still
taken as the previous tooth's path (single regeneration: a skipped pass is not
remembered). Without it the forces stay linear in x and the run is the linear delay
equation the lobes describe, so its growth per tooth period is the critical Floquet
multiplier's modulus.

Integration: the tooth period is cut into m equal steps (so x(t − τ) is a stored sample,
no interpolation), m ≥ max(``STEPS_PER_TOOTH``, ``STEPS_PER_PERIOD`` · τ · f_max,
``STEPS_PER_CUT`` / in-cut fraction), chosen so that the teeth enter and leave the cut on
step boundaries (the force's jumps are then integrated exactly). Over each step every mode is advanced exactly
(matrix exponential) under a force that varies linearly between the step's ends
(first-order hold); the force at the step's end depends on the position there, which is
solved exactly (a 2 × 2 linear system per step, the contact set taken from a predictor).
The loop over time is inherent to the delay; it is vectorised over modes, teeth and a
batch of depths.

Signatures::

    ModalSet(freq_hz, damping_ratio, stiffness_n_m)           # .frf(freq_hz)
    simulate_milling(modes_x, modes_y, *, teeth, ktc, krc, diameter, ae, milling, rpm, depth,
                     duration_s, fs, feed_per_tooth, kte=0, kre=0, rng=None,
                     contact_loss=True) -> MillingRun
    modal_fit(freq_hz, frf, *, max_modes=4, rel_level=0.05, tolerance=0.15, what="FRF") -> ModalFit
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from taptune.errors import InputError
from taptune.machine.engagement import engagement_angles

#: Fewest integration steps per tooth period, per period of the fastest mode, per cut arc.
STEPS_PER_TOOTH = 100
STEPS_PER_PERIOD = 40
STEPS_PER_CUT = 40
#: MillingRun.flip: the median cosine between successive once-per-period differences below this.
FLIP_COSINE = -0.99


@dataclass(frozen=True)
class ModalSet:
    """Uncoupled modes of one direction of the tool point.

    Attributes
    ----------
    freq_hz : tuple of float
        Natural frequencies f_i [Hz], > 0.
    damping_ratio : tuple of float
        Viscous damping ratios ζ_i, in (0, 1).
    stiffness_n_m : tuple of float
        Modal stiffnesses k_i [N/m], > 0 (the static compliance of mode i is 1/k_i).
    """

    freq_hz: tuple
    damping_ratio: tuple
    stiffness_n_m: tuple

    def __post_init__(self):
        cols = [tuple(float(v) for v in np.atleast_1d(np.asarray(c, dtype=float)))
                for c in (self.freq_hz, self.damping_ratio, self.stiffness_n_m)]
        if not (len(cols[0]) == len(cols[1]) == len(cols[2])):
            raise InputError("a modal set needs one damping ratio and one stiffness per frequency")
        f, z, k = (np.array(c) for c in cols)
        if not (np.all(np.isfinite(f)) and np.all(f > 0)):
            raise InputError("modal frequencies must be finite and > 0 Hz")
        if not (np.all(z > 0) and np.all(z < 1)):
            raise InputError("modal damping ratios must lie in (0, 1)")
        if not (np.all(np.isfinite(k)) and np.all(k > 0)):
            raise InputError("modal stiffnesses must be finite and > 0 N/m")
        for name, c in zip(("freq_hz", "damping_ratio", "stiffness_n_m"), cols):
            object.__setattr__(self, name, c)

    @property
    def n_modes(self) -> int:
        return len(self.freq_hz)

    def frf(self, freq_hz) -> np.ndarray:
        """The receptance Σ (1/k) ω_i²/(ω_i² − ω² + 2iζω_iω) [m/N] at ``freq_hz``."""
        w = 2 * np.pi * np.asarray(freq_hz, dtype=float)[..., None]
        wn = 2 * np.pi * np.array(self.freq_hz)
        z, k = np.array(self.damping_ratio), np.array(self.stiffness_n_m)
        return np.sum(wn**2 / k / (wn**2 - w**2 + 2j * z * wn * w), axis=-1)

    def scaled(self, freq_factor=1.0, stiffness_factor=1.0) -> "ModalSet":
        """The same modes with frequencies and stiffnesses multiplied (scalars or one per mode)."""
        return ModalSet(np.array(self.freq_hz) * freq_factor, self.damping_ratio,
                        np.array(self.stiffness_n_m) * stiffness_factor)

    def to_dict(self) -> dict:
        return {"freq_hz": list(self.freq_hz), "damping_ratio": list(self.damping_ratio),
                "stiffness_n_m": list(self.stiffness_n_m)}


@dataclass(frozen=True)
class MillingRun:
    """A simulated cut, sampled at ``fs`` (SI: s, m, N).

    ``x_m``, ``y_m``, ``fx_n``, ``fy_n`` have shape (n,) for one depth, (depths, n) for a
    batch. ``growth`` is the growth factor of the vibration per tooth period (one per
    depth): the geometric mean over the second half of the run of the ratio of successive
    once-per-tooth-period state differences (the forced vibration repeats every period and
    cancels). Without contact loss it is the modulus of the critical Floquet multiplier:
    < 1 stable, > 1 chatter. ``flip`` is True where those differences alternate in sign
    (period doubling) rather than rotate (Hopf).
    """

    t_s: np.ndarray = field(repr=False)
    x_m: np.ndarray = field(repr=False)
    y_m: np.ndarray = field(repr=False)
    fx_n: np.ndarray = field(repr=False)
    fy_n: np.ndarray = field(repr=False)
    rpm: float = 0.0
    teeth: int = 0
    depth_m: np.ndarray = field(default=None, repr=False)
    growth: np.ndarray = field(default=None, repr=False)
    flip: np.ndarray = field(default=None, repr=False)
    steps_per_tooth: int = 0
    contact_loss: bool = True

    @property
    def tooth_period_s(self) -> float:
        return 60.0 / (self.rpm * self.teeth)

    def to_dict(self) -> dict:
        return {"rpm": self.rpm, "teeth": self.teeth, "depth_mm": (np.asarray(self.depth_m) * 1e3).tolist(),
                "growth_per_tooth_period": np.asarray(self.growth).tolist(), "flip": np.asarray(self.flip).tolist(),
                "steps_per_tooth": self.steps_per_tooth, "contact_loss": self.contact_loss}


def _mode_columns(modes_x: ModalSet, modes_y: ModalSet | None):
    """(direction index, ω_n [rad/s], ζ, k [N/m]) of every mode, x first."""
    sets = [(0, modes_x)] + ([(1, modes_y)] if modes_y is not None else [])
    d = np.concatenate([[i] * s.n_modes for i, s in sets]).astype(int)
    wn = np.concatenate([2 * np.pi * np.array(s.freq_hz) for _, s in sets])
    z = np.concatenate([np.array(s.damping_ratio) for _, s in sets])
    k = np.concatenate([np.array(s.stiffness_n_m) for _, s in sets])
    return d, wn, z, k


def _step_matrices(wn, z, k, h: float):
    """Exact one-step propagation of each mode under a linearly varying force.

    Returns (E, g0, g1): s(h) = E s(0) + g0 F(0) + g1 F(h) for s = (q, q̇), shapes (M, 2, 2),
    (M, 2), (M, 2). From the exponential of the augmented matrix [[A, b, 0], [0, 0, 1], [0, 0, 0]] h.
    """
    from scipy.linalg import expm

    m = len(wn)
    big = np.zeros((m, 4, 4))
    big[:, 0, 1] = 1.0
    big[:, 1, 0] = -wn**2
    big[:, 1, 1] = -2 * z * wn
    big[:, 1, 2] = wn**2 / k
    big[:, 2, 3] = 1.0
    e = expm(big * h)
    # Responses to F(0) held and to a ramp of unit slope; the ramp of the step is (F(h) − F(0)) / h.
    gamma1, gamma2 = e[:, :2, 2], e[:, :2, 3] / h
    return e[:, :2, :2], gamma1 - gamma2, gamma2


def _aligned(m0: int, cut_fraction: float) -> int:
    """The step count from ``m0`` to 2 m0 that puts a tooth's exit nearest a step boundary
    (entries lie on boundaries): the first within 2 % of a step, else the nearest."""
    frac = cut_fraction % 1.0
    if frac == 0.0:
        return m0
    ms = np.arange(m0, 2 * m0 + 1)
    miss = np.abs(ms * frac - np.round(ms * frac))
    good = np.flatnonzero(miss <= 0.02)
    return int(ms[good[0]] if good.size else ms[np.argmin(miss)])


def steps_per_tooth(rpm: float, teeth: int, f_max_hz: float, cut_fraction: float) -> int:
    """Integration steps per tooth period (module docstring)."""
    tau = 60.0 / (rpm * teeth)
    return int(max(STEPS_PER_TOOTH, np.ceil(STEPS_PER_PERIOD * tau * f_max_hz),
                   np.ceil(STEPS_PER_CUT / max(cut_fraction, 1e-6))))


def simulate_milling(modes_x: ModalSet, modes_y: ModalSet | None, *, teeth: int, ktc: float, krc: float,
                     diameter: float, ae: float, milling: str, rpm: float, depth, duration_s: float, fs: float,
                     feed_per_tooth: float, kte: float = 0.0, kre: float = 0.0, rng=None,
                     contact_loss: bool = True, steps: int | None = None) -> MillingRun:
    """Simulate a milling cut with the regenerative delay.

    Parameters
    ----------
    modes_x, modes_y : ModalSet
        Tool-point modes in x (feed) and y; ``modes_y=None`` is a rigid y.
    teeth : int
        Number of teeth N (evenly spaced, no helix, no runout).
    ktc, krc : float
        Cutting-force coefficients [N/m²]; ``kte``, ``kre`` edge coefficients [N/m].
    diameter, ae : float
        Tool diameter and radial depth of cut [m].
    milling : {"up", "down"}
    rpm : float
        Spindle speed [rpm].
    depth : float or array_like
        Axial depth of cut [m]; an array runs a batch (one trajectory per depth).
    duration_s, fs : float
        Length of the run [s] and output sample rate [Hz].
    feed_per_tooth : float
        Feed per tooth f_t [m].
    rng : numpy.random.Generator, optional
        When given, every mode starts from a random displacement of 0.1 µm rms (else at
        rest), so that chatter can build up from other than the entry transient.
    contact_loss : bool
        A tooth with a negative chip thickness leaves the cut (module docstring).
    steps : int, optional
        Integration steps per tooth period (default :func:`steps_per_tooth`).

    Returns
    -------
    MillingRun
    """
    if not (rpm > 0 and np.isfinite(rpm)):
        raise InputError(f"the spindle speed must be > 0 rpm, got {rpm!r}")
    if not (int(teeth) == teeth and teeth >= 1):
        raise InputError(f"the number of teeth must be a whole number >= 1, got {teeth!r}")
    if not (duration_s > 0 and fs > 0):
        raise InputError("the duration and the sample rate must be > 0")
    if not (feed_per_tooth >= 0):
        raise InputError(f"the feed per tooth must be >= 0 m, got {feed_per_tooth!r}")
    teeth = int(teeth)
    a = np.atleast_1d(np.asarray(depth, dtype=float))
    if a.ndim != 1 or np.any(~(a >= 0)) or np.any(~np.isfinite(a)):
        raise InputError("the axial depth of cut must be finite and >= 0 m")
    phi_st, phi_ex = engagement_angles(ae, diameter, milling)
    d, wn, z, k = _mode_columns(modes_x, modes_y)
    tau = 60.0 / (rpm * teeth)
    cut_fraction = (phi_ex - phi_st) / (2 * np.pi / teeth)
    m = int(steps) if steps else _aligned(steps_per_tooth(rpm, teeth, wn.max() / (2 * np.pi), cut_fraction),
                                          cut_fraction)
    h = tau / m
    n_steps = int(np.ceil(duration_s / h)) + 1
    e, g0, g1 = _step_matrices(wn, z, k, h)

    # Tooth geometry repeats every tooth period: per phase p of the m steps and tooth j.
    # Tooth 0 enters at t = 0, so every entry lies on a step boundary (and, with the step
    # count of _aligned, every exit nearly so). A force sample at a boundary has two values:
    # the left limit ends a step (the teeth cutting just before), the right limit starts
    # the next (just after); first-order hold is then exact at the jumps.
    omega = 2 * np.pi * rpm / 60.0
    phase = (phi_st + omega * h * np.arange(m)[:, None] + 2 * np.pi * np.arange(teeth)[None, :] / teeth) % (2 * np.pi)
    rel = (phase - phi_st) % (2 * np.pi)
    rel = np.where(rel > 2 * np.pi - 1e-9, 0.0, rel)
    width = phi_ex - phi_st
    arc_left = (rel > 1e-9) & (rel <= width + 1e-9)
    arc_right = (rel < width - 1e-9)
    s, c = np.sin(phase), np.cos(phase)
    u = np.stack([-(ktc * c + krc * s), ktc * s - krc * c], axis=-1)  # force per a·h, (m, N, 2)
    edge = np.stack([-(kte * c + kre * s), kte * s - kre * c], axis=-1)  # force per a
    w = np.stack([s, c], axis=-1)  # chip-thickness direction
    static = u * (feed_per_tooth * s)[..., None] + edge  # per tooth and a, (m, N, 2)
    h_all = np.einsum("pni,pnj->pnij", u, w)  # linear term per tooth, (m, N, 2, 2)
    h_left = np.einsum("pn,pnij->pij", arc_left, h_all)
    h_right = np.einsum("pn,pnij->pij", arc_right, h_all)
    f_left = np.einsum("pn,pni->pi", arc_left, static)
    f_right = np.einsum("pn,pni->pi", arc_right, static)

    sel = np.zeros((len(wn), 2))
    sel[np.arange(len(wn)), d] = 1.0
    gx = np.array([g1[d == i, 0].sum() for i in range(2)])  # x(h) per unit F(h), per direction

    nb = len(a)
    q = np.zeros((nb, len(wn)))
    v = np.zeros((nb, len(wn)))
    if rng is not None:
        q = rng.normal(0.0, 1e-7, size=q.shape)
    hist = np.zeros((nb, 2, m))  # x at step j is kept at j % m; zeros: the nominal surface before the cut
    x_rec = np.empty((n_steps, nb, 2))
    v_rec = np.empty((n_steps, nb, 2))
    f_rec = np.empty((n_steps, nb, 2))
    per_state = []
    x_rec[0] = q @ sel
    v_rec[0] = v @ sel
    hist[:, :, 0] = x_rec[0]
    force = np.zeros((nb, 2))
    f_rec[0] = force
    e00, e01, e10, e11 = e[:, 0, 0], e[:, 0, 1], e[:, 1, 0], e[:, 1, 1]
    a_col = a[:, None]
    for step in range(1, n_steps):
        p = step % m
        fm = force[:, d]
        bq = e00 * q + e01 * v + g0[:, 0] * fm
        bv = e10 * q + e11 * v + g0[:, 1] * fm
        xb = bq @ sel
        xd = hist[:, :, p].copy()
        dx = xb - xd
        if contact_loss:
            # Contact set from a predictor (the end force taken as the start force).
            xp = xb + gx * force
            chip = feed_per_tooth * s[p] + (xp - xd) @ w[p].T  # (nb, N)
            on = arc_left[p] & (chip > 0)
            hm = np.einsum("bn,nij->bij", on, h_all[p])
            f0 = on @ static[p]
        else:
            hm = np.broadcast_to(h_left[p], (nb, 2, 2))
            f0 = np.broadcast_to(f_left[p], (nb, 2))
        # F = a [H (xb + G F − x(t−τ)) + F0]  →  (I − a H G) F = a (H (xb − x(t−τ)) + F0)
        rhs = a_col * (np.einsum("bij,bj->bi", hm, dx) + f0)
        m00 = 1 - a * hm[:, 0, 0] * gx[0]
        m01 = -a * hm[:, 0, 1] * gx[1]
        m10 = -a * hm[:, 1, 0] * gx[0]
        m11 = 1 - a * hm[:, 1, 1] * gx[1]
        det = m00 * m11 - m01 * m10
        force = np.stack([(m11 * rhs[:, 0] - m01 * rhs[:, 1]) / det, (m00 * rhs[:, 1] - m10 * rhs[:, 0]) / det], axis=1)
        fm = force[:, d]
        q = bq + g1[:, 0] * fm
        v = bv + g1[:, 1] * fm
        x_now = q @ sel
        hist[:, :, p] = x_now
        # The right limit at this boundary starts the next step.
        if contact_loss:
            chip = feed_per_tooth * s[p] + (x_now - xd) @ w[p].T
            on = arc_right[p] & (chip > 0)
            force = a_col * (np.einsum("bn,nij,bj->bi", on, h_all[p], x_now - xd) + on @ static[p])
        else:
            force = a_col * ((x_now - xd) @ h_right[p].T + f_right[p])
        x_rec[step], v_rec[step], f_rec[step] = x_now, v @ sel, force
        if p == 0:
            per_state.append(np.concatenate([q, v / wn], axis=1))
    growth, flip = _growth(np.array(per_state))

    t = np.arange(0.0, duration_s, 1.0 / fs)
    j = np.minimum((t / h).astype(int), n_steps - 2)
    r = (t - j * h) / h
    # Cubic Hermite in position (velocities known), linear in force (a tooth's entry is a jump).
    h00, h10, h01, h11 = 2 * r**3 - 3 * r**2 + 1, r**3 - 2 * r**2 + r, -2 * r**3 + 3 * r**2, r**3 - r**2
    pos = (h00[:, None, None] * x_rec[j] + h10[:, None, None] * h * v_rec[j]
           + h01[:, None, None] * x_rec[j + 1] + h11[:, None, None] * h * v_rec[j + 1])
    frc = (1 - r)[:, None, None] * f_rec[j] + r[:, None, None] * f_rec[j + 1]
    one = np.ndim(depth) == 0

    def out(arr):
        arr = np.moveaxis(arr, 0, -1)  # (nb, n)
        return arr[0] if one else arr

    return MillingRun(t_s=t, x_m=out(pos[:, :, 0]), y_m=out(pos[:, :, 1]), fx_n=out(frc[:, :, 0]),
                      fy_n=out(frc[:, :, 1]), rpm=float(rpm), teeth=teeth, depth_m=a, growth=growth, flip=flip,
                      steps_per_tooth=m, contact_loss=bool(contact_loss))


def _growth(states) -> tuple[np.ndarray, np.ndarray]:
    """Growth factor per tooth period and flip flag from once-per-period states, shape (periods, nb, 2M)."""
    nb = states.shape[1] if states.ndim == 3 else 0
    if states.ndim != 3 or states.shape[0] < 6:
        return np.full(nb, np.nan), np.zeros(nb, bool)
    diff = np.diff(states, axis=0)  # the periodic forced response cancels
    norm = np.linalg.norm(diff, axis=2)
    half = diff.shape[0] // 2
    tail = np.log(np.maximum(norm[half:], 1e-300))
    slope = np.polyfit(np.arange(tail.shape[0]), tail, 1)[0]
    # Flip: successive differences point opposite ways (cosine of the angle near −1; a Hopf
    # multiplier at angle θ gives about cos θ, so only θ within ~8° of π passes).
    dots = np.sum(diff[half + 1:] * diff[half:-1], axis=2) / np.maximum(norm[half + 1:] * norm[half:-1], 1e-300)
    return np.exp(slope), np.median(dots, axis=0) < FLIP_COSINE


# --------------------------------------------------------------------------- modal fit

#: A peak must stand this many times above the dip separating it from any higher one
#: (noise ripples on a measured peak do not; two real modes do).
MIN_PROMINENCE = 1.25
#: The modal fit's band and weighting floor, relative to the FRF's peak (modal_fit).
FIT_LEVEL = 0.2
#: Starting damping ratio of a peak whose local fit fails.
DEFAULT_DAMPING = 0.03


def _prominence(mag, i: int) -> float:
    """|G| at the local top nearest grid index i over the higher of the lowest points
    between it and a higher value on each side (or the end of the band)."""
    i = int(np.clip(i, 0, len(mag) - 1))
    while True:  # climb to the local top (the grid point nearest a fitted frequency may sit beside it)
        j = i + (1 if i + 1 < len(mag) and mag[i + 1] > mag[i] else -1 if i > 0 and mag[i - 1] > mag[i] else 0)
        if j == i:
            break
        i = j
    lo, hi = i, i
    while lo > 0 and not mag[lo - 1] > mag[i]:
        lo -= 1
    while hi < len(mag) - 1 and not mag[hi + 1] > mag[i]:
        hi += 1
    left = mag[lo: i + 1].min() if lo > 0 else 0.0  # the band's end counts as a deep dip
    right = mag[i: hi + 1].min() if hi < len(mag) - 1 else 0.0
    return float(mag[i] / max(left, right, 1e-300))


@dataclass(frozen=True)
class ModalFit:
    """Modes fitted to one tool-point FRF and how well they reproduce it.

    ``rel_error`` is ‖G_fit − G‖ / ‖G‖ over the fitted band: the frequencies where |G| is at
    least ``FIT_LEVEL`` × its peak (where the chatter frequencies lie), widened by three
    half-power bandwidths around each mode.
    """

    modes: ModalSet
    rel_error: float
    band_hz: tuple

    def to_dict(self) -> dict:
        return {"modes": self.modes.to_dict(), "rel_error": self.rel_error, "band_hz": list(self.band_hz)}


def modal_fit(freq_hz, frf, *, max_modes: int = 6, rel_level: float = 0.05, tolerance: float = 0.15,
              what: str = "FRF") -> ModalFit:
    """Fit uncoupled viscous modes to a direct tool-point receptance.

    The prominent peaks of |G| (at least ``rel_level`` of the highest, at most
    ``max_modes``; each one's frequency and damping from
    :func:`taptune.machine.peaks.dominant_modes` on its own stretch) start the fit; the
    modal stiffnesses follow by linear least squares, then all three per mode are refined
    by nonlinear least squares over the band that matters for chatter (:class:`ModalFit`).

    Raises
    ------
    InputError
        One line naming ``what`` when no mode is found, a mode comes out with a negative
        or no stiffness, or the relative error exceeds ``tolerance``.
    """
    from scipy.optimize import least_squares

    from taptune.machine.peaks import dominant_modes

    f = np.asarray(freq_hz, dtype=float)
    g = np.asarray(frf, dtype=complex)
    mag = np.abs(g)
    if f.ndim != 1 or g.shape != f.shape or f.size < 8:
        raise InputError(f"{what}: a modal fit needs at least 8 frequencies with one value each")
    tops = np.flatnonzero((mag[1:-1] > mag[:-2]) & (mag[1:-1] >= mag[2:])) + 1
    tops = [i for i in tops[np.argsort(-mag[tops])]
            if mag[i] >= rel_level * mag.max() and _prominence(mag, i) >= MIN_PROMINENCE][:max_modes]
    start = []
    for i in tops:  # each peak's frequency and damping from a local fit on its own stretch
        near = np.abs(f - f[i]) <= 0.15 * f[i]
        found = [p for p in dominant_modes(f[near], g[near], "", rel_level=0.5, max_modes=1)
                 if np.isfinite(p.damping_ratio) and 0 < p.damping_ratio < 0.5]
        start.append((found[0].hz, found[0].damping_ratio) if found else (f[i], DEFAULT_DAMPING))
    if not start:
        raise InputError(f"{what}: no resonance peak to fit modes to (the lobes need at least one mode)")
    start.sort()
    # The band that decides the lobes: where |G| is large (the chatter frequencies lie
    # there), and each mode's own neighbourhood; misfit weighted relative to |G| but no
    # less than FIT_LEVEL of the peak, so that a low flank does not count as much as a peak.
    band = mag >= FIT_LEVEL * mag.max()
    for hz, zeta in start:
        band |= np.abs(f - hz) <= 3 * 2 * zeta * hz
    fb, gb = f[band], g[band]
    wb = 1.0 / np.maximum(np.abs(gb), FIT_LEVEL * mag.max())

    def basis(fn, zeta):
        w, wn = 2 * np.pi * fb[:, None], 2 * np.pi * fn[None, :]
        return wn**2 / (wn**2 - w**2 + 2j * zeta[None, :] * wn * w)

    fn0 = np.array([hz for hz, _ in start])
    z0 = np.array([zeta for _, zeta in start])
    b = basis(fn0, z0) * wb[:, None]
    lhs = np.concatenate([b.real, b.imag])
    rhs = np.concatenate([(gb * wb).real, (gb * wb).imag])
    comp, *_ = np.linalg.lstsq(lhs, rhs, rcond=None)
    comp = np.where(comp > 0, comp, 1e-3 * np.abs(comp).max())  # a negative start is kept tiny, then refined

    def resid(x):
        n = len(fn0)
        fit = basis(np.exp(x[:n]), np.exp(x[n:2 * n])) @ np.exp(x[2 * n:])
        r = (fit - gb) * wb
        return np.concatenate([r.real, r.imag])

    def jac(x):  # analytic: finite differences cost 3n + 1 residuals per step
        n = len(fn0)
        fn, zeta, c = np.exp(x[:n]), np.exp(x[n:2 * n]), np.exp(x[2 * n:])
        w, wn = 2 * np.pi * fb[:, None], 2 * np.pi * fn[None, :]
        den = wn**2 - w**2 + 2j * zeta[None, :] * wn * w
        b = wn**2 / den
        d_fn = wn * (2 * wn * den - wn**2 * (2 * wn + 2j * zeta[None, :] * w)) / den**2  # ∂B/∂log f_n
        d_z = -2j * zeta[None, :] * wn**3 * w / den**2  # ∂B/∂log ζ
        j = np.concatenate([d_fn * c, d_z * c, b * c], axis=1) * wb[:, None]
        return np.concatenate([j.real, j.imag])

    x0 = np.log(np.concatenate([fn0, z0, comp]))
    sol = least_squares(resid, x0, jac=jac, method="lm", max_nfev=50 * len(x0))
    n = len(fn0)
    fn, zeta, comp = np.exp(sol.x[:n]), np.exp(sol.x[n:2 * n]), np.exp(sol.x[2 * n:])
    if not (np.all(np.isfinite(sol.x)) and np.all(zeta < 1)):
        raise InputError(f"{what}: the modal fit did not converge (a damping ratio ≥ 1 or no finite mode)")
    keep = comp > 1e-6 * comp.max()  # a mode the refinement switched off
    modes = ModalSet(fn[keep], zeta[keep], 1.0 / comp[keep])
    err = float(np.linalg.norm(modes.frf(fb) - gb) / np.linalg.norm(gb))
    if not err <= tolerance:
        raise InputError(f"{what}: {len(fn0)} modes reproduce the FRF only to {err:.0%} (relative error over "
                         f"{fb[0]:g}–{fb[-1]:g} Hz; at most {tolerance:.0%} is usable for the lobes)")
    return ModalFit(modes=modes, rel_error=err, band_hz=(float(fb[0]), float(fb[-1])))
