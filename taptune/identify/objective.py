"""The identification objective of docs/physics.md §4.

    J(p) = Σ_n [(f_n(p) − f_n^meas) / (σ_f f_n^meas)]²  +  (1/σ_s²) · mean_k [Ŝ(f_k) − Ĥ(f_k; p)]²

summed over every recording of a joint identification. The shape term compares the
measured spectrum with the model's tool-tip receptance on a 1 Hz grid over a window
(default 200 Hz) centred on the measured first bending mode, both normalised to their
peak in the window (the tap force and the microphone gain are unknown).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from taptune.errors import InputError


@dataclass(frozen=True)
class ObjectiveOptions:
    """Weights and variants of the objective (docs/physics.md §4 defaults)."""

    sigma_f: float = 0.005  # relative frequency tolerance
    sigma_s: float = 0.05  # RMS shape tolerance (normalised units)
    window_hz: float = 200.0  # width of the shape window around measured f1 [Hz]
    compare: str = "linear"  # "linear" or "db"
    quantity: str = "receptance"  # "receptance" or "accelerance"

    def __post_init__(self):
        if self.compare not in ("linear", "db"):
            raise InputError(f"objective: compare must be 'linear' or 'db', got {self.compare!r}")
        if self.quantity not in ("receptance", "accelerance"):
            raise InputError(f"objective: quantity must be 'receptance' or 'accelerance', got {self.quantity!r}")
        if not (self.sigma_f > 0 and self.sigma_s > 0 and self.window_hz > 0):
            raise InputError("objective: sigma_f, sigma_s and window_hz must be > 0")


@dataclass(frozen=True)
class Target:
    """What one recording says: measured bending frequencies and the normalised window shape.

    Attributes
    ----------
    modes : tuple of int
        Bending-mode numbers (1-based) that were measured.
    measured_hz : ndarray
        Their frequencies [Hz], same order as ``modes``.
    window_hz : ndarray, shape (K,)
        The 1 Hz grid of the shape window [Hz].
    shape : ndarray, shape (K,)
        Measured spectrum on ``window_hz``, normalised to its peak (or in dB relative to it).
    """

    modes: tuple[int, ...]
    measured_hz: np.ndarray
    window_hz: np.ndarray
    shape: np.ndarray
    label: str = ""
    warnings: tuple[str, ...] = field(default=(), compare=False)


def _normalise(mag: np.ndarray, compare: str) -> np.ndarray:
    """Scale a magnitude curve to its peak; in dB mode return dB below the peak / 20 dB."""
    mag = np.abs(mag)
    peak = np.max(mag, axis=-1, keepdims=True)
    peak = np.where(peak > 0, peak, 1.0)
    rel = mag / peak
    if compare == "db":
        # 20 dB of level difference counts like a full-scale linear difference.
        return 20 * np.log10(np.maximum(rel, 1e-6)) / 20.0
    return rel


def make_target(
    freq_hz,
    magnitude,
    bending_hz: dict[int, float],
    options: ObjectiveOptions = ObjectiveOptions(),
    label: str = "",
) -> Target:
    """Build the :class:`Target` of one recording.

    Parameters
    ----------
    freq_hz, magnitude : array_like
        The averaged spectrum: uniform frequency grid [Hz] and linear magnitude.
    bending_hz : dict
        Measured bending frequencies [Hz] by mode number (1, 2, 3). Mode 1 is required:
        the shape window is centred on it.
    """
    freq_hz = np.asarray(freq_hz, dtype=float)
    magnitude = np.abs(np.asarray(magnitude, dtype=float))
    if not bending_hz:
        raise InputError(f"{label or 'recording'}: no bending peak was found, nothing to fit")
    outside = sorted(m for m in bending_hz if m not in (1, 2, 3))
    if outside:
        raise InputError(f"{label or 'recording'}: bending mode number(s) {outside} outside 1–3 (only modes 1–3 are fitted)")
    if 1 not in bending_hz:
        raise InputError(
            f"{label or 'recording'}: the first bending mode was not found; the fit needs it "
            "(its window carries the damping information)"
        )
    warnings = []
    modes = tuple(sorted(int(m) for m in bending_hz))
    if len(modes) < 3:
        missing = sorted(set((1, 2, 3)) - set(modes))
        warnings.append(
            f"{label or 'recording'}: bending mode(s) {', '.join(map(str, missing))} not found; "
            f"fitting {len(modes)} frequenc{'y' if len(modes) == 1 else 'ies'} only"
        )
    f1 = float(bending_hz[1])
    half = options.window_hz / 2
    window = f1 + np.arange(-half, half + 0.5, 1.0)
    if window[0] < freq_hz[0] or window[-1] > freq_hz[-1]:
        raise InputError(f"{label or 'recording'}: the spectrum does not cover the window {window[0]:.0f}–{window[-1]:.0f} Hz")
    shape = _normalise(np.interp(window, freq_hz, magnitude), options.compare)
    return Target(
        modes=modes,
        measured_hz=np.array([bending_hz[m] for m in modes], dtype=float),
        window_hz=window,
        shape=shape,
        label=label,
        warnings=tuple(warnings),
    )


def model_shape(window_hz: np.ndarray, receptance: np.ndarray, options: ObjectiveOptions) -> np.ndarray:
    """Normalised model curve on the window (receptance or accelerance magnitude)."""
    mag = np.abs(receptance)
    if options.quantity == "accelerance":
        mag = mag * (2 * np.pi * window_hz) ** 2
    if mag.ndim == 1 and options.compare == "linear":
        # One curve, linear: what the optimiser asks thousands of times (few numpy calls).
        peak = mag.max()
        return mag / peak if peak > 0 else mag
    return _normalise(mag, options.compare)


def _frequency_misses(target: Target, bending_hz, options: ObjectiveOptions) -> list[float]:
    """(f_n(p) − f_n^meas) / (σ_f f_n^meas) per measured mode (plain floats: 1–3 values)."""
    sigma = options.sigma_f
    return [(float(bending_hz[m - 1]) - f) / (sigma * f) for m, f in zip(target.modes, target.measured_hz.tolist())]


def residual_vector(
    target: Target, bending_hz: np.ndarray, receptance: np.ndarray, options: ObjectiveOptions
) -> np.ndarray:
    """The residuals whose squares sum to J of one recording, shape (len(modes) + K,).

    The relative frequency misses in tolerances, then the shape misfit per window point
    scaled by 1/(σ_s √K): ``sum(r[:len(modes)]**2)`` is the frequency term, the rest the
    shape term. What a Gauss–Newton polish works on.
    """
    rel = _frequency_misses(target, bending_hz, options)
    diff = target.shape - model_shape(target.window_hz, receptance, options)
    return np.concatenate([rel, diff / (options.sigma_s * np.sqrt(diff.size))])


def objective_terms(
    target: Target, bending_hz: np.ndarray, receptance: np.ndarray, options: ObjectiveOptions
) -> tuple[float, float]:
    """The frequency and the shape term of J for one recording.

    Parameters
    ----------
    bending_hz : ndarray
        Model bending frequencies f1, f2, f3 … [Hz].
    receptance : ndarray
        Model tip receptance on ``target.window_hz`` [m/N].
    """
    freq_term = sum(r * r for r in _frequency_misses(target, bending_hz, options))
    diff = target.shape - model_shape(target.window_hz, receptance, options)
    shape_term = float(diff @ diff) / diff.size / options.sigma_s**2
    return freq_term, shape_term


class Objective:
    """J(p) over one or several recordings, each with its own model evaluator.

    ``evaluators[i].evaluate(p, window_hz)`` must return an object with ``bending_hz``
    and ``tip_receptance`` (see :class:`taptune.model.reduced.FastEvaluator`).
    Counts its calls; a failed model evaluation counts as a very bad candidate.
    The summed terms of every point evaluated are remembered (:attr:`memo`): the
    near-optimal set asks again for the terms of hundreds of archive points, and a GA
    child that is a clone of its parent costs nothing.
    """

    BAD = 1e12

    def __init__(self, targets, evaluators, options: ObjectiveOptions = ObjectiveOptions()):
        if len(targets) != len(evaluators) or not targets:
            raise ValueError("one evaluator per target is needed")
        self.targets = tuple(targets)
        self.evaluators = tuple(evaluators)
        self.options = options
        self.evaluations = 0
        self.memo: dict[bytes, np.ndarray] = {}  # p.tobytes() → summed (frequency, shape) terms

    def terms(self, p) -> list[tuple[float, float]]:
        """(frequency term, shape term) per recording at parameter vector p."""
        out = []
        for target, ev in zip(self.targets, self.evaluators):
            e = ev.evaluate(np.asarray(p, dtype=float), target.window_hz)
            out.append(objective_terms(target, e.bending_hz, e.tip_receptance, self.options))
        return out

    def _guarded_terms(self, p):
        """:meth:`terms`, or None where the model evaluation fails (a candidate the solver
        cannot handle is a very bad candidate, never a crash)."""
        try:
            terms = self.terms(p)
        except (np.linalg.LinAlgError, FloatingPointError, ValueError):
            return None
        return terms if np.all(np.isfinite(terms)) else None

    def summed_terms(self, p) -> np.ndarray:
        """(frequency term, shape term) summed over the recordings; both BAD on failure."""
        p = np.asarray(p, dtype=float)
        key = p.tobytes()
        found = self.memo.get(key)
        if found is None:
            terms = self._guarded_terms(p)
            found = np.array([self.BAD, self.BAD]) if terms is None else np.sum(terms, axis=0)
            self.memo[key] = found
        return found

    def known(self, p) -> bool:
        """Whether the terms at p are remembered (asking for them costs no evaluation)."""
        return np.asarray(p, dtype=float).tobytes() in self.memo

    def residuals(self, p) -> np.ndarray:
        """The residual vector of every recording, concatenated (J = its squared norm);
        counts one evaluation and remembers the summed terms. A failed model evaluation
        gives residuals whose squares sum to :attr:`BAD`."""
        p = np.asarray(p, dtype=float)
        self.evaluations += 1
        try:
            parts = []
            for target, ev in zip(self.targets, self.evaluators):
                e = ev.evaluate(p, target.window_hz)
                parts.append(residual_vector(target, e.bending_hz, e.tip_receptance, self.options))
            r = np.concatenate(parts)
            ok = bool(np.all(np.isfinite(r)))
        except (np.linalg.LinAlgError, FloatingPointError, ValueError):
            ok = False
        if not ok:
            n = sum(len(t.modes) + len(t.window_hz) for t in self.targets)
            self.memo.setdefault(p.tobytes(), np.array([self.BAD, self.BAD]))
            return np.full(n, np.sqrt(self.BAD / n))
        if p.tobytes() not in self.memo:
            sq = r * r
            f, start = 0.0, 0
            for t in self.targets:
                f += float(np.sum(sq[start:start + len(t.modes)]))
                start += len(t.modes) + len(t.window_hz)
            self.memo[p.tobytes()] = np.array([f, float(np.sum(sq)) - f])
        return r

    def __call__(self, p) -> float:
        self.evaluations += 1
        f, s = self.summed_terms(p)
        return self.BAD if f >= self.BAD else float(f + s)

    def batch(self, P) -> np.ndarray:
        """J for every row of P (a GA generation): the points not yet remembered are
        evaluated together where the evaluators can (``evaluate_many``), else one by one."""
        P = np.atleast_2d(np.asarray(P, dtype=float))
        keys = [p.tobytes() for p in P]
        new = list(dict.fromkeys(k for k in keys if k not in self.memo))
        if len(new) > 1 and all(hasattr(ev, "evaluate_many") for ev in self.evaluators):
            first = {}
            for i, k in enumerate(keys):
                first.setdefault(k, i)
            rows = [first[k] for k in new]
            terms = self._batched_terms(P[rows])
            if terms is not None:
                for k, t in zip(new, terms):
                    self.memo[k] = t if np.all(np.isfinite(t)) else np.array([self.BAD, self.BAD])
        return np.array([self(p) for p in P])

    def _batched_terms(self, P) -> np.ndarray | None:
        """Summed (frequency, shape) terms of every row of P, (n, 2), from the evaluators'
        batch form; None if a model evaluation fails (the caller then goes one by one)."""
        out = np.zeros((len(P), 2))
        opt = self.options
        try:
            for target, ev in zip(self.targets, self.evaluators):
                e = ev.evaluate_many(P, target.window_hz)
                # objective_terms, vectorised over the rows.
                measured = target.measured_hz
                rel = (e.bending_hz[:, np.array(target.modes) - 1] - measured) / (opt.sigma_f * measured)
                out[:, 0] += np.sum(rel * rel, axis=1)
                diff = target.shape - model_shape(target.window_hz, e.tip_receptance, opt)
                out[:, 1] += np.sum(diff * diff, axis=1) / diff.shape[1] / opt.sigma_s**2
        except (np.linalg.LinAlgError, FloatingPointError, ValueError):
            return None
        return out
