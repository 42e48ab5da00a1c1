"""Tap detection: mono mix, envelope, onsets, clipped taps and double hits (docs/tap-test.md).

A tap is a hard, short impact: the envelope jumps from the noise floor by orders of
magnitude within a fraction of a millisecond and then decays for 1–30 ms per mode. Hum,
room noise and the ring-down of earlier taps are slow by comparison, so an envelope
threshold a multiple of the median envelope finds taps without knowing their number.
Not every sharp rise is a tap: one far below the recording's taps (a thump, a click) and
one that does not ring down (a word, a note, a machine; :func:`rings_down`,
:func:`ring_time`) are kept apart as ``rejected`` events, never averaged in.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, replace

import numpy as np
from scipy.linalg import solve_toeplitz


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
    clip_level : float
        Level of the flat tops (full scale 1) when ``clipped``, else 0.
    rejected : str
        Why the event is not a tap at all ("" for a tap): ``"faint"`` (far below the
        recording's taps: a thump, a click, a codec's pre-echo) or ``"no ring-down"`` (the
        sound grows or holds after its onset: speech, music, a machine starting).
    """

    onset: int
    time_s: float
    end: int
    peak: float
    snr_db: float
    clipped: bool = False
    double_hit: bool = False
    used: bool = True
    clip_level: float = 0.0
    rejected: str = ""

    def to_dict(self) -> dict:
        """Plain dict for JSON."""
        return {k: (float(v) if isinstance(v, np.floating) else v) for k, v in asdict(self).items()}


def moving_average(x, n: int) -> np.ndarray:
    """Centred moving average of ``x`` (n,) over ``n`` samples, same length as ``x``.

    Near the ends the window shrinks to the samples available.
    """
    x = np.asarray(x, dtype=np.float64)
    n = min(max(int(n), 1), x.size)
    c = np.empty(x.size + 1)
    c[0] = 0.0
    np.cumsum(x, out=c[1:])
    h = n // 2
    out = np.empty_like(x)
    # Interior: full windows [i − h, i − h + n).
    lo_end = x.size - n + h + 1
    out[h:lo_end] = (c[n:] - c[:x.size - n + 1]) / n
    for i in list(range(h)) + list(range(lo_end, x.size)):
        a, b = max(i - h, 0), min(i - h + n, x.size)
        out[i] = (c[b] - c[a]) / (b - a)
    return out


def robust_floor(env) -> float:
    """Median of an envelope (on every 8th sample: plenty for a level estimate, 8x faster)."""
    e = np.asarray(env)
    return float(np.median(e[::8] if e.size > 8000 else e))


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
    # Channel-major copy: every per-channel reduction below runs on contiguous memory.
    xs = np.array(x.T, dtype=np.float64, order="C")
    xs -= xs.mean(axis=1, keepdims=True)
    if xs.shape[0] == 1:
        return xs[0]
    env = [envelope(c, sample_rate, smooth_s) for c in xs]
    noise = np.array([robust_floor(e) for e in env]) + 1e-300
    signal = np.array([float(np.max(e)) for e in env])
    best = int(np.argmax(signal / noise))
    # Samples where the best channel is loud carry the taps: estimate gains there.
    loud = env[best] > 0.25 * signal[best]
    ref = xs[best, loud]
    ref_energy = max(float(np.dot(ref, ref)), 1e-300)
    gains = np.array([float(np.dot(c[loud], ref)) / ref_energy for c in xs])
    # Maximum-ratio weights gain / noise² (noise ∝ median envelope), best channel = 1;
    # a channel that hardly hears the taps (dead, disconnected) gets none.
    heard = np.abs(gains) >= 0.05 * np.max(np.abs(gains))
    noise = np.maximum(noise, 1e-9 * signal[best])
    weights = np.where(heard, gains * (noise[best] / noise) ** 2, 0.0)
    # Normalise so the best channel's tap level is preserved.
    return weights @ xs / float(np.dot(weights, gains))


def _flat_top_level(seg, hi: float, lo: float, tol: float, min_run: int = 2, min_count: int = 3) -> float:
    """The level (full scale 1) at which ``seg`` sits at its channel's extreme ``hi`` or
    ``lo`` (within tol) for ``min_run`` consecutive samples or ``min_count`` samples in
    all; 0 when it does not.

    A free ring-down reaches its extremes once; a clipped one stays there (each clipped
    half-cycle holds one or more samples at the limit). The two polarities are checked
    separately because a DC offset makes them clip at different levels.
    """
    at_hi = np.abs(seg - hi) <= tol
    at_lo = np.abs(seg - lo) <= tol
    n_hi, n_lo = np.count_nonzero(at_hi), np.count_nonzero(at_lo)
    level = float(abs(hi)) if n_hi >= n_lo else float(abs(lo))
    if n_hi + n_lo >= min_count:
        return level
    if n_hi + n_lo < min_run:  # too few samples at either extreme for a run (the usual case)
        return 0.0
    # A run must stay at one extreme: at a low sample rate (8 kHz) a free ring-down of a
    # mode near Nyquist swings from its maximum to its minimum in one sample, which is no
    # flat top.
    if _longest_run(at_hi) >= min_run:
        return float(abs(hi))
    return float(abs(lo)) if _longest_run(at_lo) >= min_run else 0.0


def _run_lengths(mask) -> np.ndarray:
    """Lengths of the runs of True values in the 1-D boolean ``mask``."""
    d = np.diff(np.concatenate(([0], np.asarray(mask, dtype=np.int8), [0])))
    return np.flatnonzero(d == -1) - np.flatnonzero(d == 1)


def _longest_run(mask) -> int:
    """Length of the longest run of True values in the 1-D boolean ``mask``."""
    return int(_run_lengths(mask).max(initial=0))


#: "At or very near full scale": within 0.1 dB of it (a recorder's own limiter or a
#: converter that stops one LSB short still counts; a loud but clean sound stays below).
NEAR_FULL_SCALE = 10 ** (-0.1 / 20)


def full_scale_runs(samples, min_run: int = 3, level: float = NEAR_FULL_SCALE) -> int:
    """Number of stretches of ``min_run`` or more consecutive samples at full scale.

    Parameters
    ----------
    samples : array_like, shape (n,) or (n, channels)
        Samples, full scale 1.
    min_run : int
        Consecutive samples at one polarity's limit that make a flat top.
    level : float
        What counts as full scale (|x| ≥ ``level``).

    Returns
    -------
    int
        Flat tops over all channels and both polarities. A ring-down passes its peak in
        one or two samples; three in a row at full scale is an overloaded input, whether
        or not a tap can be found in it (an input so hot that the noise clips hides the taps).
    """
    x = np.asarray(samples, dtype=np.float64)
    x = x[:, None] if x.ndim == 1 else x
    total = 0
    for c in range(x.shape[1]):
        col = x[:, c]
        for mask in (col >= level, col <= -level):
            total += int(np.count_nonzero(_run_lengths(mask) >= min_run))
    return total


_INTEGER_BITS = {"PCM_S8": 8, "PCM_U8": 8, "PCM_16": 16, "PCM_24": 24, "PCM_32": 32}


def integer_bits(samples, subtype: str = "FLOAT") -> int | None:
    """Bits per sample of an integer recording: from its format, or of a float file that
    holds integer samples (a 16- or 24-bit recording saved as float); None otherwise."""
    bits = _INTEGER_BITS.get(subtype.upper())
    if bits or subtype.upper() not in ("FLOAT", "DOUBLE"):
        return bits
    x = np.asarray(samples, dtype=np.float64).ravel()
    probe = x[::max(x.size // 4096, 1)]  # a float recording fails on its first few samples
    for b in (16, 24):
        scale = 2.0 ** (b - 1)
        if all(np.array_equal(v * scale, np.round(v * scale)) for v in (probe, x)):
            return b
    return None


def clip_levels(samples, subtype: str = "FLOAT") -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per channel, the levels a flat top must sit at to be clipping (max, min) of
    (n, channels) samples, and a tolerance.

    Real clipping holds the signal at a limit for several samples. An integer recording
    clips at its format's full scale only: a 16-bit file peaking at −8 dBFS is not
    clipped, however many equal samples a slow peak holds (its values change by less than
    one step near a crest). Its limits are ±inf unless the channel reaches within
    :data:`NEAR_FULL_SCALE` of full scale; the tolerance is then half a step. A float
    recording (and a lossy codec's decoded output) has no such steps, so equal samples
    at its extremes are a flat top at any level — a limiter or a saturating preamp
    below full scale; the tolerance is a relative 1e-9.
    """
    x = np.asarray(samples, dtype=np.float64)
    if x.ndim == 1:
        x = x[:, None]
    cols = [np.ascontiguousarray(x[:, c]) for c in range(x.shape[1])]
    hi = np.array([float(np.max(c)) for c in cols])
    lo = np.array([float(np.min(c)) for c in cols])
    bits = integer_bits(x, subtype)
    lsb = 2.0 ** (1 - bits) if bits else 0.0
    tol = np.maximum(0.5 * lsb, 1e-9 * np.maximum(np.abs(hi), np.abs(lo)))
    if bits:
        hi = np.where(hi >= NEAR_FULL_SCALE - tol, hi, np.inf)
        lo = np.where(lo <= -NEAR_FULL_SCALE + tol, lo, -np.inf)
    return hi, lo, tol


def is_double_hit(x, onset: int, sample_rate: float, window_s=(2e-3, 30e-3), order: int = 24,
                  ratio: float = 0.35, outlier: float = 2.5) -> bool:
    """Whether a second impact follows the onset within ``window_s`` [s].

    After an impact the sound is a sum of decaying sinusoids, which a linear predictor
    (order ``order``, fitted on this stretch) predicts almost perfectly, beats included;
    an impact is a broadband transient it cannot predict. So the prediction error has
    a spike at the first impact, and a second spike where a second impact comes. A
    reflection is a transient too, but weaker (the wall is farther than the tool), so
    only spikes of at least ``ratio`` times the first count.

    A soft tap (a knuckle, a felt or rubber mallet: a contact of a few ms on a body that
    rings at a few hundred Hz) is no clean spike: its prediction error stays ragged for
    tens of ms, with many bumps of similar height. A second impact is one spike standing
    ``outlier`` times above the 95th percentile of the error elsewhere in the window (more
    than 2 ms from it: AAC smears a spike over a few ms); on real knuckle taps that ratio
    stays below 2.3, on second impacts of 0.4–0.8 times the first it is 2.5–4.5 (WAV,
    MP3, AAC and Opus alike).
    """
    fs = float(sample_rate)
    start = max(onset - int(0.5e-3 * fs), 0)
    stop = min(onset + int(round((window_s[1] + 3e-3) * fs)), len(x))
    seg = np.asarray(x[start:stop], dtype=np.float64)
    if seg.size < 4 * order:
        return False
    # Autocorrelation at lags 0…order only (a full correlation is O(n²)).
    r = np.array([np.dot(seg[:seg.size - k], seg[k:]) for k in range(order + 1)])
    if r[0] <= 0:
        return False
    r[0] *= 1.0 + 1e-9  # white-noise correction keeps the Toeplitz system regular
    try:
        a = solve_toeplitz(r[:order], -r[1:order + 1])
    except np.linalg.LinAlgError:
        return False
    # The prediction-error filter is FIR: a convolution (scipy.signal costs ~0.6 s to import).
    err = np.convolve(seg, np.concatenate(([1.0], a)))[:seg.size]
    env = moving_average(np.abs(err), round(0.3e-3 * fs))
    k0 = onset - start
    k_first = int(np.argmax(env[:k0 + int(2e-3 * fs)]))
    first = float(env[k_first])
    w0 = k0 + int(window_s[0] * fs)
    later = env[w0:k0 + int(window_s[1] * fs)]
    if not later.size:
        return False
    # In noise the prediction error is noise everywhere: a spike must also stand out
    # from the error's own median (noise bumps of a 0.3 ms envelope reach ~2x).
    k_top = w0 + int(np.argmax(later))
    top = float(env[k_top])
    # ... and be an event of its own: the error falls in between. A lossy codec (AAC)
    # smears the impact over a few ms, so the first spike's tail reaches into the window.
    separate = float(np.min(env[k_first:k_top + 1])) < 0.5 * top
    guard = max(int(2e-3 * fs), 1)
    kt = k_top - w0
    rest = np.concatenate([later[:max(kt - guard, 0)], later[kt + guard:]])
    alone = not rest.size or top > outlier * float(np.percentile(rest, 95))
    return bool(top > ratio * first and top > 3.0 * float(np.median(later)) and separate and alone)


def louder_second_strike(x, onset: int, sample_rate: float, window_s=(2e-3, 30e-3), dip_db: float = 10.0,
                         rise: float = 3.0) -> bool:
    """Whether a second strike louder than the first follows the onset within ``window_s`` [s].

    The prediction-error test (:func:`is_double_hit`) looks for a spike standing out of
    the first impact's ring; a second strike that is the louder one (a knock on a cup:
    a glancing touch, then the blow 20 ms later) drowns that test in its own ring. Its
    2 ms envelope shows it plainly: the first ring falls ``dip_db`` below its peak, then
    jumps ``rise`` times within 3 ms to above that peak. A ring cannot do that (it only
    decays; beating modes swell back at most to where they started), a soft tap's ragged
    contact lasts 2-4 ms, not a 10 dB dip.
    """
    fs = float(sample_rate)
    env = envelope(np.asarray(x[onset:onset + int((window_s[1] + 5e-3) * fs)], dtype=np.float64), fs, 2e-3)
    k0 = int(window_s[0] * fs)
    if env.size <= k0 + 1:
        return False
    first = float(np.max(env[:k0]))
    later = env[k0:]
    k = int(np.argmax(later))
    if later[k] <= first:
        return False
    dip = float(np.min(later[:k + 1]))
    before = float(np.min(later[max(k - int(3e-3 * fs), 0):k + 1]))
    return dip < first * 10 ** (-dip_db / 20) and later[k] > rise * before


def ring_time(env, onset: int, sample_rate: float, before_s=(20e-3, 1e-3), ratio: float = 2.0,
              peak_within_s: float = 5e-3, max_s: float = 30e-3, gap_s: float = 4e-3) -> float:
    """How long [s] the envelope ``env`` stays above ``ratio`` times its level before the
    onset (the median over ``before_s`` before it), counted from its peak within
    ``peak_within_s`` after the onset (a lossy codec's pre-echo can trigger the onset a
    few ms early), at most ``max_s``.

    A 0.5 ms envelope of a low ring dips at every zero crossing (a 164 Hz ring's
    half-period is 3 ms): only a stay below for ``gap_s`` ends the ring. That matters
    where a tap follows the last one's ring closely (knocks 0.15 s apart), so the level
    before it is that ring's, not the room's.
    """
    fs = float(sample_rate)
    a, b = max(onset - int(before_s[0] * fs), 0), max(onset - int(before_s[1] * fs), 0)
    level = float(np.median(env[a:b])) if b > a else 0.0
    seg = np.asarray(env[onset:onset + int(max_s * fs)])
    k = int(np.argmax(seg[:max(int(peak_within_s * fs), 1)]))
    w = max(int(gap_s * fs), 1)
    # First i with the envelope at or below the level over all of [i, i + w) (past the end counts as below).
    above = np.concatenate([np.asarray(seg[k:]) > ratio * level, np.zeros(w - 1, dtype=bool)])
    run = np.concatenate(([0], np.cumsum(above)))
    below = np.flatnonzero(run[w:] - run[:-w] == 0)
    return (int(below[0]) if below.size else seg.size - k) / fs


def rings_down(env, onset: int, end: int, sample_rate: float, early_s: float = 35e-3,
               min_decay_db: float = 6.0, growth_db: float = 3.0) -> bool:
    """Whether the event at ``onset`` is an impact ring: loudest just after its onset, then
    decaying.

    ``env`` is a 2 ms envelope. An impact puts all its energy in at once: the envelope peaks
    within ``early_s`` of the onset (a resonator tube or beating modes may swell it a
    little, up to ``growth_db``; a second strike within the double-hit window, 30 ms, may
    be the louder one: a double hit, not a swell) and has fallen by ``min_decay_db`` over the last 40 % of
    the segment. A word grows into its vowel after a plosive, a note swells and holds, a
    machine that starts stays loud: none of them does both. Segments shorter than 60 ms
    (a tap cut off by the end of the file) are not judged.
    """
    fs = float(sample_rate)
    seg = np.asarray(env[onset:end])
    n_early = int(early_s * fs)
    if seg.size < max(int(0.06 * fs), n_early + 1):
        return True
    early = float(np.max(seg[:n_early]))
    later = float(np.max(seg[n_early:]))
    tail = float(np.median(seg[int(0.6 * seg.size):]))
    if later > early * 10 ** (growth_db / 20):
        return False
    return early >= tail * 10 ** (min_decay_db / 20)


def find_taps(mono, sample_rate: float, *, raw=None, subtype: str = "FLOAT",
              smooth_s: float = 0.5e-3, threshold: float = 5.0,
              rise: float = 3.0, min_interval_s: float = 0.1, pre_onset_s: float = 2e-3,
              segment_s: float = 0.25, double_hit_window_s=(2e-3, 30e-3),
              faint_db: float = 24.0, min_ring_s: float = 1.5e-3) -> list[Tap]:
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
    rise : float
        An onset also stands this many times above the envelope 3–12 ms before it.
    min_interval_s : float
        Minimum spacing of taps [s]; a rise within it belongs to the same tap, unless it
        is ``rise`` times louder than all since (then what came first was a faint
        precursor: a click, the noise of a gated recorder opening 0.1 s before the tap,
        which must not swallow it). Knocks by hand come 0.14–0.3 s apart.
    pre_onset_s, segment_s : float
        Segment start before the onset and maximum segment length [s].
    double_hit_window_s : (float, float)
        Where a second onset makes a double hit [s after onset].
    faint_db : float
        An event whose peak lies more than this below the loudest tap's is no tap
        (``rejected="faint"``): taps by hand differ by up to ~20 dB, while a handling
        thump, a click or a codec's artefact lies 26–45 dB below them.
    min_ring_s : float
        An event that stands out of what came before for less than this (a click, a
        clank in machine noise; :func:`ring_time`) is no tap either: the most damped
        bending mode worth measuring (ζ = 2 %, a finger on the tool, at 3 kHz) rings
        for about 4 ms after its peak over a 20 dB background, a click for under 1 ms.

    Returns
    -------
    list of Tap
        In time order; ``used`` is False for clipped taps and double hits unless no
        clean tap exists (then all clean-or-not taps are used and the caller warns),
        and for events that are no tap at all (``rejected``: faint, or no ring-down,
        :func:`rings_down`).
    """
    x = np.asarray(mono, dtype=np.float64)
    fs = float(sample_rate)
    env = envelope(x, fs, smooth_s)
    floor = robust_floor(env)
    if floor <= 0.0:
        # Digital silence between taps: use a tiny positive floor above rounding noise.
        nz = env[env > 0]
        floor = float(np.min(nz)) if nz.size else 0.0
    if floor <= 0.0:
        return []
    # An impact jumps out of what came before; a ring-down that wanders about the
    # threshold (beats, the faint precursor of a hysteretic model) does not. So an onset
    # is where the envelope is above the threshold *and* 3x above its maximum over
    # the 3-12 ms before (block maxima of 1 ms keep this cheap).
    blk = max(int(fs * 1e-3), 1)
    bmax = np.maximum.reduceat(env, np.arange(0, env.size, blk))
    padded = np.concatenate([np.zeros(12), bmax])
    lag_max = np.lib.stride_tricks.sliding_window_view(padded, 10)[:bmax.size].max(axis=1)
    sharp = (env > threshold * floor) & (env > rise * lag_max[np.arange(env.size) // blk])
    starts = np.flatnonzero(sharp[1:] & ~sharp[:-1]) + 1
    if sharp[0]:
        starts = np.concatenate(([0], starts))
    min_gap = int(round(min_interval_s * fs))
    # Within min_gap a rise still starts an event of its own if it is `rise` times louder
    # than everything since the last onset (that was a precursor: a click, a gated
    # recorder opening 0.1 s before the tap), unless it comes within the double-hit
    # window (a second strike of the same tap).
    dbl_end = int(round(double_hit_window_s[1] * fs))
    peak_n = max(int(2e-3 * fs), 1)
    onsets: list[int] = []
    for c in starts:
        if not onsets or c - onsets[-1] >= min_gap or (
                c - onsets[-1] > dbl_end
                and float(np.max(env[c:c + peak_n])) > rise * float(np.max(env[onsets[-1]:c]))):
            onsets.append(int(c))
    if not onsets:
        return []
    seg_n = int(round(segment_s * fs))
    pre = int(round(pre_onset_s * fs))
    if raw is not None:
        raw2 = np.asarray(raw, dtype=np.float64)
        raw2 = raw2[:, None] if raw2.ndim == 1 else raw2
        hi, lo, tol = clip_levels(raw2, subtype)
        raw_cols = [np.ascontiguousarray(raw2[:, c]) for c in range(raw2.shape[1])]
    taps = []
    for i, on in enumerate(onsets):
        nxt = onsets[i + 1] - pre if i + 1 < len(onsets) else x.size
        end = int(min(on + seg_n, nxt, x.size))
        seg = x[on:end]
        peak = float(np.max(np.abs(seg))) if seg.size else 0.0
        snr = 20 * np.log10(max(float(np.max(env[on:end])) if end > on else 0.0, 1e-300) / floor)
        clip_level = 0.0
        if raw is not None:
            s0 = max(on - pre, 0)
            for c, col in enumerate(raw_cols):
                if hi[c] > lo[c]:
                    clip_level = max(clip_level, _flat_top_level(col[s0:end], hi[c], lo[c], tol[c]))
        clipped = clip_level > 0
        dbl = is_double_hit(x, on, fs, double_hit_window_s) or louder_second_strike(x, on, fs, double_hit_window_s)
        taps.append(Tap(onset=on, time_s=on / fs, end=end, peak=peak, snr_db=float(snr),
                        clipped=clipped, double_hit=dbl, used=not (clipped or dbl), clip_level=clip_level))
    taps = [t if rings_down(envelope(x[t.onset:t.end], fs, 2e-3), 0, t.end - t.onset, fs)
            and ring_time(env, t.onset, fs) >= min_ring_s
            else replace(t, used=False, rejected="no ring-down") for t in taps]
    # "Faint" is measured against the loudest *tap*: a loud sound that is no tap (a held
    # tone, a clank) must not make the real taps faint.
    ringing = [t.peak for t in taps if not t.rejected]
    loudest = max(ringing) if ringing else 0.0
    taps = [replace(t, used=False, rejected="faint") if t.peak < loudest * 10 ** (-faint_db / 20) and not t.rejected
            else t for t in taps]
    if not any(t.used for t in taps):
        taps = [t if t.rejected else replace(t, used=True) for t in taps]
    return taps


def sound_without_tap(mono, sample_rate: float, taps: list[Tap], *, smooth_s: float = 10e-3,
                      threshold: float = 5.0, within_db: float = 12.0, min_s: float = 20e-3) -> list[float]:
    """Start times [s] of loud sounds in which no event begins: speech, music, a machine.

    A tap recording is quiet between its taps: every stretch where the sound stands out of
    the noise floor (a 10 ms envelope over ``threshold`` times its 10th percentile) begins with a
    tap's sharp onset and is its ring-down. Words, notes and a machine's bursts are
    stretches as loud as the taps (within ``within_db`` of the loudest used tap) that
    begin without one (they swell in); :func:`find_taps` finds at most the odd syllable
    that starts like a tap. Stretches shorter than ``min_s`` (a click) do not count. A
    ring whose beating modes cancel so deeply that it falls back into the noise and comes
    back within 12 dB of its start is the one tap sound that could look alike: it needs
    two modes matched within ~5 %, rare, and several such stretches.

    Parameters
    ----------
    mono : ndarray, shape (n,)
    sample_rate : float
        [Hz].
    taps : list of Tap
        Every event :func:`find_taps` returned (rejected ones included: they are reported
        on their own).
    """
    x = np.asarray(mono, dtype=np.float64)
    fs = float(sample_rate)
    used = [t for t in taps if t.used]
    # On 1 ms blocks: a 10 ms envelope needs no finer grid (and costs 1/50 of the time).
    blk = max(int(1e-3 * fs), 1)
    nb = x.size // blk
    if not used or nb < 2:
        return []
    n_avg = max(int(round(smooth_s / 1e-3)), 1)
    env = np.convolve(np.abs(x[:nb * blk]).reshape(nb, blk).mean(axis=1), np.ones(n_avg) / n_avg, "same")
    # The quiet between words or taps (10th percentile): the median of speech is speech.
    nz = env[env > 0]
    floor = float(np.percentile(nz, 10)) if nz.size else 0.0
    loudest = max(float(np.max(env[t.onset // blk:max(t.end // blk, t.onset // blk + 1)])) for t in used)
    loud = np.concatenate(([False], env > threshold * floor, [False]))
    edges = np.flatnonzero(np.diff(loud.astype(np.int8)))
    starts, stops = edges[0::2], edges[1::2]
    # An event's onset may lie up to one smoothing length before its stretch starts.
    onsets = np.array(sorted(t.onset // blk for t in taps))
    out = []
    for a, b in zip(starts, stops):
        if (b - a) * 1e-3 < min_s or float(np.max(env[a:b])) < loudest * 10 ** (-within_db / 20):
            continue
        k = np.searchsorted(onsets, a - n_avg)
        if k < onsets.size and onsets[k] < b:
            continue
        out.append(a * blk / fs)
    return out
