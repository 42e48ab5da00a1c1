"""Tap detection: mono mix, envelope, onsets, clipped taps and double hits (MODEL.md §8.3).

A tap is a hard, short impact: the envelope jumps from the noise floor by orders of
magnitude within a fraction of a millisecond and then decays for 1–30 ms per mode. Hum,
room noise and the ring-down of earlier taps are slow by comparison, so an envelope
threshold a multiple of the median envelope finds taps without knowing their number.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np


@dataclass(frozen=True)
class Tap:
    """One detected tap.

    Attributes
    ----------
    onset : int
        Sample index of the onset (first envelope sample above the threshold).
    time_s : float
        Onset time [s].
    end : int
        Sample index (exclusive) where the tap's analysis segment ends.
    peak : float
        Largest absolute sample of the mono signal within the tap (full scale 1).
    snr_db : float
        Envelope peak over the noise floor [dB].
    clipped : bool
        Flat tops at the recording's extreme level were found in the tap.
    double_hit : bool
        A second impact 2–30 ms after the first.
    used : bool
        Whether the tap enters the averaged spectrum.
    """

    onset: int
    time_s: float
    end: int
    peak: float
    snr_db: float
    clipped: bool = False
    double_hit: bool = False
    used: bool = True

    def to_dict(self) -> dict:
        """Plain dict for JSON."""
        return {k: (float(v) if isinstance(v, np.floating) else v) for k, v in asdict(self).items()}


def moving_average(x, n: int) -> np.ndarray:
    """Centred moving average of ``x`` (n,) over ``n`` samples, same length as ``x``."""
    x = np.asarray(x, dtype=np.float64)
    n = max(int(n), 1)
    c = np.concatenate(([0.0], np.cumsum(x)))
    lo = np.clip(np.arange(x.size) - n // 2, 0, x.size)
    hi = np.clip(lo + n, 0, x.size)
    return (c[hi] - c[lo]) / np.maximum(hi - lo, 1)


def envelope(x, sample_rate: float, smooth_s: float = 0.5e-3) -> np.ndarray:
    """Smoothed absolute-value envelope of ``x`` (n,) over ``smooth_s`` seconds."""
    return moving_average(np.abs(x), round(smooth_s * sample_rate))


def to_mono(samples, sample_rate: float, smooth_s: float = 0.5e-3) -> np.ndarray:
    """Mix (n, channels) samples to one channel, favouring the channel that hears the taps.

    Each channel is weighted by its tap-to-noise amplitude ratio over its noise level
    (maximum-ratio combining) with the sign of its correlation with the best channel,
    so a quiet, inverted or dead channel neither cancels nor dilutes the taps.

    Returns
    -------
    ndarray, shape (n,)
        The mix, scaled so the best channel keeps its level; DC removed per channel.
    """
    x = np.asarray(samples, dtype=np.float64)
    if x.ndim == 1:
        return x - np.mean(x)
    x = x - np.mean(x, axis=0)
    if x.shape[1] == 1:
        return x[:, 0].copy()
    env = np.stack([envelope(x[:, c], sample_rate, smooth_s) for c in range(x.shape[1])], axis=1)
    noise = np.median(env, axis=0) + 1e-300
    signal = np.max(env, axis=0)
    snr = signal / noise
    best = int(np.argmax(snr))
    # Samples where the best channel is loud carry the taps: estimate gains there.
    loud = env[:, best] > 0.25 * signal[best]
    ref = x[loud, best]
    weights = np.zeros(x.shape[1])
    for c in range(x.shape[1]):
        num = float(np.dot(x[loud, c], ref))
        gain = num / max(float(np.dot(ref, ref)), 1e-300)
        # weight = gain / noise^2 (noise ∝ median envelope); in units of the best channel.
        weights[c] = gain * (noise[best] / noise[c]) ** 2
    if not np.any(weights > 0):
        return x[:, best].copy()
    weights[np.abs(weights) < 0.05 * np.max(np.abs(weights))] = 0.0
    # Normalise so the best channel's tap level is preserved.
    gains = np.array([np.dot(x[loud, c], ref) / max(np.dot(ref, ref), 1e-300) for c in range(x.shape[1])])
    mono = x @ weights / float(np.dot(weights, gains))
    return mono


def _flat_top_runs(seg, level: float, tol: float, min_run: int) -> bool:
    """True when ``seg`` holds ``min_run`` consecutive samples at ±``level`` (within tol)."""
    at = np.abs(np.abs(seg) - level) <= tol
    if np.count_nonzero(at) < min_run:
        return False
    # Longest run of True values.
    d = np.diff(np.concatenate(([0], at.astype(np.int8), [0])))
    starts = np.flatnonzero(d == 1)
    ends = np.flatnonzero(d == -1)
    return bool(np.max(ends - starts) >= min_run)


def clip_level(samples, subtype: str = "FLOAT") -> tuple[np.ndarray, np.ndarray]:
    """Per-channel clipping level and tolerance of (n, channels) samples.

    The level is the channel's largest absolute sample: real clipping (ADC full scale,
    or a preamp that saturates below it) holds the signal there for several samples.
    The tolerance is half an LSB for integer formats, else a relative 1e-6.
    """
    x = np.asarray(samples, dtype=np.float64)
    if x.ndim == 1:
        x = x[:, None]
    level = np.max(np.abs(x), axis=0)
    bits = {"PCM_S8": 8, "PCM_U8": 8, "PCM_16": 16, "PCM_24": 24, "PCM_32": 32}.get(subtype.upper())
    lsb = 2.0 ** (1 - bits) if bits else 0.0
    tol = np.maximum(0.5 * lsb, 1e-6 * level)
    return level, tol


def is_double_hit(env_slow, onset: int, sample_rate: float, window_s=(2e-3, 30e-3),
                  rise: float = 2.0, min_fraction: float = 0.2) -> bool:
    """Whether a second impact follows the onset within ``window_s`` [s].

    ``env_slow`` (n,) is an envelope smoothed over ~2 ms (long enough to average out the
    beating of modes more than ~500 Hz apart). A second hit shows as a rise of the
    envelope by ``rise`` over its running minimum since the first peak, to at least
    ``min_fraction`` of that peak; a free ring-down only decays.
    """
    a = onset + int(round(window_s[0] * sample_rate))
    b = min(onset + int(round(window_s[1] * sample_rate)), env_slow.size)
    if b - a < 3:
        return False
    head = env_slow[onset:a + 1]
    first_peak = float(np.max(head)) if head.size else float(env_slow[onset])
    seg = env_slow[onset + int(np.argmax(head)):b]
    if seg.size < 3:
        return False
    run_min = np.minimum.accumulate(seg)
    up = (seg > rise * run_min) & (seg > min_fraction * first_peak)
    return bool(np.any(up))


def find_taps(mono, sample_rate: float, *, raw=None, subtype: str = "FLOAT",
              smooth_s: float = 0.5e-3, threshold: float = 10.0,
              min_interval_s: float = 0.3, pre_onset_s: float = 2e-3,
              segment_s: float = 0.25, double_hit_window_s=(2e-3, 30e-3)) -> list[Tap]:
    """Find every tap in a mono signal.

    Parameters
    ----------
    mono : ndarray, shape (n,)
        Mono signal, DC removed.
    sample_rate : float
        [Hz].
    raw : ndarray, shape (n, channels), optional
        The samples as read, for clipping (a clipped channel clips the tap).
    subtype : str
        soundfile subtype of ``raw`` (integer full scale / LSB).
    smooth_s : float
        Envelope smoothing [s].
    threshold : float
        Onset threshold as a multiple of the noise floor (median envelope).
    min_interval_s : float
        Minimum spacing of taps [s]; a rise within it belongs to the same tap.
    pre_onset_s, segment_s : float
        Segment start before the onset and maximum segment length [s].
    double_hit_window_s : (float, float)
        Where a second onset makes a double hit [s after onset].

    Returns
    -------
    list of Tap
        In time order; ``used`` is False for clipped taps and double hits unless no
        clean tap exists (then all are used and the caller warns).
    """
    x = np.asarray(mono, dtype=np.float64)
    fs = float(sample_rate)
    env = envelope(x, fs, smooth_s)
    floor = float(np.median(env))
    if floor <= 0.0:
        # Digital silence between taps: use a tiny positive floor above rounding noise.
        nz = env[env > 0]
        floor = float(np.min(nz)) if nz.size else 0.0
    if floor <= 0.0:
        return []
    above = env > threshold * floor
    crossings = np.flatnonzero(above[1:] & ~above[:-1]) + 1
    if above[0]:
        crossings = np.concatenate(([0], crossings))
    min_gap = int(round(min_interval_s * fs))
    onsets: list[int] = []
    for c in crossings:
        if not onsets or c - onsets[-1] >= min_gap:
            onsets.append(int(c))
    if not onsets:
        return []
    env_slow = envelope(x, fs, 2e-3)
    seg_n = int(round(segment_s * fs))
    pre = int(round(pre_onset_s * fs))
    if raw is not None:
        raw2 = np.asarray(raw, dtype=np.float64)
        raw2 = raw2[:, None] if raw2.ndim == 1 else raw2
        level, tol = clip_level(raw2, subtype)
    taps = []
    for i, on in enumerate(onsets):
        nxt = onsets[i + 1] - pre if i + 1 < len(onsets) else x.size
        end = int(min(on + seg_n, nxt, x.size))
        seg = x[on:end]
        peak = float(np.max(np.abs(seg))) if seg.size else 0.0
        snr = 20 * np.log10(max(float(np.max(env[on:end])) if end > on else 0.0, 1e-300) / floor)
        clipped = False
        if raw is not None:
            s0 = max(on - pre, 0)
            for c in range(raw2.shape[1]):
                # A flat top needs a level that is not itself noise-like.
                if level[c] > 0 and _flat_top_runs(raw2[s0:end, c], level[c], tol[c], 3):
                    clipped = True
        dbl = is_double_hit(env_slow, on, fs, double_hit_window_s)
        taps.append(Tap(onset=on, time_s=on / fs, end=end, peak=peak, snr_db=float(snr),
                        clipped=clipped, double_hit=dbl, used=not (clipped or dbl)))
    if not any(t.used for t in taps):
        taps = [Tap(**{**t.__dict__, "used": True}) for t in taps]
    return taps
