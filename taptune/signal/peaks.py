"""Peaks: picking on the averaged spectrum, then sub-bin refinement by a pole fit.

Picking follows docs/physics.md §4 (local maxima of the dB spectrum with a prominence
threshold, parabolic interpolation over three bins). Parabolic interpolation is biased
by the neighbouring modes, the background and the zero-padding grid, by up to a few
0.01 % — as large as the accuracy we need. So each peak is refined by fitting the taps'
*complex* spectra around it with the exact DFT of a decaying sinusoid (one pole shared
by all taps, its own complex amplitude per tap) plus a complex linear background that
absorbs the other modes' tails and the onset uncertainty. Variable projection leaves
two nonlinear unknowns per pole: the damped frequency and the decay rate; the residues
and the background come from a linear least-squares solve. Reflections (the sound's
echo from the floor or a wall) are what is left: they skew wide peaks by up to a few
0.1 %; :func:`refine_peaks` starts the segments after the early ones and models a late
one explicitly (a delayed copy of every pole's column).

Frequencies are reported as the model defines them (docs/physics.md §3: ``sqrt(Re λ)/2π``
of the eigenvalue λ = −s² of the pole s = −σ + iω_d): f = √(ω_d² − σ²)/2π and
ζ = Im λ / (2 Re λ) = ω_d σ / (ω_d² − σ²).
"""

from __future__ import annotations

from dataclasses import asdict, dataclass
from typing import NamedTuple

import numpy as np


def _sparse_table(x: np.ndarray, op, fill: float) -> np.ndarray:
    """Row j holds op over x[i : i + 2**j] (padded with ``fill``): O(1) range queries."""
    rows = [x]
    span = 1
    while 2 * span <= x.size:
        prev = rows[-1]
        rows.append(np.concatenate([op(prev[:-span], prev[span:]), np.full(span, fill)]))
        span *= 2
    return np.array(rows)


def _range(table: np.ndarray, op, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """op over x[lo:hi] for each pair (hi > lo), from a :func:`_sparse_table`."""
    j = np.floor(np.log2(hi - lo)).astype(int)
    return op(table[j, lo], table[j, hi - (1 << j)])


def find_peaks(x, prominence: float | None = None):
    """Local maxima of x and their prominences, as ``scipy.signal.find_peaks`` defines them.

    A peak is a sample (or the middle of a flat run) higher than both neighbours, the
    ends excluded; its prominence is its height above the higher of the lowest points
    between it and the nearest higher sample on either side (or the signal's end).
    Written with numpy because importing ``scipy.signal`` costs ~0.6 s of start-up,
    more than the whole analysis of a recording.

    Returns
    -------
    peaks : ndarray of int
        Indices of the peaks whose prominence is at least ``prominence`` (all without it).
    properties : dict
        ``{"prominences": ndarray}`` when ``prominence`` is given, else empty.
    """
    x = np.asarray(x, dtype=np.float64)
    n = x.size
    # Runs of equal samples collapse to one value; a peak is a run higher than both neighbours.
    start = np.flatnonzero(np.r_[True, x[1:] != x[:-1]]) if n else np.zeros(0, dtype=int)
    end = np.r_[start[1:], n] - 1
    v = x[start]
    inner = np.flatnonzero((v[1:-1] > v[:-2]) & (v[1:-1] > v[2:])) + 1
    peaks = (start[inner] + end[inner]) // 2
    if prominence is None:
        return peaks, {}
    if peaks.size == 0:
        return peaks, {"prominences": np.zeros(0)}
    height = x[peaks]
    high = _sparse_table(x, np.maximum, -np.inf)
    low = _sparse_table(x, np.minimum, np.inf)
    step = 1 << int(np.ceil(np.log2(n)))
    # Nearest higher sample on the left (−1: none) and on the right (n: none), by binary
    # lifting on the range maximum, which only grows as the range widens.
    left = np.full(peaks.size, -1)
    right = np.full(peaks.size, n)
    while step:
        cand = left + step
        ok = cand < peaks
        ok[ok] = _range(high, np.maximum, cand[ok], peaks[ok]) > height[ok]
        left = np.where(ok, cand, left)
        cand = right - step
        ok = cand > peaks
        ok[ok] = _range(high, np.maximum, peaks[ok] + 1, cand[ok] + 1) > height[ok]
        right = np.where(ok, cand, right)
        step //= 2
    base = np.maximum(_range(low, np.minimum, left + 1, peaks + 1), _range(low, np.minimum, peaks, right))
    prom = height - base
    keep = prom >= prominence
    return peaks[keep], {"prominences": prom[keep]}


@dataclass(frozen=True)
class Peak:
    """A spectral peak.

    Attributes
    ----------
    hz : float
        Refined frequency [Hz] (undamped, as the model defines it).
    level_db : float
        Averaged spectrum at the peak [dB re the loudest peak].
    kind : str
        ``"bending"``, ``"local"`` or ``"other"``.
    mode : int or None
        1, 2, 3 for bending peaks.
    damping_ratio : float or None
        ζ from the pole fit (None when the fit failed).
    scatter_hz : float
        Standard deviation of the peak frequency from tap to tap [Hz] (0 for one tap).
    prominence_db : float
        Prominence in the averaged dB spectrum.
    snr_db : float
        Peak over the median of its surroundings [dB].
    note : str
        Why it got its kind (e.g. ``"interface band"``, ``"stationary (hum)"``).
    reliability : str
        ``"clear"`` (found by :func:`pick_peaks`) or ``"faint"`` (a few dB to ~15 dB over
        the noise, found only by the guided search of :func:`pick_faint_peaks`: there in
        every tap and resonance-shaped, but its frequency is less sure).
    """

    hz: float
    level_db: float
    kind: str = "other"
    mode: int | None = None
    damping_ratio: float | None = None
    scatter_hz: float = 0.0
    prominence_db: float = 0.0
    snr_db: float = 0.0
    note: str = ""
    reliability: str = "clear"

    def to_dict(self) -> dict:
        """Plain dict for JSON (contract keys ``hz, level_db, kind`` first)."""
        d = asdict(self)
        # 9 significant digits: 1e-5 Hz at 10 kHz, far below what the data carry.
        return {k: (float(f"{v:.9g}") if isinstance(v, float) else v) for k, v in d.items()}


def parabolic_peak(y, i):
    """Vertex of the parabola through ``y[i-1], y[i], y[i+1]``: (offset in bins, height)."""
    y = np.asarray(y, dtype=np.float64)
    i = np.asarray(i)
    a, b, c = y[i - 1], y[i], y[i + 1]
    den = a - 2 * b + c
    with np.errstate(divide="ignore", invalid="ignore"):
        d = np.where(den < 0, 0.5 * (a - c) / den, 0.0)
    d = np.clip(d, -0.5, 0.5)
    return d, b - 0.25 * (a - c) * d


def pick_peaks(freq_hz, mag, floor, *, prominence_db: float = 6.0, min_snr_db: float = 15.0,
               min_local_db: float = 12.0, ring_hz: float = 500.0, fmin_hz: float = 100.0,
               fmax_hz: float | None = None, max_peaks: int = 40,
               shoulder_prominence_db: float = 10.0, shoulder_snr_db: float = 30.0):
    """Local maxima of the dB spectrum that stand out from their surroundings and the floor.

    Prominence alone is a poor test on a noisy spectrum: the nulls of a noise-like
    spectrum make its bumps look prominent. A peak must also stand ``min_local_db``
    above the median of a ring around it (from 4 half-power widths out to
    ``ring_hz`` beyond), which a bump of a noise-like spectrum does in ~1e-5 of the
    bins (Rayleigh statistics), and ``min_snr_db`` above ``floor``.

    Parameters
    ----------
    freq_hz, mag, floor : ndarray, shape (m,)
        Uniform grid [Hz], linear magnitude and the noise floor (same units).
    prominence_db : float
        Minimum prominence in the dB spectrum.
    min_snr_db : float
        Minimum height above ``floor`` [dB].
    min_local_db : float
        Minimum height above the median of the ring around the peak [dB].
    ring_hz : float
        Width of that ring on each side [Hz].
    fmin_hz, fmax_hz : float
        Band searched [Hz].
    max_peaks : int
        Keep at most this many, those standing highest above their ring.
    shoulder_prominence_db, shoulder_snr_db : float
        A peak failing the ring test (a mode on the skirt of a louder one) is kept with
        this prominence and either this height above ``floor`` or ``min_local_db`` above
        the median of the lower of the ring's two sides (the side away from the louder
        peak's skirt).

    Returns
    -------
    idx : ndarray of int, shape (p,)
        Bin of each peak, ascending.
    hz : ndarray, shape (p,)
        Parabolic-interpolated frequency [Hz].
    level_db : ndarray, shape (p,)
        Interpolated level [dB re the linear unit of ``mag``].
    prominence_db : ndarray, shape (p,)
    local_db : ndarray, shape (p,)
        Height above the ring median [dB].
    floor_db : ndarray, shape (p,)
        Height above ``floor`` [dB].
    """
    f = np.asarray(freq_hz)
    m = np.asarray(mag, dtype=np.float64)
    db = 20 * np.log10(m + 1e-300)
    fl = 20 * np.log10(np.asarray(floor) + 1e-300)
    df = f[1] - f[0]
    lo = max(int(np.ceil(fmin_hz / df)), 1)
    hi = min(int(fmax_hz / df) if fmax_hz else f.size - 2, f.size - 2)
    idx, props = find_peaks(db[lo:hi + 1], prominence=prominence_db)
    idx = idx + lo
    prom = props["prominences"]
    over = db[idx] - fl[idx]
    keep = over >= min_snr_db
    idx, prom, over = idx[keep], prom[keep], over[keep]
    hw = np.array([half_power_width(f, m, int(i)) for i in idx])
    ring = int(round(ring_hz / df))
    local = np.zeros(idx.size)
    lower_side = np.full(idx.size, -np.inf)
    for k, i in enumerate(idx):
        w_in = max(int(np.ceil(4 * hw[k] / df)), 3)
        left = db[max(i - w_in - ring, 0):max(i - w_in, 0)]
        right = db[i + w_in:i + w_in + ring]
        around = np.concatenate([left, right])
        local[k] = db[i] - (np.median(around) if around.size else -np.inf)
        if left.size and right.size:
            lower_side[k] = db[i] - min(np.median(left), np.median(right))
    # Beside a much louder peak the ring median sits on its skirt: there a clear
    # prominence is enough far above the noise, or over the side away from the skirt.
    keep = (local >= min_local_db) | ((prom >= shoulder_prominence_db)
                                      & ((over >= shoulder_snr_db) | (lower_side >= min_local_db)))
    idx, prom, local, hw, over = idx[keep], prom[keep], local[keep], hw[keep], over[keep]
    if idx.size > max_peaks:
        top = np.sort(np.argsort(local)[::-1][:max_peaks])
        idx, prom, local, hw, over = idx[top], prom[top], local[top], hw[top], over[top]
    d, lev = parabolic_peak(db, idx)
    return idx, f[idx] + d * df, lev, prom, local, over


def leakage_lobes(idx, level_db, leakage_db, first_null: int, margin_db: float = 3.0) -> np.ndarray:
    """Which picked peaks are side lobes of a louder peak's window leakage, not modes.

    A mode still ringing when its segment ends (a xylophone bar, a guitar body, a lightly
    damped holder mode in a short segment) is cut off by the window, and its peak grows
    side lobes about one native bin (1/segment) apart: a ring at 297.5 Hz in 0.25 s
    segments shows "peaks" near ±10 and ±15 Hz. A peak is such a lobe when it lies
    beyond the main lobe of a louder peak (past its first null) and no higher than the
    window's own side-lobe envelope at that distance (:func:`~taptune.signal.spectrum.window_leakage_db`,
    the undamped worst case) plus ``margin_db``. A real mode there would stand above
    the envelope; one hidden below it cannot be told from leakage with these segments.

    Parameters
    ----------
    idx : array_like of int, shape (p,)
        Bins of the picked peaks.
    level_db : array_like, shape (p,)
        Their levels [dB].
    leakage_db : ndarray
        Side-lobe envelope per bin offset [dB re the peak] (non-increasing).
    first_null : int
        The main lobe's first minimum [bins].

    Returns
    -------
    ndarray of bool, shape (p,)
        True for a side lobe.
    """
    b = np.asarray(idx, dtype=int)
    lev = np.asarray(level_db, dtype=np.float64)
    lobe = np.zeros(b.size, dtype=bool)
    reach = len(leakage_db) - 1
    for k in range(b.size):
        d = np.abs(b - b[k])
        near = (d >= first_null) & (d <= reach) & (lev > lev[k])
        if np.any(near):
            allowed = lev[near] + np.asarray(leakage_db)[d[near]] + margin_db
            lobe[k] = bool(np.any(lev[k] <= allowed))
    return lobe


def harmonic_fundamental(hz, level_db, *, max_peaks: int = 12, within_db: float = 40.0, tol: float = 0.02,
                         min_harmonics: int = 5, min_share: float = 0.7, f0_range_hz=(50.0, 1000.0)) -> float | None:
    """The fundamental [Hz] when the loud peaks form one harmonic series (a voice, a note), else None.

    A tapped body rings at frequencies set by its shape (a free-free beam's bending modes
    go as 1 : 2.76 : 5.40), never on a harmonic series; a voice or a musical note puts
    its energy at whole multiples of one pitch. So: of the ``max_peaks`` loudest peaks
    within ``within_db`` of the loudest, at least ``min_share`` lie within ``tol`` × f0
    of multiples of one fundamental f0 in ``f0_range_hz``, covering at least
    ``min_harmonics`` different multiples. Candidates for f0: the spacings of the loud
    peaks and the loudest peaks over 1–4.
    """
    f = np.asarray(hz, dtype=np.float64)
    lev = np.asarray(level_db, dtype=np.float64)
    if f.size < min_harmonics:
        return None
    order = np.argsort(lev)[::-1]
    order = order[lev[order] >= lev[order[0]] - within_db][:max_peaks]
    loud = f[order]
    if loud.size < min_harmonics:
        return None
    cands = np.concatenate([np.abs(loud[:, None] - loud[None, :]).ravel(),
                            (loud[:3, None] / np.arange(1, 5)[None, :]).ravel()])
    cands = np.unique(np.round(cands[(cands >= f0_range_hz[0]) & (cands <= f0_range_hz[1])], 1))
    for f0 in cands[::-1]:  # the highest that fits: every series also fits its sub-multiples
        n = np.round(loud / f0)
        on = (n >= 1) & (np.abs(loud - n * f0) <= tol * f0)
        if on.mean() >= min_share and np.unique(n[on]).size >= min_harmonics:
            return float(np.sum(loud[on] * n[on]) / np.sum(n[on] ** 2))  # least-squares pitch
    return None


def half_power_width(freq_hz, mag, i: int, max_hz: float = 2000.0) -> float:
    """Half-power (−3 dB) half-width of the peak at bin ``i`` [Hz], from the magnitude.

    Each side walks out to the first bin below the half-power level, stepping over
    small ripples (reflections, noise) but not over a higher peak; the narrower side
    counts (a neighbouring mode widens only one side). At most ``max_hz``.
    """
    m = np.asarray(mag)
    df = freq_hz[1] - freq_hz[0]
    n_max = max(int(max_hz / df), 1)
    target = m[i] / np.sqrt(2.0)
    widths = []
    for seg in (m[i + 1:i + 1 + n_max], m[max(i - n_max, 0):i][::-1]):
        below = np.flatnonzero(seg < target)
        higher = np.flatnonzero(seg > m[i])
        k = below[0] + 1 if below.size else seg.size
        if higher.size and higher[0] < k:
            k = higher[0] + 1
        widths.append(k)
    return float(min(widths)) * df


def _basis(freq_hz, fd, sig, sample_rate, f_c, w, delays=()):
    """Columns of one decaying sinusoid per pole (exact DFT), the same delayed by each of
    ``delays`` [s] (reflections), then 1 and (f − f_c)/w; the derivatives of the pole
    columns by fd [Hz] and σ [1/s]; the delay factors exp(−i2πf·d), shape (m, r)."""
    f = np.asarray(freq_hz)[:, None]
    z = np.exp((-sig[None, :] + 2j * np.pi * (fd[None, :] - f)) / sample_rate)
    one_minus = 1.0 - z
    # 1/(1 − z) is the DFT of z^n, n = 0…∞; scaled by 1/fs so the columns are O(1/σ).
    modes = 1.0 / (one_minus * sample_rate)
    dz = z / (one_minus**2 * sample_rate**2)
    d_fd = dz * (2j * np.pi)
    d_sig = -dz
    shifts = np.exp(-2j * np.pi * f * np.asarray(delays, dtype=np.float64)[None, :])
    bg = np.ones((f.shape[0], 2), dtype=complex)
    bg[:, 1] = (f[:, 0] - f_c) / w
    cols = [modes] + [modes * shifts[:, r:r + 1] for r in range(shifts.shape[1])] + [bg]
    return np.hstack(cols), d_fd, d_sig, shifts


class PoleFit(NamedTuple):
    """Result of :func:`fit_poles`."""

    fd: np.ndarray        #: damped frequencies ω_d/2π [Hz], shape (j,)
    sigma: np.ndarray     #: decay rates [1/s], shape (j,)
    std_fd: np.ndarray    #: standard errors of fd [Hz] for uncorrelated bins, shape (j,)
    ok: bool              #: converged inside the band with a decay rate in range
    delays: tuple         #: reflection delays [s after the segment start], fitted
    rss: float = np.inf   #: residual sum of squares (data scaled to peak 1)
    dof: int = 0          #: residual degrees of freedom


def fit_poles(freq_hz, spec, sample_rate: float, f0, sigma0, lo_hz: float, hi_hz: float,
              max_iter: int = 40, delays=(), fit_delays: bool = False) -> PoleFit:
    """Fit poles shared by all taps to complex spectra in the band [lo_hz, hi_hz].

    Variable projection (residues and background solved linearly for given poles) with
    Kaufman's Jacobian and Levenberg-Marquardt steps on (fd, log σ) and, optionally,
    the reflection delays.

    Parameters
    ----------
    freq_hz : ndarray, shape (m,)
        Grid [Hz].
    spec : ndarray, shape (k, m), complex
        Per-tap complex spectra of segments starting just after the onset.
    sample_rate : float
        [Hz].
    f0, sigma0 : array_like, shape (j,)
        Starting damped frequencies [Hz] and decay rates σ [1/s].
    lo_hz, hi_hz : float
        Band fitted [Hz].
    max_iter : int
        Iteration limit.
    delays : sequence of float
        Arrival times [s after the segment start] of reflections inside the segment:
        each adds a delayed copy of every pole's column with its own amplitude.
    fit_delays : bool
        Refine ``delays`` too (they are then starting values).

    Returns
    -------
    PoleFit
        ``std_fd`` assumes uncorrelated bins: multiply its variance by the zero-padding
        factor.
    """
    f = np.asarray(freq_hz)
    sel = (f >= lo_hz) & (f <= hi_hz)
    fw = f[sel]
    y = np.asarray(spec)[:, sel].T  # (m, k)
    f0 = np.atleast_1d(np.asarray(f0, dtype=np.float64))
    s0 = np.maximum(np.atleast_1d(np.asarray(sigma0, dtype=np.float64)), 1.0)
    d0 = np.asarray(delays, dtype=np.float64).ravel()
    j = f0.size
    n_del = d0.size
    n_free = n_del if fit_delays else 0
    fail = PoleFit(f0, s0, np.full(j, np.inf), False, tuple(d0))
    m, k = y.shape
    n_lin = j * (1 + n_del) + 2
    if m < n_lin + 2:
        return fail
    f_c = 0.5 * (lo_hz + hi_hz)
    w = max(0.5 * (hi_hz - lo_hz), 1e-9)
    y = y / (np.max(np.abs(y)) + 1e-300)
    ms = 1e-3  # delays move in ms

    def decode(theta):
        dl = d0 + ms * theta[2 * j:] if n_free else d0
        return f_c + w * theta[0:2 * j:2], np.exp(theta[1:2 * j:2]), dl

    def evaluate(theta, jac: bool):
        fd, sig, dl = decode(theta)
        b, d_fd, d_sig, shifts = _basis(fw, fd, sig, sample_rate, f_c, w, dl)
        q, r_ = np.linalg.qr(b)
        if not np.all(np.abs(np.diag(r_)) > 1e-300):
            return None, None
        c = np.linalg.solve(r_, q.conj().T @ y)
        res = y - b @ c
        if not jac:
            return res, None
        cols = []

        def add(v):
            v = v - q @ (q.conj().T @ v)  # projected out of span(B)
            cols.append(-np.concatenate([v.real.ravel(), v.imag.ravel()]))

        for p in range(j):
            # The pole's direct and delayed columns all move with it.
            coef = np.broadcast_to(c[p][None, :], (m, k)).copy()
            for r in range(n_del):
                coef += shifts[:, r:r + 1] * c[j * (1 + r) + p][None, :]
            add((d_fd[:, p] * w)[:, None] * coef)
            add((d_sig[:, p] * sig[p])[:, None] * coef)
        for r in range(n_free):
            modes = b[:, j * (1 + r):j * (2 + r)]
            add((-2j * np.pi * ms * fw)[:, None] * (modes @ c[j * (1 + r):j * (2 + r)]))
        return res, np.column_stack(cols)

    # θ = (u1, v1, …, uj, vj, δ1 … δr): fd = f_c + w·u, σ = exp(v), delay = d0 + δ ms.
    theta = np.zeros(2 * j + n_free)
    theta[0:2 * j:2] = (f0 - f_c) / w
    theta[1:2 * j:2] = np.log(s0)
    lam = 1e-3
    res, jm = evaluate(theta, True)
    if res is None:
        return fail
    cost = float(np.sum(np.abs(res) ** 2))
    for _ in range(max_iter):
        r_vec = np.concatenate([res.real.ravel(), res.imag.ravel()])
        jtj = jm.T @ jm
        g = jm.T @ r_vec
        improved = converged = False
        for _ in range(10):
            a = jtj + lam * np.diag(np.diag(jtj) + 1e-12)
            try:
                step = -np.linalg.solve(a, g)
            except np.linalg.LinAlgError:
                lam *= 10
                continue
            # Converged: the frequency would move by < 1e-6 of the half-band, the decay
            # by < 1e-4 (relative), a delay by < 0.1 µs.
            if (np.max(np.abs(step[0:2 * j:2])) < 1e-6 and np.max(np.abs(step[1:2 * j:2])) < 1e-4
                    and np.all(np.abs(step[2 * j:]) < 1e-4)):
                converged = True
                break
            trial = theta + step
            trial[1:2 * j:2] = np.clip(trial[1:2 * j:2], -5.0, 30.0)
            res_t, _ = evaluate(trial, False)
            if res_t is not None:
                cost_t = float(np.sum(np.abs(res_t) ** 2))
                if cost_t < cost:
                    improved = True
                    break
            lam *= 10
        if converged or not improved:
            break
        theta, lam = trial, max(lam / 10, 1e-9)
        done = cost - cost_t <= 1e-10 * cost
        res, jm = evaluate(theta, True)
        cost = cost_t
        if done:
            break
    fd, sig, dl = decode(theta)
    inside = (np.all(np.abs(theta[0:2 * j:2]) < 0.98) and np.all(sig < 2 * np.pi * w * 4 + 10.0)
              and np.all(sig > 0.05) and np.all(dl > 0))
    n_res = 2 * m * k
    n_par = 2 * j + n_free + 2 * k * n_lin
    s2 = cost / max(n_res - n_par, 1)
    try:
        cov = s2 * np.linalg.pinv(jm.T @ jm)
        std = w * np.sqrt(np.maximum(np.diag(cov)[0:2 * j:2], 0.0))
    except np.linalg.LinAlgError:
        std = np.full(j, np.inf)
    return PoleFit(fd, sig, std, bool(inside), tuple(float(v) for v in dl), cost, max(n_res - n_par, 1))


def reflection_profile(freq_hz, spec, sample_rate: float, fit: PoleFit, lo_hz: float, hi_hz: float,
                       grid_s) -> np.ndarray:
    """How much a reflection at each trial delay would explain, for fixed poles.

    For each delay d of ``grid_s`` [s after the segment start] the poles' columns
    delayed by d join the linear least squares (besides those of ``fit.delays``); the
    drop of the residual, in units of the residual variance, comes back, shape of
    ``grid_s`` (≈ the number of added parameters where there is no reflection).
    """
    f = np.asarray(freq_hz)
    sel = (f >= lo_hz) & (f <= hi_hz)
    fw = f[sel]
    y = np.asarray(spec)[:, sel].T
    j = fit.fd.size
    f_c, w = 0.5 * (lo_hz + hi_hz), max(0.5 * (hi_hz - lo_hz), 1e-9)
    b0, *_ = _basis(fw, fit.fd, fit.sigma, sample_rate, f_c, w, fit.delays)
    modes = b0[:, :j]
    q0, _ = np.linalg.qr(b0)
    r0 = y - q0 @ (q0.conj().T @ y)
    var = float(np.sum(np.abs(r0) ** 2)) / max(fit.dof, 1)
    phase = np.exp(-2j * np.pi * np.outer(np.asarray(grid_s), fw))  # (g, m)
    if j == 1:
        # One pole: every trial column at once, projected out of span(B) by rows.
        e = phase * modes[:, 0][None, :]
        e = e - (e @ q0.conj()) @ q0.T
        num = np.sum(np.abs(e.conj() @ r0) ** 2, axis=1)
        drops = num / np.maximum(np.sum(np.abs(e) ** 2, axis=1), 1e-300)
    else:
        drops = np.zeros(len(grid_s))
        for n in range(len(grid_s)):
            e = modes * phase[n][:, None]
            e = e - q0 @ (q0.conj().T @ e)
            qe, _ = np.linalg.qr(e)
            drops[n] = float(np.sum(np.abs(qe.conj().T @ r0) ** 2))
    return drops / max(var, 1e-300)


def with_reflection(freq_hz, spec, sample_rate: float, fit: PoleFit, lo_hz: float, hi_hz: float,
                    max_delay_s: float, min_delay_s: float = 1e-3, count: int = 2,
                    f_threshold: float = 15.0) -> PoleFit | None:
    """The fit with one reflection added, when it explains significantly more; else None.

    The few best trial delays of :func:`reflection_profile` (on a 0.2 ms grid from
    ``min_delay_s`` to ``max_delay_s`` after the segment start) are fitted together with
    the poles (delays free: with the poles still skewed by the reflection the best trial
    delay can be off by a millisecond); the best is kept if its F statistic (residual
    drop per added parameter over the residual variance, ≈ 1 without a reflection)
    exceeds ``f_threshold``.
    """
    grid = np.arange(min_delay_s, max_delay_s, 0.2e-3)
    if grid.size < 3:
        return None
    prof = reflection_profile(freq_hz, spec, sample_rate, fit, lo_hz, hi_hz, grid)
    peak = np.flatnonzero((prof >= np.roll(prof, 1)) & (prof >= np.roll(prof, -1)))
    peak = peak[np.argsort(prof[peak])[::-1][:count]]
    best = None
    for i in peak:
        t = fit_poles(freq_hz, spec, sample_rate, fit.fd, fit.sigma, lo_hz, hi_hz,
                      delays=fit.delays + (float(grid[i]),), fit_delays=True)
        if t.ok and t.rss < fit.rss and (best is None or t.rss < best.rss):
            best = t
    if best is None:
        return None
    f_stat = ((fit.rss - best.rss) / max(fit.dof - best.dof, 1)) / (best.rss / best.dof)
    return best if f_stat > f_threshold else None


def undamped(fd_hz, sigma):
    """Model-convention frequency [Hz] and ζ from a pole's damped frequency and decay rate."""
    fd = np.asarray(fd_hz, dtype=np.float64)
    s = np.asarray(sigma, dtype=np.float64) / (2 * np.pi)
    re = np.maximum(fd**2 - s**2, 1e-300)
    return np.sqrt(re), fd * s / re


#: Segment starts tried by the refinement, latest first [s after the onset].
FIT_STARTS_S = (30e-3, 20e-3, 15e-3, 10e-3, 6e-3, 4e-3, 3e-3, 2e-3, 1.5e-3, 1e-3, 0.5e-3)


def refine_peaks(freq_hz, mag, fit_spectra, sample_rate: float, idx, hz0, *,
                 seg_s: float, effort=None, quick_start_s: float = 1.5e-3,
                 snr_db=None, min_fit_snr_db: float = 10.0, starts_s=FIT_STARTS_S,
                 target_rel_std: float = 1e-4, noise_tradeoff: float = 2.0,
                 width_factor: float = 3.0, max_reflection_s: float = 15e-3,
                 reflection_start_s: float = 1.5e-3, max_width_hz: float = 600.0):
    """Refine picked peaks by pole fits; group peaks whose fit bands overlap.

    A reflection arriving ``d`` seconds after the tap multiplies the spectrum by
    ``1 + g exp(-iωd)``, which skews a wide peak by up to ~γ²·g·d (0.1 % for a 1 %
    damped mode and a 1 ms, −12 dB reflection). Two remedies, in this order:

    * a late reflection (``reflection_start_s`` … ``max_reflection_s``) is sought in a
      segment that starts after the early ones (:func:`with_reflection`); found, it is
      modelled and that fit is the answer;
    * otherwise, after the last reflection has arrived the signal is again a pure sum
      of decaying sinusoids, so each peak is fitted with the latest segment start whose
      frequency standard error is still below ``target_rel_std`` (or within
      ``noise_tradeoff`` of the smallest).

    Parameters
    ----------
    freq_hz : ndarray, shape (m,)
        Grid of ``mag`` [Hz].
    mag : ndarray, shape (m,)
        Averaged magnitude (for the starting half-widths).
    fit_spectra : callable
        ``fit_spectra(start_s) -> (freq_hz, spec, oversample)``: per-tap complex spectra
        (k, m') of segments starting ``start_s`` after each onset, their grid and
        the zero-padding factor (FFT length / segment length).
    sample_rate : float
        [Hz].
    idx, hz0 : ndarray, shape (p,)
        Picked bins and their parabolic frequencies [Hz].
    seg_s : float
        Segment length [s]; the native resolution 1/seg_s sets the narrowest band.
    starts_s : sequence of float
        Segment starts tried, latest first [s after onset].
    snr_db : array_like, shape (p,), optional
        Peak heights over the noise floor [dB]. A start at which a mode (decaying at the
        rate its half-power width tells) would stand less than ``min_fit_snr_db`` above
        the noise is skipped: there the fit would lock onto noise.
    min_fit_snr_db : float
    target_rel_std : float
        Largest acceptable relative standard error of a refined frequency.
    noise_tradeoff : float
        When no start meets ``target_rel_std``, the latest start whose standard error
        is at most this many times the smallest one is taken.
    width_factor : float
        Band half-width in half-power half-widths.
    max_reflection_s : float
        Latest reflection sought [s after the onset]; 0 = none.
    reflection_start_s : float
        Segment start of the reflection search [s after the onset], after the early
        (floor, table) reflections.
    max_width_hz : float
        Widest band half-width [Hz].

    Returns
    -------
    hz : ndarray, shape (p,)
        Refined (undamped) frequency [Hz]; the parabolic one where every fit failed.
    zeta : ndarray, shape (p,)
        Damping ratio (NaN where every fit failed).
    std_hz : ndarray, shape (p,)
        Standard error of ``hz`` [Hz] (inf where every fit failed).
    """
    f = np.asarray(freq_hz)
    p = len(idx)
    hz = np.array(hz0, dtype=np.float64)
    zeta = np.full(p, np.nan)
    std_hz = np.full(p, np.inf)
    if p == 0:
        return hz, zeta, std_hz
    hw = np.array([half_power_width(f, mag, int(i)) for i in idx])
    hw = np.maximum(hw, 0.5 / seg_s)
    half = np.clip(width_factor * hw, 3.0 / seg_s, max_width_hz)
    lo = hz - half
    hi = hz + half
    # Group peaks whose bands overlap: one fit with several poles.
    groups = [[0]]
    for i in range(1, p):
        if lo[i] <= max(hi[g] for g in groups[-1]):
            groups[-1].append(i)
        else:
            groups.append([i])
    effort = np.full(p, 2) if effort is None else np.asarray(effort)
    for g in groups:
        g = np.array(g)
        level = int(np.max(effort[g]))
        if g.size > 4 or level == 0:  # a dense cluster of noise peaks: not worth a joint fit
            continue
        band_lo, band_hi = float(np.min(lo[g])), float(np.max(hi[g]))
        f_start, s_start = hz[g], 2 * np.pi * hw[g]
        # The narrowest resolvable half-width is ~1/(2T): above it the width is the decay.
        s_decay = np.maximum(s_start - np.pi / seg_s, 0.0)
        margin_db = 60.0 if snr_db is None else float(np.min(np.asarray(snr_db)[g])) - min_fit_snr_db
        t_max = max(margin_db, 0.0) / (20 * np.log10(np.e)) / max(float(np.max(s_decay)), 1e-9)
        tried = [ts for ts in starts_s if ts <= t_max] or [min(starts_s)]
        if level == 1:
            tried = [quick_start_s]
        def accept(fit, ovs):
            """(f, ζ, std f) of a fit that refines these peaks, else None."""
            if not fit.ok:
                return None
            fu, z = undamped(fit.fd, fit.sigma)
            # A fit that wandered to another peak, or to a noise spike much narrower than
            # the peak, is not a refinement of this one.
            near = np.abs(fu - hz[g]) < np.maximum(hw[g], 2.0 / seg_s)
            if not np.all(near) or np.any(fit.sigma < 0.2 * s_decay):
                return None
            return fu, z, fit.std_fd * np.sqrt(ovs)

        if level == 2 and max_reflection_s > reflection_start_s:
            # A late reflection skews a wide peak by up to ~γ²·g·d whatever the start
            # before it; found, it is modelled from an early start, which keeps the
            # signal-to-noise ratio.
            ff, spec, ovs = fit_spectra(reflection_start_s)
            base = fit_poles(ff, spec, sample_rate, f_start, s_start, band_lo, band_hi)
            found = with_reflection(ff, spec, sample_rate, base, band_lo, band_hi,
                                    max_reflection_s - reflection_start_s) if base.ok else None
            est = accept(found, ovs) if found is not None else None
            if est is not None:
                hz[g], zeta[g], std_hz[g] = est
                continue
        fits = []
        for ts in tried:
            ff, spec, ovs = fit_spectra(ts)
            est = accept(fit_poles(ff, spec, sample_rate, f_start, s_start, band_lo, band_hi), ovs)
            if est is None:
                continue
            fits.append(est)
            if np.all(est[2] <= target_rel_std * est[0]):
                break
        if not fits:
            continue
        # The latest start meeting the target; failing that, the latest whose error is
        # at most ``noise_tradeoff`` times the smallest: a reflection arriving between
        # two starts skews the earlier fit by many standard errors (up to ~γ²·g·d),
        # while starting later costs only a little noise.
        rel = np.array([np.max(fit[2] / fit[0]) for fit in fits])
        limit = max(target_rel_std, noise_tradeoff * float(np.min(rel)))
        hz[g], zeta[g], std_hz[g] = fits[int(np.flatnonzero(rel <= limit)[0])]
    return hz, zeta, std_hz


def tap_scatter(freq_hz, tap_mag, idx) -> np.ndarray:
    """Standard deviation over taps of each peak's parabolic frequency [Hz], shape (p,).

    ``tap_mag`` (k, m) are the taps' magnitude spectra; each tap's maximum is sought
    within ±2 bins of the averaged peak bin ``idx`` (p,).
    """
    t = np.asarray(tap_mag)
    if t.shape[0] < 2 or len(idx) == 0:
        return np.zeros(len(idx))
    f = np.asarray(freq_hz)
    df = f[1] - f[0]
    db = 20 * np.log10(t + 1e-300)
    out = np.zeros(len(idx))
    for n, i in enumerate(idx):
        a, b = max(int(i) - 2, 1), min(int(i) + 3, f.size - 1)
        loc = a + np.argmax(db[:, a:b], axis=1)
        loc = np.clip(loc, 1, f.size - 2)
        rows = np.arange(t.shape[0])
        y0, y1, y2 = db[rows, loc - 1], db[rows, loc], db[rows, loc + 1]
        den = y0 - 2 * y1 + y2
        d = np.where(den < 0, 0.5 * (y0 - y2) / np.where(den < 0, den, -1.0), 0.0)
        out[n] = float(np.std(f[loc] + np.clip(d, -0.5, 0.5) * df, ddof=1))
    return out


def _flank_floor_db(db, i: int, inner: int, outer: int, side: str = "both") -> float:
    """Robust local floor [dB] at bin ``i``: the mean of the medians of the two flanks
    ``[i − outer, i − inner)`` and ``(i + inner, i + outer]`` (a straight line in dB
    through them, so a peak on the sloping skirt of a louder mode is judged against
    the skirt, not the far noise); ``side`` "left" or "right" takes that flank alone."""
    left = db[max(i - outer, 0):max(i - inner, 0)] if side != "right" else db[:0]
    right = db[i + inner + 1:i + outer + 1] if side != "left" else db[:0]
    meds = [float(np.median(part)) for part in (left, right) if part.size >= 3]
    return float(np.mean(meds)) if meds else -np.inf


def _clear_side(db, i: int, inner: int, outer: int, louder_bins) -> str:
    """The flank to judge bin ``i`` against: "both", or the one without a louder known
    peak in it (its top, not a skirt, would lift the floor by tens of dB: as
    :func:`pick_peaks` judges a shoulder by the side away from the louder peak)."""
    b = np.asarray(louder_bins, dtype=int)
    b = b[db[b] > db[i]] if b.size else b
    in_left = bool(np.any((b >= i - outer) & (b < i - inner)))
    in_right = bool(np.any((b > i + inner) & (b <= i + outer)))
    return "right" if in_left and not in_right else "left" if in_right and not in_left else "both"


def fit_resonance(freq_hz, mag, i: int, half_hz: float, oversample: float = 1.0,
                  min_half_width_hz: float = 0.5, reach_hz: float | None = None) -> tuple[float, float, float]:
    """One-mode fit of the averaged magnitude around bin ``i`` against a flat (sloping) floor.

    Over ``±half_hz`` the magnitude is fitted twice, linear in the amplitudes: a
    straight background alone, and the background plus a single-degree-of-freedom
    magnitude peak ``c / sqrt(1 + ((f − f0)/γ)²)`` (c > 0; f0 within ``reach_hz`` of bin
    ``i``, default one bin; γ from ``min_half_width_hz`` to ``half_hz``), by a grid
    search refined once around its best point. The F ratio is
    ``((RSS_floor − RSS_peak)/3) / (RSS_peak/(n_eff − 5))`` with ``n_eff`` the bins over
    the zero-padding factor ``oversample`` (neighbouring bins of a zero-padded spectrum
    are not independent): a ringing mode gives tens to thousands, noise about 1.

    Returns
    -------
    f_ratio : float
        0 when the window is too short or no positive peak fits.
    f0_hz : float
        The fitted peak frequency [Hz] (the bin's when no peak fits): the whole peak's
        shape places it, steadier than the noisy top of a faint peak.
    half_width_hz : float
        The fitted half-power half-width γ [Hz] (≈ ζ·f0).
    """
    f = np.asarray(freq_hz)
    m = np.asarray(mag, dtype=np.float64)
    df = f[1] - f[0]
    w = max(int(round(half_hz / df)), 3)
    a, b = max(i - w, 0), min(i + w + 1, m.size)
    x, y = f[a:b] - f[i], m[a:b]
    n_eff = x.size / max(oversample, 1.0)
    if n_eff < 8:
        return 0.0, float(f[i]), float("nan")
    y = y / (float(np.max(np.abs(y))) or 1.0)
    base = np.column_stack([np.ones_like(x), x / max(half_hz, df)])
    c0, *_ = np.linalg.lstsq(base, y, rcond=None)
    rss0 = float(np.sum((y - base @ c0) ** 2))
    best = [rss0, 0.0, float("nan")]

    def scan(centres, widths):
        for f0 in centres:
            for g in widths:
                a3 = np.column_stack([base, 1.0 / np.sqrt(1.0 + ((x - f0) / g) ** 2)])
                c, *_ = np.linalg.lstsq(a3, y, rcond=None)
                if c[2] <= 0:
                    continue
                rss = float(np.sum((y - a3 @ c) ** 2))
                if rss < best[0]:
                    best[:] = [rss, float(f0), float(g)]

    reach = df if reach_hz is None else max(reach_hz, df)
    scan(np.linspace(-reach, reach, 17), np.geomspace(max(min_half_width_hz, 0.5 * df), max(half_hz, 2 * df), 16))
    if best[0] >= rss0:
        return 0.0, float(f[i]), float("nan")
    step = reach / 8
    scan(np.linspace(best[1] - step, best[1] + step, 17), best[2] * np.geomspace(0.7, 1.4, 9))
    ratio = ((rss0 - best[0]) / 3.0) / (max(best[0], 1e-300) / max(n_eff - 5.0, 1.0))
    return float(ratio), float(f[i] + best[1]), best[2]


def pick_faint_peaks(freq_hz, mag, tap_mag, windows, *, noise_mag=None, min_db: float = 8.0,
                     tap_db: float = 3.0, f_ratio: float = 8.0, prominence_db: float = 3.0,
                     ring_hz: float = 250.0, stationary_margin_db: float = 6.0,
                     oversample: float = 1.0, per_window: int = 2, min_width_rel: float = 1e-3,
                     tap_fraction: float = 0.5, known_bins=()):
    """Faint resonances inside search windows: the guided search for missing modes.

    :func:`pick_peaks` demands 15 dB over the noise so that nothing it returns is noise,
    anywhere in the spectrum. Where the model says a bending mode must be, a lower bar
    is safe if the peak passes three independent tests: it stands ``min_db`` over the
    robust local floor (:func:`_flank_floor_db`, flanks from 4 half-power widths out to
    ``ring_hz``), it is there in *every* tap (each tap stands over its own floor, within
    one native bin of the averaged peak, by ``tap_db`` and by ``tap_fraction`` of the
    average's height in dB: a mode rings in every tap alike, while a bump of one tap's
    noise or a click is not where the others have theirs), and it is shaped like a resonance
    (the F ratio of :func:`fit_resonance` ≥ ``f_ratio``). Peaks less than ``stationary_margin_db``
    over the between-tap spectrum ``noise_mag`` are hum, not modes.

    Parameters
    ----------
    freq_hz, mag : ndarray, shape (m,)
        Uniform grid [Hz] and averaged linear magnitude.
    tap_mag : ndarray, shape (k, m)
        Per-tap magnitudes.
    windows : sequence of (lo_hz, hi_hz)
        Where to search [Hz].
    oversample : float
        Zero-padding factor of the spectrum (FFT length over segment length).
    per_window : int
        At most this many per window, those standing highest over their floor.
    min_width_rel : float
        Smallest half-power half-width taken for the floor's flanks and the resonance
        fit, relative to the frequency (a faint peak's measured width is cut short by
        the noise ripple).
    known_bins : sequence of int
        Bins of the peaks already picked: a flank that holds one louder than the
        candidate (an interface mode beside a faint bending mode) is left out of its floor.

    Returns
    -------
    list of dict
        ``idx`` (bin), ``hz`` and ``zeta`` (of the one-mode fit, :func:`fit_resonance`:
        on a faint peak steadier than a pole fit, which can lock onto a noise spike)
        [Hz, –], ``db`` (level [dB re the unit of ``mag``]), ``over_db`` (over the
        floor), ``prominence_db``, ``f_ratio`` and ``width_hz`` (the half-power
        half-width taken), ascending.
    """
    f = np.asarray(freq_hz)
    m = np.asarray(mag, dtype=np.float64)
    t = np.atleast_2d(np.asarray(tap_mag, dtype=np.float64))
    db = 20 * np.log10(m + 1e-300)
    tdb = 20 * np.log10(t + 1e-300)
    ndb = None if noise_mag is None else 20 * np.log10(np.asarray(noise_mag) + 1e-300)
    df = f[1] - f[0]
    ring = max(int(round(ring_hz / df)), 4)
    found = {}
    for lo_hz, hi_hz in windows:
        lo, hi = max(int(np.ceil(lo_hz / df)), 1), min(int(np.floor(hi_hz / df)), f.size - 2)
        if hi - lo < 3:
            continue
        idx, props = find_peaks(db[lo:hi + 1], prominence=prominence_db)
        keep = []
        for i, prom in zip(idx + lo, props["prominences"]):
            # A faint peak's half-power width is cut short by the noise ripple: at least
            # ``min_width_rel`` × f (ζ ≈ 0.1–0.5 % of a tool-holder mode) counts.
            hw = max(half_power_width(f, m, int(i), max_hz=ring_hz / 2), min_width_rel * f[i])
            inner = max(int(np.ceil(4 * hw / df)), 3)
            side = _clear_side(db, int(i), inner, inner + ring, known_bins)
            over = db[i] - _flank_floor_db(db, int(i), inner, inner + ring, side)
            if over < min_db:
                continue
            if ndb is not None and db[i] - float(np.max(ndb[max(i - 2, 0):i + 3])) < stationary_margin_db:
                continue
            # Each tap's own maximum lies within one native bin (1/segment) of the average's.
            reach = max(int(round(oversample)), 2)
            taps_over = [float(np.max(tdb[k, max(i - reach, 0):i + reach + 1]))
                         - _flank_floor_db(tdb[k], int(i), inner, inner + ring, side) for k in range(t.shape[0])]
            if min(taps_over) < max(tap_db, tap_fraction * over):
                continue
            ratio, f0, gamma = fit_resonance(f, m, int(i), half_hz=max(4 * hw, 8 * df * oversample),
                                             oversample=oversample, reach_hz=hw)
            if ratio < f_ratio:
                continue
            _, lev = parabolic_peak(db, int(i))
            keep.append({"idx": int(i), "hz": f0, "zeta": gamma / f0, "db": float(lev), "over_db": float(over),
                         "prominence_db": float(prom), "f_ratio": ratio, "width_hz": float(hw)})
        keep.sort(key=lambda c: -c["over_db"])
        # Noise splits the top of a faint resonance into several maxima: the highest stands
        # for the others within two of its half-power widths (measured or fitted) either side.
        chosen = []
        for c in keep:
            if all(abs(c["hz"] - q["hz"]) > 2 * max(q["width_hz"], q["zeta"] * q["hz"]) for q in chosen):
                chosen.append(c)
        for c in chosen[:per_window]:
            found[c["idx"]] = c
    return [found[i] for i in sorted(found)]
