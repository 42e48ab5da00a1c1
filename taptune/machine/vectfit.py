"""Common-pole rational fit of measured FRFs (vector fitting), to smooth noisy hammer tests.

FRFs measured on one structure share its poles. Vector fitting (Gustavsen & Semlyen,
IEEE Trans. Power Delivery 14(3), 1999) relocates a set of starting poles by repeated
linear least squares, then fits every FRF's residues with the poles fixed:

    G_k(s) ≈ Σ_n r_kn / (s − p_n) + d_k + e_k s,      s = iω.

The poles are free complex numbers, not conjugate pairs: structures with hysteretic
(complex-stiffness) damping, as in this model and in the spindle files, have the modal
sum Σ φφ/(λ + s²) with poles ±i√λ that are not conjugates, and only positive
frequencies are measured anyway. A few dozen numbers per FRF then replace thousands of
noisy samples, and inverse RCSA (docs/machine.md) on the fitted FRFs amplifies far less
noise than on the raw ones.

Signature::

    fit_frfs(freq_hz, frfs, n_poles=None, iterations=10, weights=None) -> RationalFit
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

#: Upper bound of the default pole count (a noisy FRF must not look like hundreds of modes).
MAX_POLES = 60

@dataclass(frozen=True)
class RationalFit:
    """Poles shared by all FRFs (in units of ``scale`` rad/s), residues, constant and s terms.

    ``evaluate(freq_hz)`` gives the fitted FRFs, shape (k, n); ``rms`` is the relative
    rms misfit of each FRF to the data it was fitted to (‖fit − data‖ / ‖data‖).
    """

    poles: np.ndarray = field(repr=False)
    residues: np.ndarray = field(repr=False)
    d: np.ndarray = field(repr=False)
    e: np.ndarray = field(repr=False)
    rms: np.ndarray = field(repr=False)
    scale: float = 1.0

    def evaluate(self, freq_hz) -> np.ndarray:
        s = 2j * np.pi * np.asarray(freq_hz, dtype=float) / self.scale
        return (_model(s, self.poles) @ np.concatenate([self.residues, self.d[:, None], self.e[:, None]], axis=1).T).T


def _model(s, poles) -> np.ndarray:
    """Columns 1/(s − p_n), 1, s, shape (len(s), n + 2)."""
    return np.concatenate([1.0 / (s[:, None] - poles[None, :]), np.ones((len(s), 1)), s[:, None]], axis=1)


def _smooth(x, width: int = 31):
    """Moving average over ``width`` points (ends: shorter windows), real or complex."""
    if len(x) <= width:
        return x
    c = np.cumsum(np.concatenate([[0], x]))
    half = width // 2
    i = np.arange(len(x))
    lo, hi = np.maximum(i - half, 0), np.minimum(i + half + 1, len(x))
    return (c[hi] - c[lo]) / (hi - lo)


def _count_peaks(mag, prominence: float = 0.1) -> int:
    """Peaks of a (possibly noisy) magnitude that rise ``prominence`` (in ln) above the
    higher of the two minima separating them from their neighbouring peaks."""
    y = np.log(np.maximum(_smooth(mag), 1e-300))
    top = np.flatnonzero((y[1:-1] > y[:-2]) & (y[1:-1] >= y[2:])) + 1
    if top.size == 0:
        return 0
    edges = np.concatenate([[0], top, [len(y) - 1]])
    count = 0
    for k, i in enumerate(top):
        left = y[edges[k]: i + 1].min()
        right = y[i: edges[k + 2] + 1].min()
        count += y[i] - max(left, right) >= prominence
    return int(count)


def fit_frfs(freq_hz, frfs, n_poles: int | None = None, iterations: int = 10, weights=None) -> RationalFit:
    """Fit FRFs of one structure with common poles (module docstring).

    Parameters
    ----------
    freq_hz : array_like, shape (n,)
        Frequencies [Hz], ascending, > 0.
    frfs : array_like, complex, shape (k, n)
        The FRFs (any units).
    n_poles : int, optional
        Number of poles. By default it starts at twice the number of peaks of the
        summed, normalised |G| (10 % prominence after light smoothing) plus eight, at
        least 12, and grows by 8 while that still lowers the misfit by a fifth (up to
        ``MAX_POLES``): noise stops the growth, model error does not.
    iterations : int
        Pole relocations per fit.
    weights : array_like, shape (n,), optional
        Confidence per frequency (multiplies the relative weight 1/|G|).

    Returns
    -------
    RationalFit
    """
    if n_poles is not None:
        return _fit(freq_hz, frfs, n_poles, iterations, weights)
    g = np.atleast_2d(np.asarray(frfs, dtype=complex))
    scaled = g / np.maximum(np.sqrt(np.mean(np.abs(g) ** 2, axis=1, keepdims=True)), 1e-300)
    n = min(MAX_POLES, max(12, 2 * _count_peaks(np.abs(scaled).sum(axis=0)) + 8))
    best = _fit(freq_hz, g, n, iterations, weights)
    while n + 8 <= MAX_POLES:
        n += 8
        trial = _fit(freq_hz, g, n, iterations, weights)
        if trial.rms.max() > 0.8 * best.rms.max():
            break
        best = trial
    return best


def _fit(freq_hz, frfs, n_poles: int, iterations: int, weights) -> RationalFit:
    """One fit with ``n_poles`` poles (see :func:`fit_frfs`)."""
    f = np.asarray(freq_hz, dtype=float)
    g = np.atleast_2d(np.asarray(frfs, dtype=complex))
    scale = 2 * np.pi * f.max()
    s = 2j * np.pi * f / scale
    # Each FRF weighted by its own size so that none dominates the pole relocation.
    w = 1.0 / np.maximum(np.sqrt(np.mean(np.abs(g) ** 2, axis=1)), 1e-300)
    gw = g * w[:, None]
    # Relative weights (measurement noise is roughly proportional to |G|): 1/|G| of the
    # lightly smoothed FRF, so antiresonances count as much as peaks.
    row_w = 1.0 / np.maximum(np.abs(np.stack([_smooth(gj) for gj in gw])), 1e-12)
    if weights is not None:
        row_w = row_w * np.asarray(weights, dtype=float)[None, :]
    beta = np.linspace(f.min(), f.max(), n_poles) * 2 * np.pi / scale
    poles = -beta / 100 + 1j * beta
    n = n_poles
    for _ in range(iterations):
        own = _model(s, poles)
        phi = own[:, :n]
        # G (1 + Σ c̃ φ) ≈ Σ r φ + d + e s: per FRF, a QR step eliminates r, d, e and
        # leaves n equations in c̃ (the "fast" vector fitting of Deschrijver et al. 2008).
        blocks, rhs = [], []
        for gj, rw in zip(gw, row_w):
            q, r = np.linalg.qr(rw[:, None] * np.concatenate([own, -gj[:, None] * phi, gj[:, None]], axis=1))
            blocks.append(r[n + 2: 2 * n + 2, n + 2: 2 * n + 2])
            rhs.append(r[n + 2: 2 * n + 2, -1])
        c, *_ = np.linalg.lstsq(np.concatenate(blocks), np.concatenate(rhs), rcond=None)
        # The zeros of σ = 1 + Σ c̃_n/(s − p_n) are the new poles.
        poles = np.linalg.eigvals(np.diag(poles) - np.outer(np.ones(n), c))
    m = _model(s, poles)
    coef = np.stack([np.linalg.lstsq(rw[:, None] * m, rw * gj, rcond=None)[0] for gj, rw in zip(gw, row_w)], axis=1)
    fit = (m @ coef).T
    rms = np.linalg.norm(fit - gw, axis=1) / np.linalg.norm(gw, axis=1)
    coef = coef / w[None, :]
    return RationalFit(poles=poles, residues=coef[:n].T, d=coef[n], e=coef[n + 1], rms=rms, scale=scale)
