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

Signatures::

    set_weights(limits, depths, verdicts, sigma=SIGMA) -> ndarray (n_sets,)
    weighted_band(a_lim, weights, quantiles=(0.05, 0.5, 0.95)) -> ndarray (len(quantiles), n_speeds)
"""

from __future__ import annotations

import numpy as np

#: Relative scatter of a stability limit that the holder's parameter sets do not capture.
SIGMA = 0.15


def set_weights(limits, depths, verdicts, sigma: float = SIGMA) -> np.ndarray:
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
    """
    from scipy.special import log_ndtr

    a = np.asarray(limits, float)
    a = a[:, None] if a.ndim == 1 else a
    d = np.asarray(depths, float)
    z = (np.log(d)[None, :] - np.log(np.where(np.isfinite(a), a, 1e6))) / sigma
    sign = np.array([{"chatter": 1.0, "stable": -1.0}.get(v, 0.0) for v in verdicts])
    loglik = np.where(sign != 0, log_ndtr(sign[None, :] * z), 0.0).sum(axis=1)
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
