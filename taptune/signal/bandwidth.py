"""How high a recording really reaches: a codec's low-pass, or Nyquist.

Perceptual codecs (AAC, MP3, Opus, Vorbis) throw away what lies above a cut-off chosen
from the bit rate: 12–20 kHz is common on phones. Above it the file holds next to
nothing, not even the microphone's noise, while below it the noise floor is intact. A
bending mode above the cut-off cannot be measured, and one just below it is distorted by
the codec's transition band. A microphone or the tap's contact force roll off gently
(12 dB per octave or so) and never empty the spectrum, so a steep step of the broadband
level down to a floor is the codec's mark.
"""

from __future__ import annotations

import numpy as np

#: Width of the bands whose median level tracks the broadband floor [Hz].
BAND_HZ = 250.0
#: A cut-off: the level falls at least this much [dB] ...
DROP_DB = 20.0
#: ... within this span above the cut-off [Hz] (a gentle roll-off needs octaves for it) ...
TRANSITION_HZ = 500.0
#: ... measured against the median level of this span below it [Hz].
REFERENCE_HZ = 1000.0
#: Cut-offs are sought above this frequency [Hz] (below it the taps carry everything).
FMIN_HZ = 2000.0
#: A mode closer than this (relative) below the cut-off is distorted by the transition band.
EDGE_MARGIN = 0.03


def band_levels_db(freq_hz, magnitude, band_hz: float = BAND_HZ):
    """Median level [dB] of ``magnitude`` in consecutive bands of ``band_hz``.

    Parameters
    ----------
    freq_hz : ndarray, shape (m,)
        Uniform frequency grid [Hz].
    magnitude : ndarray, shape (m,)
        Linear magnitude spectrum.

    Returns
    -------
    edges : ndarray, shape (k + 1,)
        Band edges [Hz].
    level_db : ndarray, shape (k,)
        Median of ``20 log10 |S|`` in each band (peaks barely move a median: it follows the
        broadband floor).
    """
    f = np.asarray(freq_hz, dtype=float)
    db = 20 * np.log10(np.abs(np.asarray(magnitude, dtype=float)) + 1e-300)
    edges = np.arange(0.0, f[-1] + band_hz, band_hz)
    idx = np.searchsorted(f, edges)
    level = np.array([np.median(db[a:b]) if b > a else np.nan for a, b in zip(idx[:-1], idx[1:])])
    return edges, level


def effective_bandwidth(freq_hz, magnitude, sample_rate: float, *, drop_db: float = DROP_DB,
                        band_hz: float = BAND_HZ, transition_hz: float = TRANSITION_HZ,
                        reference_hz: float = REFERENCE_HZ, fmin_hz: float = FMIN_HZ) -> tuple[float, bool]:
    """The highest frequency a recording carries [Hz], and whether a low-pass set it.

    A low-pass sits at the lowest band edge ``c`` at which the median level of the
    ``reference_hz`` below ``c`` exceeds by ``drop_db`` every band from
    ``c + transition_hz`` up to 98 % of Nyquist; the cut-off is the first band edge
    after ``c`` where the level has fallen half-way. Without one, the bandwidth is Nyquist.

    Parameters
    ----------
    freq_hz : ndarray, shape (m,)
        Uniform frequency grid [Hz] from 0 to (about) Nyquist.
    magnitude : ndarray, shape (m,)
        Linear magnitude spectrum of the taps (or of the whole recording).
    sample_rate : float
        [Hz].

    Returns
    -------
    bandwidth_hz : float
        The cut-off, or Nyquist ``sample_rate / 2``.
    low_pass : bool
        True when a cut-off below Nyquist was found.
    """
    nyquist = float(sample_rate) / 2
    edges, level = band_levels_db(freq_hz, magnitude, band_hz)
    top = np.searchsorted(edges, 0.98 * nyquist, side="right") - 1  # bands wholly inside
    n_ref = max(int(round(reference_hz / band_hz)), 1)
    n_gap = max(int(round(transition_hz / band_hz)), 1)
    first = max(int(np.ceil(fmin_hz / band_hz)), n_ref)
    # Highest level from band k up to the top: one backward running maximum.
    above = np.maximum.accumulate(np.nan_to_num(level[:top], nan=-np.inf)[::-1])[::-1]
    for c in range(first, top - n_gap):
        below = np.nanmedian(level[c - n_ref:c])
        if below - above[c + n_gap] >= drop_db:
            # The step lies within the transition span after c: where the level is half-way down.
            fallen = np.flatnonzero(level[c:c + n_gap + 1] < below - drop_db / 2)
            return float(edges[c + fallen[0]]), True
    return nyquist, False


def hidden_modes(expected_hz, bandwidth_hz: float, sample_rate: float, edge_margin: float = EDGE_MARGIN):
    """Expected modes a recording cannot show: ``[(mode, f_hz, limit_hz), ...]``.

    A mode is hidden when it lies above ``(1 - edge_margin)`` of the effective bandwidth
    (its peak would be cut or bent by the transition band) or above 0.9 × Nyquist (where
    anti-alias filters already roll off). ``limit_hz`` is the tighter limit.
    """
    limit = min((1 - edge_margin) * bandwidth_hz, 0.9 * sample_rate / 2)
    return [(n, float(f), limit) for n, f in enumerate(np.asarray(expected_hz, dtype=float), 1) if f > limit]
