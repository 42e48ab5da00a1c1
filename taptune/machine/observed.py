"""Cuts observed on the machine move the lobe prediction: the near-optimal parameter sets weighed by how well they explain them.

A holder's prediction band comes from its near-optimal parameter sets (each a plausible
holder, each giving its own tool-point FRF and lobes). A cut heard stable or chattering
at (speed, depth) is evidence about which of them is right: a set whose lobes put that
cut far on the wrong side of its boundary explains it badly. With the limit of set i at
the cut, a_i, the probability the set gives the observed verdict is

    P(chatter | i) = Φ((ln a − ln a_i) / σ),   P(stable | i) = 1 − P(chatter | i),

σ the relative scatter of a limit that no set captures (cutting coefficients, the lobe
model, the cut's own variation; :data:`SIGMA`); ``unclear`` cuts carry no weight. The
sets' weights are the products over the cuts (Bayes with equal priors), and the band is
the weighted spread of their limits per speed.

In the product the sets are the holder's band (:mod:`taptune.machine.band`: every
tool-point modal frequency × s, stiffness × s², the FRF ÷ g, limit g s² a(n/s)) on the full
grid of its s and its g (independent, each at evenly spaced quantiles of its distribution),
so weighing them costs one interpolation per s and cut. A verdict is taken as wrong with
probability :data:`LAPSE` whatever the set (one misheard cut must not rule out the truth).
The band with the cuts is the posterior predictive of the limit: pairs drawn by their
weights, each limit scattered by σ as the cuts' were (the next cut varies as they did), so
the safe depth (the (1 − P) quantile per speed) and the pockets are computed as without
observations. The output says how the cuts moved and narrowed the band of s (where the
lobes lie), of g (how deep they reach) and of the limit itself, and names the cuts that
contradict a prediction made with ≥ P confidence.

On 60 tool points drawn inside a band of ±6 % in frequency and ×/÷1.6 in dynamic stiffness,
each with 3–15 cuts at random speeds and 0.4–2.5 × its limit, the weighed safe depth lay at
or below the true limit at ≥ 90 % of the speeds in 55 of them (the band alone: 50), and its
median rose from 0.62 to 0.77 of the true limit (tests/cut/test_observed_honest.py; on 300
such tool points 276 and 248, 0.66 to 0.75).

Signatures::

    set_weights(limits, depths, verdicts, sigma=SIGMA, lapse=0.0) -> ndarray (n_sets,)
    weighted_band(a_lim, weights, quantiles=(0.05, 0.5, 0.95)) -> ndarray (len(quantiles), n_speeds)
    comparable(observations, *, teeth, ae_mm, milling, ktc_mpa, krc_mpa) -> list
    observed_band(rpm_ext, a_ext, inner, scales, cuts, confidence, depth_cap=inf, sources="",
                  magnitudes=None) -> ObservedBand
    lobes_with_observations(freq_hz, phi_xx, phi_yy, *, cuts, band, ..., confidence=0.9) -> (Lobes, ObservedBand)
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

#: Relative scatter of a stability limit that the holder's parameter sets do not capture.
SIGMA = 0.15


#: Tool points drawn from the weighed band for its safe depth and pockets.
DRAWS = 256
#: Chance that a cut's verdict is wrong whatever the tool point (a misheard or mislabelled cut):
#: one such cut must not rule out the truth.
LAPSE = 0.02


def _log_likelihood(limits, depths, verdicts, sigma: float, lapse: float) -> np.ndarray:
    """Log-probability of the verdicts for every row of ``limits`` (..., n_cuts) [m]: the limit
    scattered by σ (log scale), and a verdict wrong with probability ``lapse``."""
    from scipy.special import ndtr

    a = np.asarray(limits, float)
    z = (np.log(np.asarray(depths, float)) - np.log(np.where(np.isfinite(a), a, 1e6))) / sigma
    sign = np.array([{"chatter": 1.0, "stable": -1.0}.get(v, 0.0) for v in verdicts])
    p = lapse + (1 - 2 * lapse) * ndtr(sign * z)
    return np.where(sign != 0, np.log(p), 0.0).sum(axis=-1)


def set_weights(limits, depths, verdicts, sigma: float = SIGMA, lapse: float = 0.0) -> np.ndarray:
    """Weights (sum 1) of the parameter sets given the observed cuts.

    Parameters
    ----------
    limits : array_like, shape (n_sets, n_cuts)
        Each set's stability limit at each cut's speed [m] (inf: no limit there).
    depths : array_like, shape (n_cuts,)
        The cuts' axial depths [m].
    verdicts : sequence of str
        "stable", "chatter" or "unclear" per cut.
    sigma : float
        Relative scatter of the limit (log scale).
    lapse : float
        Chance that a verdict is wrong whatever the set (0: the verdicts as heard; :func:`observed_band`
        takes :data:`LAPSE`).
    """
    a = np.asarray(limits, float)
    loglik = _log_likelihood(a[:, None] if a.ndim == 1 else a, depths, verdicts, sigma, lapse)
    w = np.exp(loglik - loglik.max())
    return w / w.sum()


def weighted_band(a_lim, weights, quantiles=(0.05, 0.5, 0.95)) -> np.ndarray:
    """Weighted quantiles over the sets of the limit per speed, shape (len(quantiles), n_speeds).

    ``a_lim`` has shape (n_sets, n_speeds) [m]; each set counts with its weight (a step
    cumulative distribution, the quantile the first set whose cumulative weight reaches it).
    """
    a = np.asarray(a_lim, float)
    w = np.asarray(weights, float)
    order = np.argsort(a, axis=0)
    sa = np.take_along_axis(a, order, axis=0)
    cw = np.cumsum(w[order], axis=0)
    cw /= cw[-1:]
    out = np.empty((len(quantiles), a.shape[1]))
    for k, q in enumerate(quantiles):
        i = np.argmax(cw >= q - 1e-12, axis=0)
        out[k] = sa[i, np.arange(a.shape[1])]
    return out


#: Observed cuts count for these lobes when their cut is the same: teeth and milling equal,
#: radial depth and cutting coefficients within this fraction.
SAME_CUT = 0.05


def comparable(observations, *, teeth: int, ae_mm: float, milling: str, ktc_mpa: float, krc_mpa: float) -> list:
    """The observed cuts (:class:`taptune.library.observations.CutObservation`-like) made
    with the same cut as the lobes (same teeth and milling, ae and K_tc, K_rc within
    :data:`SAME_CUT`): only they test these lobes."""
    def close(a, b):
        return abs(a - b) <= SAME_CUT * max(abs(b), 1e-12)

    return [o for o in observations if o.teeth == teeth and o.milling == milling and close(o.ae_mm, ae_mm)
            and close(o.ktc_mpa, ktc_mpa) and close(o.krc_mpa, krc_mpa)]


@dataclass(frozen=True)
class ObservedBand:
    """The holder's band before and after weighing its samples by the observed cuts.

    Attributes
    ----------
    prior, band : taptune.machine.band.LobeBand
        Without and with the observations (``band`` is ``prior`` when no cut counts).
    weights : ndarray, shape (len(scales), len(magnitudes))
        Weight of each pair (s, g) of the grid (sum 1; equal without cuts).
    scales, magnitudes : ndarray
        The grid's frequency factors s and dynamic-stiffness divisors g (each ascending).
    cuts : int
        Observed cuts that carried weight (stable or chatter, inside the speed grid).
    width_before, width_after : float
        Central ``confidence`` interval of s, before and after (its relative width: the band
        of the tool-point frequencies, which decides where the lobes lie).
    shift : float
        The weighted median of s less 1 (the observations' shift of the tool-point frequencies).
    stiffness_width_before, stiffness_width_after : float
        Central ``confidence`` interval of g (its width relative to the prior's median g = 1:
        the band of the tool point's dynamic stiffness, which scales every limit).
    stiffness_shift : float
        The weighted median of g less 1 (+0.2: the cuts say the limits lie 20 % higher).
    depth_width_before, depth_width_after : float
        Median over the speeds of ln(a_high / a_low) (the band of the limit itself, relative).
    warnings : tuple of str
    """

    prior: object
    band: object
    weights: np.ndarray
    scales: np.ndarray
    cuts: int
    width_before: float
    width_after: float
    shift: float
    warnings: tuple = ()
    magnitudes: np.ndarray = None
    stiffness_width_before: float = 0.0
    stiffness_width_after: float = 0.0
    stiffness_shift: float = 0.0
    depth_width_before: float = 0.0
    depth_width_after: float = 0.0

    @property
    def narrowing(self) -> float:
        """Fraction by which the observations narrowed the band of s (0: not at all)."""
        return 1.0 - self.width_after / self.width_before if self.width_before > 0 else 0.0

    @property
    def stiffness_narrowing(self) -> float:
        """Fraction by which the observations narrowed the band of g (0: not at all)."""
        b = self.stiffness_width_before
        return 1.0 - self.stiffness_width_after / b if b > 0 else 0.0

    @property
    def depth_narrowing(self) -> float:
        """Fraction by which the observations narrowed the band of the limit (median over the
        speeds; negative: the band with the cuts is wider, the scatter of the cuts themselves)."""
        b = self.depth_width_before
        return 1.0 - self.depth_width_after / b if b > 0 else 0.0

    def to_dict(self) -> dict:
        return {"observed_cuts_used": self.cuts, "band_width_before_pct": 100 * self.width_before,
                "band_width_after_pct": 100 * self.width_after, "band_narrowed_pct": 100 * self.narrowing,
                "toolpoint_frequency_shift_pct": 100 * self.shift,
                "stiffness_band_width_before_pct": 100 * self.stiffness_width_before,
                "stiffness_band_width_after_pct": 100 * self.stiffness_width_after,
                "stiffness_band_narrowed_pct": 100 * self.stiffness_narrowing,
                "toolpoint_stiffness_shift_pct": 100 * self.stiffness_shift,
                "depth_band_narrowed_pct": 100 * self.depth_narrowing}


def _weighted_quantile(x, w, q) -> float:
    order = np.argsort(x)
    cw = np.cumsum(np.asarray(w, float)[order])
    return float(np.asarray(x, float)[order][min(np.searchsorted(cw, q * cw[-1] - 1e-12), len(x) - 1)])


def _width(x, w, confidence: float) -> float:
    """Width of the central ``confidence`` interval of x weighted by w."""
    return _weighted_quantile(x, w, (1 + confidence) / 2) - _weighted_quantile(x, w, (1 - confidence) / 2)


def _log_width(low, high) -> float:
    """Median over the speeds of ln(high / low), where both are finite and positive (0: nowhere)."""
    ok = np.isfinite(low) & np.isfinite(high) & (low > 0)
    return float(np.median(np.log(high[ok] / low[ok]))) if ok.any() else 0.0


def _resampled_index(weights, n: int) -> np.ndarray:
    """``n`` indices at evenly spaced quantiles of the weights."""
    w = np.asarray(weights, float)
    cw = np.cumsum(w) / np.sum(w)
    i = np.searchsorted(cw, (np.arange(n) + 0.5) / n)
    return np.minimum(i, len(w) - 1)


def observed_band(rpm_ext, a_ext, inner: slice, scales, cuts, confidence: float, depth_cap: float = np.inf,
                  sources: str = "", sigma: float = SIGMA, magnitudes=None) -> ObservedBand:
    """The band of :func:`taptune.machine.band.lobe_band` with its samples weighed by the observed ``cuts``.

    s and g are independent in the band (:func:`taptune.machine.band.band_samples`), and its
    s and its g are each evenly spaced quantiles of their own distribution: every s with
    every g, equally weighted, is the band on a full grid (64 × 64 pairs for one
    interpolation per s). The cuts weigh each pair (:func:`set_weights`, with a verdict wrong
    with probability :data:`LAPSE`); the band with the cuts is the posterior predictive of
    the limit: :data:`DRAWS` pairs drawn at evenly spaced quantiles of the weights, each
    with its limit scattered by e^(σ z) (z at evenly spaced normal quantiles): a limit the
    band does not capture moves the next cut as it moved the observed ones. The safe depth
    is the (1 − P) quantile of the draws per speed, the pockets as without observations.

    Parameters
    ----------
    rpm_ext, a_ext, inner, scales, confidence, depth_cap, sources
        As :func:`taptune.machine.band.lobe_band` (central lobes on the extended grid [rpm, m]).
    cuts : sequence of (rpm, depth [m], verdict)
        Observed cuts with the same cut as the lobes; those outside the requested speed grid
        and ``unclear`` ones carry no weight.
    sigma : float
        Relative scatter of a limit the samples do not capture (:data:`SIGMA`).
    magnitudes : ndarray, optional
        The samples' FRF magnitude divisors g (:func:`taptune.machine.band.band_samples`; default 1).

    Returns
    -------
    ObservedBand
        With a warning per cut that contradicts a prediction made with ≥ ``confidence``
        (chatter where ≥ P of the samples are stable, stable where ≥ P chatter), and one when
        the cuts point beyond the band (the best samples are its outermost).
    """
    from scipy.special import ndtr

    from taptune.machine.band import LobeBand, golden_normal, lobe_band, safe_pockets, sample_limits

    s0 = np.asarray(scales, float)
    g0 = np.ones_like(s0) if magnitudes is None else np.asarray(magnitudes, float)
    s, g = np.unique(s0), np.unique(g0)
    rpm = np.asarray(rpm_ext, float)[inner]
    prior = lobe_band(rpm_ext, a_ext, inner, s0, confidence, depth_cap, sources, g0)
    inside = [(float(n), float(d), v) for n, d, v in cuts
              if v in ("stable", "chatter") and rpm[0] <= n <= rpm[-1] and d > 0]
    equal = np.full((s.size, g.size), 1.0 / (s.size * g.size))
    ws0, wg0 = equal.sum(axis=1), equal.sum(axis=0)
    width0, gwidth0 = _width(s, ws0, confidence), _width(g, wg0, confidence)
    dwidth0 = _log_width(prior.a_low, prior.a_high)
    if not inside or len(s0) == 1:
        return ObservedBand(prior, prior, equal, s, 0, width0, width0, _weighted_quantile(s, ws0, 0.5) - 1.0,
                            magnitudes=g, stiffness_width_before=gwidth0, stiffness_width_after=gwidth0,
                            stiffness_shift=_weighted_quantile(g, wg0, 0.5) - 1.0,
                            depth_width_before=dwidth0, depth_width_after=dwidth0)
    n_obs = np.array([c[0] for c in inside])
    depth = np.array([c[1] for c in inside])
    verdicts = [c[2] for c in inside]
    lim0 = np.minimum(sample_limits(rpm_ext, a_ext, n_obs, s0, g0), depth_cap)  # the band's samples at the cuts
    warnings = []
    for j, (n, d, v) in enumerate(inside):
        p_stable = float(np.mean(lim0[:, j] > d))
        if v == "chatter" and p_stable >= confidence:
            warnings.append(f"chatter observed at {n:.0f} rpm and {d * 1e3:.3g} mm where the lobes say stable with "
                            f"{100 * p_stable:.0f} % confidence: the model is off there")
        elif v == "stable" and 1 - p_stable >= confidence:
            warnings.append(f"a clean cut at {n:.0f} rpm and {d * 1e3:.3g} mm where the lobes say chatter with "
                            f"{100 * (1 - p_stable):.0f} % confidence: the model is off there")
    # Every pair (s, g): limit g s² a(n/s) at the cuts, shape (s, g, cuts).
    lim = np.minimum(g[None, :, None] * sample_limits(rpm_ext, a_ext, n_obs, s)[:, None, :], depth_cap)
    loglik = _log_likelihood(lim, depth, verdicts, sigma, LAPSE)
    w = np.exp(loglik - loglik.max())
    w /= w.sum()
    ws, wg = w.sum(axis=1), w.sum(axis=0)
    # Cuts that even the pair explaining all of them best gets wrong with ≥ P: beyond the band.
    best = np.unravel_index(int(np.argmax(w)), w.shape)
    sign = np.array([1.0 if v == "chatter" else -1.0 for v in verdicts])
    a_best = lim[best]
    p_best = ndtr(sign * (np.log(depth) - np.log(np.where(np.isfinite(a_best), a_best, 1e6))) / sigma)
    beyond = np.flatnonzero(p_best < 1 - confidence)
    if beyond.size:
        where = ", ".join(f"{n_obs[j]:.0f} rpm" for j in beyond[:3])
        warnings.append(f"no tool point within the holder's band explains the cut(s) at {where}: the holder or its "
                        "model is off (tap the assembly again), or the chatter is not the tool's")
    # The posterior predictive: pairs drawn by their weights, each limit scattered by σ
    # (normal quantiles in golden-ratio order, so the scatter is independent of the pair).
    idx = _resampled_index(w.ravel(), DRAWS)
    i_s, i_g = np.unravel_index(idx, w.shape)
    scatter = np.exp(sigma * golden_normal(DRAWS))
    per_s = sample_limits(rpm_ext, a_ext, rpm, s)
    samples = np.minimum((g[i_g] * scatter)[:, None] * per_s[i_s], depth_cap)
    one_clean = verdicts.count("stable") < 2
    if one_clean:
        # One clean cut alone never deepens the safe depth: it may have been misheard (a
        # single "stable" at 1.5× the true limit lifted it above the truth at 43 % of the
        # speeds). A second clean cut confirms it; chatter lowers it at once.
        samples = np.minimum(samples, prior.a_safe)
    low = np.quantile(samples, 1 - confidence, axis=0, method="inverted_cdf")
    high = np.maximum(np.quantile(samples, confidence, axis=0, method="inverted_cdf"), low)
    dwidth1 = _log_width(low, high)
    text = (f"{sources}; weighed by {len(inside)} observed cut(s)" if sources else
            f"weighed by {len(inside)} observed cut(s)")
    if one_clean:
        text += " (the safe depth is not raised until two cuts were clean)"
    band = LobeBand(rpm=rpm, a_safe=low, a_low=low, a_high=high, confidence=confidence,
                    safe_pockets=safe_pockets(rpm, samples, confidence), sources=text, samples=DRAWS)
    return ObservedBand(prior, band, w, s, len(inside), width0, _width(s, ws, confidence),
                        _weighted_quantile(s, ws, 0.5) - 1.0, tuple(warnings), magnitudes=g,
                        stiffness_width_before=gwidth0, stiffness_width_after=_width(g, wg, confidence),
                        stiffness_shift=_weighted_quantile(g, wg, 0.5) - 1.0,
                        depth_width_before=dwidth0, depth_width_after=dwidth1)


def lobes_with_observations(freq_hz, phi_xx, phi_yy, *, teeth: int, ktc: float, krc: float, diameter: float, ae: float,
                            milling: str, rpm, cuts=(), method: str = "auto", confidence: float = 0.9, band=None,
                            depth_cap: float = np.inf, modes=None):
    """The central lobes on ``rpm`` and the holder's band weighed by the observed ``cuts``.

    As :func:`taptune.machine.band.lobes_with_band` (``band`` as
    :func:`taptune.machine.band.band_from_prediction` gives it), then
    :func:`observed_band` with ``cuts`` = (rpm, depth [m], verdict) of the same cut.

    Returns
    -------
    (taptune.machine.lobes.Lobes, ObservedBand)
    """
    from taptune.machine.band import NO_BAND, band_parts, band_samples, central_lobes, check_confidence, extended_grid

    check_confidence(confidence)
    rel, coverage, sources, depth = band_parts(band if band is not None else (0.0, 0.9, NO_BAND))
    scales, magnitudes = band_samples(rel, coverage, depth)
    ext, inner = extended_grid(rpm, scales)
    wide = central_lobes(freq_hz, phi_xx, phi_yy, teeth=teeth, ktc=ktc, krc=krc, diameter=diameter, ae=ae,
                         milling=milling, rpm=ext, method=method, depth_cap=depth_cap, modes=modes,
                         scales=scales, magnitudes=magnitudes)
    return wide.on(inner), observed_band(ext, wide.a_lim, inner, scales, cuts, confidence, depth_cap, sources,
                                         magnitudes=magnitudes)
