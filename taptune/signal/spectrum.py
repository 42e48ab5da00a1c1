"""Per-tap spectra, their average, and the noise spectrum between taps (docs/physics.md §4).

A tap's ring-down (decay time 1–30 ms) is practically complete within 0.25 s, so each
segment is transformed with a rectangular window, a short cosine fade at the end, and
zero-padding to a fine bin spacing. The same segments, started just after the onset and
without the fade, give the complex spectra the peak refinement fits (``peaks.py``).
"""

from __future__ import annotations

import functools

import numpy as np
from scipy import fft as sfft

from taptune.signal.taps import Tap


def fft_length(n_samples: int, sample_rate: float, max_bin_hz: float = 1.0) -> int:
    """Smallest fast FFT length ≥ ``n_samples`` with bin spacing ≤ ``max_bin_hz`` [Hz]."""
    n = max(int(n_samples), int(np.ceil(sample_rate / max_bin_hz)))
    return int(sfft.next_fast_len(n, real=True))


def tap_segments(mono, sample_rate: float, taps: list[Tap], start_s: float, n_max: int,
                 fade_fraction: float = 0.0) -> np.ndarray:
    """Stack the taps' segments, each starting ``start_s`` [s] after its onset.

    Parameters
    ----------
    mono : ndarray, shape (n,)
    taps : list of Tap
        Segments end at ``tap.end``; shorter ones are zero-filled.
    start_s : float
        Segment start relative to the onset [s] (negative = before it).
    n_max : int
        Rows are ``n_max`` samples long.
    fade_fraction : float
        Length of a raised-cosine fade-out, as a fraction of each segment.

    Returns
    -------
    ndarray, shape (len(taps), n_max)
        Mean-removed segments.
    """
    x = np.asarray(mono, dtype=np.float64)
    out = np.zeros((len(taps), n_max))
    shift = int(round(start_s * sample_rate))
    for i, t in enumerate(taps):
        a = max(t.onset + shift, 0)
        b = min(t.end, a + n_max)
        if b > a:
            out[i, :b - a] = fade_out(x[a:b] - np.mean(x[a:b]), fade_fraction)
    return out


def fade_out(seg, fraction: float) -> np.ndarray:
    """``seg`` (..., n) with a raised-cosine fade over its last ``fraction`` of samples."""
    seg = np.array(seg, dtype=np.float64)
    m = int(round(fraction * seg.shape[-1]))
    if m > 1:
        seg[..., -m:] *= 0.5 * (1 + np.cos(np.pi * np.arange(m) / (m - 1)))
    return seg


@functools.lru_cache(maxsize=8)
def window_leakage_db(n: int, fade_fraction: float, n_fft: int, max_bins: int) -> tuple[np.ndarray, int]:
    """How far a steady sinusoid leaks through the segment window, bin by bin.

    The tap segments are rectangular windows of ``n`` samples with a raised-cosine fade
    over their last ``fade_fraction``, zero-padded to ``n_fft``: a mode still ringing at
    the segment's end (a long ring-down) is cut off there and its peak grows side lobes,
    spaced about one native bin (fs/n) apart. A decaying mode leaks less: the undamped
    one is the worst case.

    Returns
    -------
    envelope_db : ndarray, shape (max_bins + 1,)
        Highest side lobe at or beyond each offset from the peak, in bins of ``n_fft``
        [dB re the peak] (non-increasing).
    first_null : int
        Offset of the main lobe's first minimum [bins]: within it, a separate maximum is
        another mode, never leakage.
    """
    w = fade_out(np.ones(int(n)), fade_fraction)
    mag = np.abs(sfft.rfft(w, n=int(n_fft), workers=1))[:int(max_bins) + 1]
    mag = mag / mag[0]
    dips = np.flatnonzero((mag[1:-1] <= mag[:-2]) & (mag[1:-1] <= mag[2:])) + 1
    first_null = int(dips[0]) if dips.size else mag.size
    env = np.maximum.accumulate(mag[::-1])[::-1]
    return 20 * np.log10(env + 1e-300), first_null


def spectra(segments, sample_rate: float, n_fft: int) -> tuple[np.ndarray, np.ndarray]:
    """Complex one-sided spectra of segments (k, n) zero-padded to ``n_fft``.

    Returns
    -------
    freq_hz : ndarray, shape (n_fft // 2 + 1,)
    spec : ndarray, shape (k, n_fft // 2 + 1), complex
        Unscaled DFT (sum over samples), so a decaying mode has the same peak height
        whatever the zero-padding.
    """
    spec = sfft.rfft(np.asarray(segments, dtype=np.float64), n=n_fft, axis=-1, workers=1)
    freq = np.arange(spec.shape[-1]) * (sample_rate / n_fft)
    return freq, spec


def noise_segments(mono, sample_rate: float, taps: list[Tap], n_seg: int, margin_s: float = 5e-3,
                   max_count: int = 4) -> np.ndarray:
    """Up to ``max_count`` segments of ``n_seg`` samples that contain no tap ring-down.

    They lie before the first tap or after a tap's segment ends; the noise spectrum
    from them shows what is there without a tap (hum, room noise), which tells a
    structural peak from a stationary one. Returns shape (k, n_seg), k may be 0.
    """
    x = np.asarray(mono, dtype=np.float64)
    margin = int(round(margin_s * sample_rate))
    busy = np.zeros(x.size + 1, dtype=np.int32)
    for t in taps:
        busy[max(t.onset - margin, 0)] += 1
        busy[min(t.end + margin, x.size)] -= 1
    quiet = np.cumsum(busy[:-1]) == 0
    out = []
    i = 0
    while i + n_seg <= x.size and len(out) < max_count:
        if quiet[i] and quiet[i + n_seg - 1] and np.all(quiet[i:i + n_seg]):
            seg = x[i:i + n_seg]
            out.append(seg - np.mean(seg))
            i += n_seg
        else:
            nxt = np.flatnonzero(~quiet[i:i + n_seg])
            i += int(nxt[-1]) + 1 if nxt.size else n_seg
    return np.array(out).reshape(len(out), n_seg)


def smooth_floor(freq_hz, mag, width_hz: float = 400.0, q: float = 30.0) -> np.ndarray:
    """A spectrum's floor: the ``q``-th percentile of ``mag`` in blocks of ``width_hz``.

    Peaks occupy a small fraction of each block, so a low percentile follows the noise
    and the broad trend (microphone roll-off) and ignores the peaks. Interpolated in dB
    back onto ``freq_hz``; shape of ``mag``.
    """
    f = np.asarray(freq_hz)
    m = np.asarray(mag, dtype=np.float64)
    df = f[1] - f[0]
    nb = max(int(round(width_hz / df)), 4)
    nblk = m.size // nb
    if nblk < 2:
        return np.full_like(m, np.percentile(m, q))
    blocks = m[:nblk * nb].reshape(nblk, nb)
    lv = np.log(np.percentile(blocks, q, axis=1) + 1e-300)
    centres = f[:nblk * nb].reshape(nblk, nb).mean(axis=1)
    return np.exp(np.interp(f, centres, lv))
