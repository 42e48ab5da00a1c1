"""The holder's uncertainty carried to the lobes: a safe depth per speed and safe pockets.

The tool point is known only to the holder's prediction band (near-optimal parameter
sets, geometry tolerances, model form; :mod:`taptune.identify.bands`), or to a tolerance
the user gives for a measured FRF. Each sample of the band is the tool point with

* every modal frequency multiplied by one factor s and every modal stiffness by s² (a
  stiffer or softer grip at the same modal mass, f ∝ √k), and
* its FRF divided by a factor g (every modal stiffness × g at the same frequencies and
  damping): what the frequencies do not say about the tool point's dynamic stiffness —
  the contact damping the near-optimal parameter sets disagree on, and the modal
  stiffness a grip profile or a mass the assembly file leaves out changes.

For that two-parameter family the delay equation of the cut is exactly similar (time
scaled by s, depth by g): the sample's limit is

    a_{s,g}(n) = g · s² · a(n / s)

with a(n) the central lobes, so ``SAMPLES`` samples cost one interpolation each, whatever
the method (ZOA or SDM; tests/machine/test_band_similarity.py checks both against the
closed-form 1-DOF lobes). s and ln g are independent normals whose central ``coverage``
intervals are the bands' ±; the samples lie on a deterministic two-dimensional
low-discrepancy set (evenly spaced quantiles of s, golden-ratio steps in g).

Per speed the **safe depth** is the (1 − P) quantile of the samples (stable with
probability ≥ P), and never more than the central limit. A **safe pocket** is a speed window at least ±``WINDOW_REL`` of its
centre wide (and at least ±``WINDOW_MIN_RPM``: a machinist cannot hold a pocket's top to a
few rpm, and the spindle's speed itself wanders) with the depth that every sample keeps
stable over the *whole* window with probability ≥ P: per sample the lowest limit in the
window, then the (1 − P) quantile over the samples. Pockets do not overlap; best first.

Why g: on 40 holders unlike the model, identified from one tap and put on a spindle
(benchmarks/lobes_coverage.py, docs/machine.md), the frequency factor that best maps the
central lobes on the true ones lay inside the band at 92 % of the stick-outs, but the
true limits were then still a near-constant 0.70–1.24 times the mapped ones (5–95 %;
one tap pins the frequencies, not the tool point's stiffness and damping): with s alone
the true limit held the safe depth at 78 % of the speeds, with g at 95 %.

Signatures::

    scale_samples(rel_half_width, coverage=0.9, n=SAMPLES) -> ndarray
    band_samples(rel_half_width, coverage=0.9, depth_rel=0.0, n=SAMPLES) -> (scales, magnitudes)
    extended_grid(rpm, scales) -> (rpm_ext, slice of rpm inside it)
    sample_limits(rpm_ext, a_ext, rpm, scales, magnitudes=None) -> ndarray (samples, speeds)
    lobe_band(rpm_ext, a_ext, inner, scales, confidence, depth_cap=inf, sources="", magnitudes=None) -> LobeBand
    band_parts(band) -> (rel_half_width, coverage, sources, depth_rel)
    band_from_prediction(prediction, mode=0) -> (rel_half_width, coverage, sources, depth_rel)
    band_from_tolerance(pct) -> (rel_half_width, coverage, sources)
    lobes_with_band(freq_hz, phi_xx, phi_yy, *, teeth, ktc, krc, diameter, ae, milling, rpm, method="auto",
                    confidence=0.9, band=(0, 0.9, NO_BAND), depth_cap=inf) -> (Lobes, LobeBand)

A band is the tuple (relative half-width of the frequencies, its coverage, what it is
made of[, relative half-width of the dynamic stiffness]); without the fourth element the
dynamic stiffness is taken as known (a measured FRF).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from taptune.errors import InputError

MM = 1e-3
#: Sampled tool points of a band (the issue asks for ≥ 50).
SAMPLES = 64
#: A safe pocket's window: ± this fraction of its centre speed, and at least ± WINDOW_MIN_RPM.
WINDOW_REL = 0.015
WINDOW_MIN_RPM = 100.0
#: Safe pockets reported.
MAX_POCKETS = 8
#: The part of the tool point's dynamic-stiffness band (relative, read as a 90 % band) that
#: the holder's near-optimal sets do not show: modal stiffness and damping a grip profile
#: or a mass left out of the assembly file changes at the same frequencies. Chosen on the
#: realism corpus's calibration split (benchmarks/lobes_coverage.py --split calibration).
DEPTH_MODEL_FORM = 0.60
#: Golden-ratio step of the magnitude quantiles (a 2-D low-discrepancy set with the s quantiles).
_GOLDEN = (np.sqrt(5.0) - 1.0) / 2.0


@dataclass(frozen=True)
class SafePocket:
    """A speed window [rpm] and the depth [m] stable over all of it with the band's confidence."""

    rpm_low: float
    rpm_high: float
    rpm: float
    a: float

    def to_dict(self) -> dict:
        return {"rpm_low": self.rpm_low, "rpm_high": self.rpm_high, "rpm": self.rpm, "a_mm": self.a / MM}


@dataclass(frozen=True)
class LobeBand:
    """Lobes with their uncertainty on the requested speed grid (SI: m).

    ``a_safe`` the depth stable with probability ≥ ``confidence`` per speed; ``a_low`` and
    ``a_high`` the (1 − P) and P quantiles (the shaded band; ``a_low`` = ``a_safe``);
    ``safe_pockets`` best first; ``sources`` what the band is made of, in words;
    ``samples`` the number of sampled tool points (1: no band).
    """

    rpm: np.ndarray = field(repr=False)
    a_safe: np.ndarray = field(repr=False)
    a_low: np.ndarray = field(repr=False)
    a_high: np.ndarray = field(repr=False)
    confidence: float = 0.9
    safe_pockets: tuple = ()
    sources: str = ""
    samples: int = 1


def check_confidence(p: float, option: str = "--confidence") -> float:
    """``p`` if it lies in (0.5, 1), else a one-line InputError naming ``option``."""
    if not (isinstance(p, (int, float)) and 0.5 < p < 1):
        raise InputError(f"{option} must lie strictly between 0.5 and 1 (a probability), got {p!r}")
    return float(p)


def scale_samples(rel_half_width: float, coverage: float = 0.9, n: int = SAMPLES) -> np.ndarray:
    """Frequency factors s at evenly spaced quantiles of N(1, σ²), σ such that ±``rel_half_width`` holds ``coverage``.

    ``rel_half_width`` 0 gives the single factor 1 (no band).
    """
    if not (rel_half_width >= 0 and np.isfinite(rel_half_width)):
        raise InputError(f"the relative band must be >= 0, got {rel_half_width!r}")
    if rel_half_width == 0:
        return np.ones(1)
    from scipy.special import ndtri  # the normal quantile (scipy.stats costs ~1 s to import)

    sigma = rel_half_width / ndtri(0.5 + coverage / 2)
    return 1.0 + sigma * ndtri((np.arange(n) + 0.5) / n)


def band_samples(rel_half_width: float, coverage: float = 0.9, depth_rel: float = 0.0,
                 n: int = SAMPLES) -> tuple[np.ndarray, np.ndarray]:
    """Frequency factors s and FRF magnitude divisors g of the band's samples.

    s as :func:`scale_samples`; ln g normal with its central ``coverage`` interval
    ±ln(1 + ``depth_rel``), independent of s: sample i takes the quantile
    frac(½ + i·0.618…) of g (golden-ratio steps), so the pairs cover the plane evenly.
    ``depth_rel`` 0 gives g = 1 throughout; both 0, the single sample (1, 1).
    """
    if not (depth_rel >= 0 and np.isfinite(depth_rel)):
        raise InputError(f"the relative dynamic-stiffness band must be >= 0, got {depth_rel!r}")
    if depth_rel == 0:
        s = scale_samples(rel_half_width, coverage, n)
        return s, np.ones_like(s)
    from scipy.special import ndtri

    s = scale_samples(rel_half_width, coverage, n) if rel_half_width > 0 else np.ones(n)
    sigma = np.log1p(depth_rel) / ndtri(0.5 + coverage / 2)
    return s, np.exp(sigma * golden_normal(n))


def golden_normal(n: int) -> np.ndarray:
    """Standard normal quantiles at frac(½ + i·0.618…), i = 0 … n−1: evenly covering the
    distribution, in an order independent of evenly spaced quantiles taken alongside."""
    from scipy.special import ndtri

    return ndtri(np.mod(0.5 + np.arange(n) * _GOLDEN, 1.0))


def extended_grid(rpm, scales) -> tuple[np.ndarray, slice]:
    """The uniform speed grid ``rpm`` extended by whole steps to cover n/s for every factor s.

    Returns the extended grid and the slice of it that is ``rpm``. A grid that is not
    uniform is returned as it is (the samples are then clipped at its ends).
    """
    r = np.asarray(rpm, dtype=float)
    s = np.asarray(scales, dtype=float)
    if r.size < 2 or s.size == 1:
        return r, slice(0, r.size)
    step = np.diff(r)
    if not np.allclose(step, step[0], rtol=1e-6):
        return r, slice(0, r.size)
    lo = r[0] / s.max()
    hi = r[-1] / s.min()
    below = int(np.ceil((r[0] - lo) / step[0]))
    below = min(below, int((r[0] - 1e-9) // step[0]))  # stay above 0 rpm
    above = int(np.ceil((hi - r[-1]) / step[0]))
    ext = r[0] + step[0] * np.arange(-below, r.size + above)
    return ext, slice(below, below + r.size)


def sample_limits(rpm_ext, a_ext, rpm, scales, magnitudes=None) -> np.ndarray:
    """Limits of every sampled tool point on ``rpm``: g s² a(n/s), shape (len(scales), len(rpm)) [m].

    ``magnitudes`` the factors g (default 1), one per scale."""
    a = np.asarray(a_ext, dtype=float)
    big = np.where(np.isfinite(a), a, np.nan)
    top = np.nanmax(big) * 1e6 if np.isfinite(big).any() else 1.0
    a = np.where(np.isfinite(a), a, top)  # inf (no lobe, or stable to the cap) kept large through the interpolation
    s = np.asarray(scales, dtype=float)[:, None]
    g = np.ones_like(s) if magnitudes is None else np.asarray(magnitudes, dtype=float).reshape(s.shape)
    out = s**2 * np.interp(np.asarray(rpm)[None, :] / s, rpm_ext, a)
    return np.where(out >= top, np.inf, g * out)


def lobe_band(rpm_ext, a_ext, inner: slice, scales, confidence: float, depth_cap: float = np.inf,
              sources: str = "", magnitudes=None) -> LobeBand:
    """Safe depth per speed and safe pockets (module docstring).

    Parameters
    ----------
    rpm_ext, a_ext : ndarray
        The central lobes on the extended grid (:func:`extended_grid`) [rpm, m].
    inner : slice
        Where the requested grid lies in ``rpm_ext``.
    scales : ndarray
        Frequency factors of the samples (:func:`scale_samples`).
    confidence : float
        P in (0.5, 1).
    depth_cap : float
        No depth above it is reported [m].
    sources : str
        What the band is made of (one line).
    magnitudes : ndarray, optional
        FRF magnitude divisors g of the samples (:func:`band_samples`; default 1).
    """
    check_confidence(confidence)
    rpm = np.asarray(rpm_ext, dtype=float)[inner]
    lim = np.minimum(sample_limits(rpm_ext, a_ext, rpm, scales, magnitudes), depth_cap)
    if lim.shape[0] == 1:
        low = high = lim[0]
    else:
        # Never above the central limit: at a cusp of the central lobes the shifted samples
        # may all lie higher, and "safe" must not read deeper than "central".
        central = np.minimum(np.asarray(a_ext, dtype=float)[inner], depth_cap)
        low = np.minimum(np.quantile(lim, 1 - confidence, axis=0, method="inverted_cdf"), central)
        high = np.maximum(np.quantile(lim, confidence, axis=0, method="inverted_cdf"), low)
    pockets = safe_pockets(rpm, lim, confidence)
    return LobeBand(rpm=rpm, a_safe=low, a_low=low, a_high=high, confidence=confidence, safe_pockets=pockets,
                    sources=sources, samples=lim.shape[0])


def _window_min(values, lo, hi) -> np.ndarray:
    """min(values[..., lo[i]:hi[i]]) for every i (inclusive lo, exclusive hi), by a sparse table."""
    levels = [values]
    width = 1
    while 2 * width <= values.shape[-1]:
        prev = levels[-1]
        levels.append(np.minimum(prev[..., :-width], prev[..., width:]))
        width *= 2
    length = hi - lo
    k = np.floor(np.log2(np.maximum(length, 1))).astype(int)
    out = np.empty(values.shape[:-1] + (lo.size,))
    for level in np.unique(k):
        i = np.flatnonzero(k == level)
        table = levels[level]
        out[..., i] = np.minimum(table[..., lo[i]], table[..., hi[i] - (1 << level)])
    return out


def safe_pockets(rpm, limits, confidence: float) -> tuple:
    """Non-overlapping speed windows with the depth stable over each with probability ≥ P, best first.

    ``limits`` shape (samples, speeds) [m] on the ascending grid ``rpm``; windows lie
    entirely inside the grid.
    """
    r = np.asarray(rpm, dtype=float)
    if r.size < 3:
        return ()
    half = np.maximum(WINDOW_REL * r, WINDOW_MIN_RPM)
    lo = np.searchsorted(r, r - half, "left")
    hi = np.searchsorted(r, r + half, "right")
    inside = (r - half >= r[0] - 1e-9) & (r + half <= r[-1] + 1e-9)
    lim = np.where(np.isfinite(limits), limits, np.finfo(float).max)
    per_sample = _window_min(lim, lo, hi)  # (samples, speeds): each sample's lowest limit over the window
    if per_sample.shape[0] == 1:
        depth = per_sample[0]
    else:
        depth = np.quantile(per_sample, 1 - confidence, axis=0, method="inverted_cdf")
    depth = np.where(inside, depth, -np.inf)
    # Local maxima of the window depth, then greedy non-overlapping choice, best first.
    out = []
    taken = np.zeros(r.size, bool)
    for i in np.argsort(-depth, kind="stable"):
        if len(out) >= MAX_POCKETS or not np.isfinite(depth[i]) or depth[i] <= 0:
            break
        if taken[lo[i]: hi[i]].any():
            continue
        peak = (i == 0 or depth[i] >= depth[i - 1]) and (i == r.size - 1 or depth[i] >= depth[i + 1])
        if not peak:
            continue
        if depth[i] >= np.finfo(float).max:
            continue  # no lobe reaches the window: nothing known there
        a = float(depth[i])
        out.append(SafePocket(float(r[lo[i]]), float(r[hi[i] - 1]), float(r[i]), a))
        taken[lo[i]: hi[i]] = True
    return _merged(out, float(np.min(np.diff(r))))


def _merged(pockets: list, step: float) -> tuple:
    """Windows of the same depth that touch (a plateau, e.g. at the flute length) as one wider pocket."""
    by_speed = sorted(pockets, key=lambda p: p.rpm_low)
    out = []
    for p in by_speed:
        q = out[-1] if out else None
        if q is not None and p.rpm_low - q.rpm_high <= 1.5 * step and abs(p.a - q.a) <= 1e-9 * max(p.a, q.a):
            out[-1] = SafePocket(q.rpm_low, p.rpm_high, 0.5 * (q.rpm_low + p.rpm_high), q.a)
        else:
            out.append(p)
    return tuple(sorted(out, key=lambda p: (-p.a, -(p.rpm_high - p.rpm_low))))


NO_BAND = "none (the FRF is taken as exact)"


def band_from_tolerance(pct: float, option: str = "--frf-tolerance") -> tuple[float, float, str]:
    """A measured FRF's band: its modal frequencies known to ±``pct`` % (read as a 90 % band)."""
    if not (isinstance(pct, (int, float)) and 0 <= pct <= 20):
        raise InputError(f"{option} must lie in 0…20 (% of the modal frequencies), got {pct!r}")
    if pct == 0:
        return 0.0, 0.9, NO_BAND
    return pct / 100, 0.9, (f"{option} ±{pct:g} % on the tool-point modal frequencies (read as a 90 % band; "
                            f"stiffness ∝ f², {SAMPLES} tool points sampled)")


def band_parts(band) -> tuple[float, float, str, float]:
    """(frequency half-width, coverage, sources, dynamic-stiffness half-width) of a band
    tuple of 3 (no stiffness band) or 4 elements."""
    rel, coverage, sources, *rest = band
    return float(rel), float(coverage), sources, float(rest[0]) if rest else 0.0


def depth_band(damping_ratio: float, damping_spread: float, model_form: float = DEPTH_MODEL_FORM) -> float:
    """Relative half-width of the tool point's dynamic stiffness: the damping ratio's spread
    over the near-optimal sets relative to it, and the model-form part, in quadrature."""
    damping = damping_spread / damping_ratio if damping_ratio > 0 else 0.0
    return float(np.hypot(damping, model_form))


def band_from_prediction(prediction, mode: int = 0) -> tuple[float, float, str, float]:
    """The holder's prediction band of bending mode ``mode`` (0: the first, the tool's own
    bending, which dominates the tool point) as a band of the tool point.

    Frequencies: the prediction's ± (its three parts, near-optimal parameter sets,
    geometry tolerances and model form, :class:`taptune.identify.bands.Band`, named with
    their share). Dynamic stiffness: the spread of the mode's damping ratio over the
    near-optimal sets (relative; the tap pins frequencies far better than damping) and
    :data:`DEPTH_MODEL_FORM`, in quadrature.
    """
    band = getattr(prediction, "band", None)
    if band is None or not prediction.bending_hz:
        return 0.0, 0.9, "none (the holder's prediction has no band)", 0.0
    m = min(mode, len(prediction.bending_hz) - 1)
    f = prediction.bending_hz[m]
    rel = band.half_width_hz[m] / f
    zeta = prediction.damping_ratio[m] if m < len(prediction.damping_ratio) else 0.0
    spread = prediction.damping_ratio_spread[m] if m < len(prediction.damping_ratio_spread) else 0.0
    damping = spread / zeta if zeta > 0 else 0.0
    depth = depth_band(zeta, spread)
    parts = ", ".join(f"{name} ±{100 * getattr(band, key)[m] / f:.1f} %"
                      for name, key in (("near-optimal parameter sets", "set_hz"),
                                        ("geometry tolerances", "geometry_hz"), ("model form", "model_form_hz")))
    text = (f"tool-point modal frequencies ±{100 * rel:.1f} % (the holder's prediction band of f{m + 1} = "
            f"{f:.0f} Hz: {parts}) and dynamic stiffness ×/÷ {1 + depth:.2f}, i.e. −{100 * depth / (1 + depth):.0f} % "
            f"to +{100 * depth:.0f} % (damping the near-optimal sets disagree by up to {100 * damping:.0f} %, "
            f"model form ×/÷ {1 + DEPTH_MODEL_FORM:.2f}), "
            f"{100 * band.coverage:.0f} % bands; {SAMPLES} sampled tool points, each with its modes × s in "
            f"frequency and × s² in stiffness and its FRF ÷ g")
    return float(rel), float(band.coverage), text, depth


def lobes_with_band(freq_hz, phi_xx, phi_yy, *, teeth: int, ktc: float, krc: float, diameter: float, ae: float,
                    milling: str, rpm, method: str = "auto", confidence: float = 0.9, band=(0.0, 0.9, NO_BAND),
                    depth_cap: float = np.inf, modes=None):
    """The central lobes on ``rpm`` and their band (module docstring).

    ``band`` is (relative half-width, its coverage, what it is made of[, relative
    dynamic-stiffness half-width]) as :func:`band_from_prediction` or
    :func:`band_from_tolerance` give it. The central lobes
    are computed once on the grid extended to n/s of every sample (:func:`extended_grid`).
    """
    check_confidence(confidence)
    rel, coverage, sources, depth = band_parts(band)
    scales, magnitudes = band_samples(rel, coverage, depth)
    ext, inner = extended_grid(rpm, scales)
    wide = central_lobes(freq_hz, phi_xx, phi_yy, teeth=teeth, ktc=ktc, krc=krc, diameter=diameter, ae=ae,
                         milling=milling, rpm=ext, method=method, depth_cap=depth_cap, modes=modes,
                         scales=scales, magnitudes=magnitudes)
    lobes = wide.on(inner)
    return lobes, lobe_band(ext, wide.a_lim, inner, scales, confidence, depth_cap, sources, magnitudes)


def search_cap(depth_cap: float, scales, magnitudes=None) -> float:
    """The depth [m] up to which the central lobes must be searched so that every sample's
    limit g·s²·a(n/s) is known up to ``depth_cap``: ``depth_cap`` / min(g·s²).

    A central limit cut off at the cap ("stable to the cap") says nothing about a sample
    softer than the centre (g·s² < 1), whose limit may lie below the cap."""
    s = np.asarray(scales, dtype=float)
    g = np.ones_like(s) if magnitudes is None else np.asarray(magnitudes, dtype=float)
    return float(depth_cap / min(1.0, float(np.min(g * s**2))))


def central_lobes(freq_hz, phi_xx, phi_yy, *, depth_cap: float, scales, magnitudes=None, **cut):
    """The central lobes (:func:`taptune.machine.lobes.stability_lobes` with ``cut``) searched
    to :func:`search_cap`, reported with ``depth_cap``: the band's samples scale them and
    are capped only after scaling."""
    from dataclasses import replace

    from taptune.machine.lobes import stability_lobes

    top = search_cap(depth_cap, scales, magnitudes)
    wide = stability_lobes(freq_hz, phi_xx, phi_yy, depth_cap=top, **cut)
    a = wide.a_lim
    if np.isfinite(top):
        # "Stable to the search cap" is a limit of at least that: kept as the cap's value, a
        # sample between such a speed and its neighbour interpolates below the truth, never above.
        a = np.where(np.isposinf(a), top, a)
    return replace(wide, a_lim=a, depth_cap=float(depth_cap))
