"""Chatter from the sound of a milling cut: the steady cut, the speed heard, forced vibration or chatter.

A milling cut at spindle speed n [rpm] with Z teeth is forced at the spindle frequency
f_sp = n/60 and, above all, at the tooth-passing frequency f_tp = Z f_sp: a stable cut
sounds only at their harmonics h f_sp (Smith & Tlusty 1990, "Update on high-speed milling
dynamics", J. Eng. Ind. 112). Regenerative chatter adds a component near a natural
frequency of the tool (or workpiece) that is *not* a harmonic, with its aliases
f_c + k f_tp (the cut modulates it at the tooth-passing rate; Insperger et al. 2003,
"Stability of up-milling and down-milling, part 1", IJMTM 43). A period-doubling (flip)
chatter sits at odd multiples of f_tp/2.

The steps, all on one recording:

1. The cut: the cutting is louder than idling or air-cutting, so frames well above the
   quiet level form the cut; its longest stretch, less its entry and exit, is the steady
   cut (or ``start_s``/``end_s`` given by the user). The quiet frames away from the cut
   are the idle part: tones present there as loud (fans, spindle bearings, mains hum) are
   not chatter.
2. Its power spectrum (Welch, Hann) and the background under the lines (a running median
   in dB); a line's prominence is its level above that background.
3. The speed heard: the comb of tooth-passing harmonics h·f_tp that stands out most,
   searched within ``speed_tolerance`` of the commanded speed and refined from the line
   positions (weighted by harmonic number). No such comb: bad input (no cut, or a wrong
   speed or tooth count).
4. Lines that are not spindle harmonics, idle tones or mains hum are chatter candidates;
   the strongest is the chatter frequency, its level is given in dB above the strongest
   tooth-passing harmonic, and the other members of its family f_c + k f_tp are listed.

Signatures::

    analyse_cut(recording, rpm, teeth, *, start_s=None, end_s=None, speed_tolerance=0.15) -> CutAnalysis
    smith_tlusty_speeds(chatter_hz, teeth, rpm, *, min_rpm, max_rpm, count=5) -> list[float]
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from taptune.errors import InputError
from taptune.signal.peaks import parabolic_peak

#: Verdicts of a cut.
VERDICTS = ("stable", "chatter", "unclear")
#: Frame length of the level envelope [s].
FRAME_S = 0.05
#: The cut's level must stand this far [dB] above the quiet frames to be told from them.
CUT_CONTRAST_DB = 6.0
#: Fraction of the cut's length dropped at each end (entry and exit of the tool).
TRIM_FRACTION = 0.12
#: Shortest steady cut analysed [s].
MIN_CUT_S = 0.4
#: Longest Welch segment [s] (finer bins than needed only cost averages).
MAX_SEGMENT_S = 1.0
#: Fewest Welch averages wanted (the spread of the noise floor falls with them).
MIN_AVERAGES = 8
#: Band analysed [Hz]: below, machine rumble; above, little a phone keeps.
F_LOW_HZ = 20.0
F_HIGH_HZ = 12000.0
#: A line stands this far [dB] above the background to count.
LINE_DB = 10.0
#: Tooth-passing harmonics scored when the speed is searched.
MAX_HARMONICS = 16
#: An idle tone as loud as the cut's line within this margin [dB] is that tone, not chatter.
IDLE_MARGIN_DB = 6.0
#: Verdict thresholds on the chatter level [dB above the strongest tooth-passing harmonic].
CHATTER_DB = -10.0
STABLE_DB = -20.0
#: Chatter also needs a clear line: this prominence [dB] over the background.
CHATTER_PROMINENCE_DB = 15.0
MAINS_HZ = (50.0, 60.0)
#: A candidate line that falls by more than this [dB] from the first to the last third of the
#: steady cut is a ring dying out (a stable cut near its limit), not a regenerative chatter.
DECAY_DB = 6.0
#: The chatter's next family members within this many dB of its strongest line may be the chatter itself.
FAMILY_DB = 10.0


@dataclass(frozen=True)
class CutAnalysis:
    """What the sound of one cut says (SI: Hz, s; levels in dB).

    Attributes
    ----------
    verdict : {"stable", "chatter", "unclear"}
    chatter_hz : float or None
        The strongest component off the spindle harmonics [Hz] (None when stable with
        no candidate).
    chatter_level_db : float or None
        Its level above the strongest tooth-passing harmonic [dB].
    family_hz, family_level_db : tuple of float
        The other lines of its family f_c + k f_tp found in the spectrum [Hz], strongest
        first, and their levels relative to the chatter line [dB].
    spindle_rpm : float
        The speed heard [rpm].
    commanded_rpm : float
    teeth : int
    tooth_passing_hz : float
        Z × the speed heard / 60 [Hz].
    forced_level_db : float
        Level of the strongest tooth-passing harmonic [dB re full scale²].
    harmonics_found : int
        Tooth-passing harmonics standing ≥ LINE_DB above the background.
    cut_s, idle_s : (float, float), float
        The steady cut analysed [s from the start]; seconds of idle used for the tones.
    freq_hz, level_db, background_db : ndarray
        The steady cut's spectrum [dB re full scale²] and its background.
    idle_db : ndarray or None
        The idle part's spectrum on the same grid.
    excluded_hz : tuple of float
        Lines set aside as idle tones or mains hum [Hz].
    warnings : tuple of str
    """

    verdict: str
    chatter_hz: float | None
    chatter_level_db: float | None
    family_hz: tuple
    family_level_db: tuple
    spindle_rpm: float
    commanded_rpm: float
    teeth: int
    tooth_passing_hz: float
    forced_level_db: float
    harmonics_found: int
    cut_s: tuple
    idle_s: float
    freq_hz: np.ndarray = field(repr=False)
    level_db: np.ndarray = field(repr=False)
    background_db: np.ndarray = field(repr=False)
    idle_db: np.ndarray | None = field(default=None, repr=False)
    excluded_hz: tuple = ()
    warnings: tuple = ()

    def to_dict(self) -> dict:
        """The verdict as JSON-ready numbers (Hz, rpm, dB, s)."""
        return {
            "verdict": self.verdict,
            "chatter_hz": self.chatter_hz,
            "chatter_level_db": self.chatter_level_db,
            "chatter_family_hz": list(self.family_hz),
            "chatter_family_level_db": list(self.family_level_db),
            "spindle_rpm": self.spindle_rpm,
            "commanded_rpm": self.commanded_rpm,
            "teeth": self.teeth,
            "tooth_passing_hz": self.tooth_passing_hz,
            "tooth_harmonics_found": self.harmonics_found,
            "cut_s": list(self.cut_s),
            "idle_s": self.idle_s,
            "excluded_hz": list(self.excluded_hz),
        }


# --------------------------------------------------------------------------- the cut in time


def frame_levels(mono, sample_rate: float, frame_s: float = FRAME_S) -> np.ndarray:
    """Level [dB] of consecutive frames of ``mono`` above 150 Hz (mains hum and rumble left out)."""
    from scipy.signal import butter, sosfiltfilt

    n = int(round(frame_s * sample_rate))
    sos = butter(4, 150.0, "highpass", fs=sample_rate, output="sos")
    y = sosfiltfilt(sos, mono) if len(mono) > 30 else mono
    m = len(y) // n
    if m == 0:
        return np.zeros(0)
    power = np.mean(y[: m * n].reshape(m, n) ** 2, axis=1)
    return 10 * np.log10(power + 1e-30)


def find_cut(levels, frame_s: float = FRAME_S) -> tuple[tuple[int, int], np.ndarray, bool]:
    """The steady cut as a frame range [i0, i1), a mask of idle frames, and whether the cut stood out.

    Frames above the midpoint between the quiet (10th percentile) and loud (95th) levels,
    or 10 dB above the quiet level if that is lower (6 dB if that leaves too short a cut),
    are cutting; gaps of up to 0.15 s are closed (a chip, an interrupted tooth). The
    longest run less :data:`TRIM_FRACTION` at each end is the steady cut. Frames below a
    quarter of the way up, at least 0.25 s away from the cut, are idle. Without that
    contrast the whole recording is taken as cut (trimmed the same way) and nothing is idle.
    """
    n = len(levels)
    lo, hi = np.percentile(levels, 10), np.percentile(levels, 95)
    if hi - lo < CUT_CONTRAST_DB:
        trim = int(TRIM_FRACTION / 2 * n)
        return (trim, n - trim), np.zeros(n, bool), False
    gap = int(round(0.15 / frame_s))
    # At most 10 dB above the quiet level: a chatter that grows late in the cut is much
    # louder than its stable start, which is still cutting; if the loud part is still too
    # short to analyse, 6 dB.
    for rise in (min(0.5 * (hi - lo), 10.0), CUT_CONTRAST_DB):
        loud = levels > lo + rise
        idx = np.flatnonzero(loud)
        for a, b in zip(idx[:-1], idx[1:]):  # close short gaps (a chip, an interrupted tooth)
            if 1 < b - a <= gap + 1:
                loud[a:b] = True
        edges = np.diff(np.concatenate([[0], loud.astype(int), [0]]))
        starts, ends = np.flatnonzero(edges == 1), np.flatnonzero(edges == -1)
        j = int(np.argmax(ends - starts))
        if (ends[j] - starts[j]) * (1 - 2 * TRIM_FRACTION) * frame_s >= MIN_CUT_S:
            break
    s, e = int(starts[j]), int(ends[j])
    trim = int(round(TRIM_FRACTION * (e - s)))
    quiet = levels < lo + 0.25 * (hi - lo)
    margin = int(round(0.25 / frame_s))
    away = np.ones(n, bool)
    for a, b in zip(starts, ends):
        away[max(a - margin, 0):b + margin] = False
    return (s + trim, e - trim), quiet & away, True


# --------------------------------------------------------------------------- spectra


def _welch(x, sample_rate: float, nperseg: int):
    from scipy.signal import welch

    f, p = welch(x, sample_rate, window="hann", nperseg=nperseg, noverlap=nperseg // 2, detrend="constant",
                 scaling="spectrum")
    return f, p


def _segments(mono, sample_rate: float, mask, frame_n: int) -> list[np.ndarray]:
    """The runs of samples whose frames are set in ``mask``."""
    edges = np.diff(np.concatenate([[0], mask.astype(int), [0]]))
    return [mono[a * frame_n:b * frame_n] for a, b in zip(np.flatnonzero(edges == 1), np.flatnonzero(edges == -1))]


def _background(level_db, bins: int) -> np.ndarray:
    from scipy.ndimage import median_filter

    return median_filter(level_db, size=bins | 1, mode="nearest")


def _peak_value(f, y, i):
    """Parabolic interpolation of the maximum at bin i: (frequency, value)."""
    if 0 < i < len(y) - 1:
        d, value = parabolic_peak(y, i)
        return float(f[i] + d * (f[1] - f[0])), float(value)
    return float(f[i]), float(y[i])


def _near_max(f, y, targets, tol_hz):
    """Per target frequency, (index, value) of the largest ``y`` within ±tol_hz (the nearest bin if none)."""
    df = f[1] - f[0]
    w = max(int(np.ceil(tol_hz / df)), 1)
    c = np.clip(np.round((np.asarray(targets) - f[0]) / df).astype(int), 0, len(f) - 1)
    offs = np.arange(-w, w + 1)
    idx = np.clip(c[:, None] + offs[None, :], 0, len(f) - 1)
    j = np.argmax(y[idx], axis=1)
    best = idx[np.arange(len(c)), j]
    return best, y[best]


# --------------------------------------------------------------------------- the speed heard


def _line_list(f, level_db, excess):
    """The lines of a spectrum: interpolated frequencies [Hz] (ascending) and their excess [dB]."""
    line = (excess >= LINE_DB - 4) & (level_db >= np.r_[level_db[1:], -np.inf]) & (level_db > np.r_[-np.inf, level_db[:-1]])
    i = np.flatnonzero(line)
    freq = np.array([_peak_value(f, level_db, j)[0] for j in i])
    return freq, excess[i]


def _comb_scores(lines, df: float, cand, h, anchors=()):
    """Score of each candidate tooth-passing frequency ``cand`` [Hz]: the lines that lie on its
    harmonics h·f_tp, plus those spaced by it around each anchor line (the chatter's family
    f_c + k f_tp). A line counts only within 0.4 bin of where the comb puts it: a comb a
    little off the true one may meet a few lines of the chatter's family (itself a comb
    of the same spacing, shifted) but not the harmonics' exact positions."""
    freq, ex = lines
    if len(freq) == 0:
        return np.zeros(len(cand))
    weight = np.clip(ex - 6.0, 0.0, 24.0)

    def at(targets):
        j = np.clip(np.searchsorted(freq, targets), 1, len(freq) - 1)
        near = np.where(np.abs(freq[j] - targets) < np.abs(freq[j - 1] - targets), j, j - 1)
        return np.where(np.abs(freq[near] - targets) <= 0.4 * df, weight[near], 0.0)

    score = at(cand[:, None] * h[None, :]).sum(axis=1)
    k = np.array([-3, -2, -1, 1, 2, 3])
    family = np.zeros(len(cand))
    for c in anchors:
        family = np.maximum(family, at(c + cand[:, None] * k[None, :]).sum(axis=1))
    return score + family


def _speed_heard(f, excess, level_db, lines, tp0: float, f_top: float, tolerance: float, anchors=()):
    """(f_tp [Hz], harmonic numbers, their excess [dB]) of the best tooth-passing comb within ``tolerance`` of ``tp0``.

    The comb is scored on the tooth-passing harmonics and on the spacing of the chatter's
    family around the ``anchors`` (the strongest lines), so that a chatter that drowns
    the forced lines still gives the speed; refined from the positions of the harmonics
    (or of the family) that stand out.
    """
    df = f[1] - f[0]
    h_max = int(max(1, min(MAX_HARMONICS, f_top // (tp0 * (1 + tolerance)))))
    h = np.arange(1, h_max + 1)
    step = df / (2 * h_max)
    cand = np.arange(tp0 * (1 - tolerance), tp0 * (1 + tolerance) + step, step)
    # A small preference for the commanded speed breaks ties between equal combs.
    score = _comb_scores(lines, df, cand, h, anchors) - 0.5 * np.abs(cand / tp0 - 1) / tolerance
    tp = float(cand[np.argmax(score)])
    idx, ex = _near_max(f, excess, tp * h, 1.5 * df)
    good = ex >= LINE_DB
    if good.sum() >= 2:
        est = np.array([_peak_value(f, level_db, i)[0] for i in idx[good]]) / h[good]
        w = h[good].astype(float)
        refined = float(np.sum(w * w * est) / np.sum(w * w))
        if abs(refined / tp - 1) < 2 * df / (tp * h[good].max()) + 1e-3:
            tp = refined
    idx, ex = _near_max(f, excess, tp * h, 1.5 * df)
    return tp, h, ex


def _family_lines(f, excess, anchors, tp: float, teeth: int) -> int:
    """Most lines standing out at c ± k f_tp (k = 1…3) around one of the ``anchors`` that is
    off the spindle harmonics (a chatter's family; lines on the harmonics are forced)."""
    df = f[1] - f[0]
    f_sp = tp / teeth
    best = 0
    for c in anchors:
        if abs(c - round(c / f_sp) * f_sp) <= 1.5 * df:
            continue
        k = np.array([-3, -2, -1, 1, 2, 3])
        x = c + k * tp
        x = x[(x > f[0]) & (x < f[-1])]
        if len(x):
            _, e = _near_max(f, excess, x, 1.5 * df)
            best = max(best, int(np.sum(e >= LINE_DB)))
    return best


def _elsewhere(lines, df: float, tp: float, tp0: float, f_top: float, tolerance: float) -> float | None:
    """A tooth-passing comb [Hz] outside ``tolerance`` of ``tp0`` (0.2–5 ×) whose first harmonics
    (up to 6) all but one stand out, and that is neither a multiple nor a sub-multiple of
    ``tp``; the one whose harmonics stand out most. None if none."""
    freq, ex = lines
    if len(freq) < 3:
        return None
    cand = np.exp(np.arange(np.log(max(0.2 * tp0, 20.0)), np.log(min(5 * tp0, f_top / 3)), df / (12 * tp0)))
    cand = cand[np.abs(cand / tp0 - 1) > tolerance]
    ratio = np.maximum(cand / tp, tp / cand)
    cand = cand[np.abs(ratio - np.round(ratio)) > 0.02]
    if len(cand) == 0:
        return None
    h = np.arange(1, 7)
    targets = cand[:, None] * h[None, :]
    inside = targets < f_top
    j = np.clip(np.searchsorted(freq, targets), 1, len(freq) - 1)
    near = np.where(np.abs(freq[j] - targets) < np.abs(freq[j - 1] - targets), j, j - 1)
    e = np.where((np.abs(freq[near] - targets) <= 0.6 * df + 1e-3 * targets) & inside & (ex[near] >= LINE_DB),
                 np.clip(ex[near], 0, 30), 0.0)
    n = inside.sum(axis=1)
    ok = ((e > 0).sum(axis=1) >= n - 1) & (n >= 4)
    if not ok.any():
        return None
    mean = e.sum(axis=1) / np.maximum(n, 1)
    i = np.flatnonzero(ok)[np.argmax(mean[ok])]
    hit = e[i] > 0
    return float(np.sum(freq[near[i]][hit]) / np.sum(h[hit]))  # the lines' positions, weighted by harmonic


def _comb_problem(f, excess, tp: float, teeth: int, ex) -> str | None:
    """Why the comb found cannot be this cut's tooth passing, or None: only every m-th of
    its harmonics stands out (the sound's tooth passing is m times higher: more teeth, or
    a higher speed, than given)."""
    e = np.clip(ex, 0.0, 30.0)
    for m in range(2, 7):
        n = min(len(e), 3 * m)
        if n < 2 * m:
            break
        h = np.arange(1, n + 1)
        on, off = e[:n][h % m == 0], e[:n][h % m != 0]
        if on.mean() >= LINE_DB and off.mean() < on.mean() - 10.0:
            nth = {2: "2nd", 3: "3rd"}.get(m, f"{m}th")
            return f"only every {nth} harmonic of the tooth-passing frequency sounds (the sound's is {m}× higher)"
    return None


def _idle_like(f, excess, tp: float, teeth: int, ex, f_top: float, margin_db: float) -> bool:
    """The tooth-passing harmonics stand no more than ``margin_db`` above the other spindle
    harmonics: a spindle turning without a tooth cutting (idle, air-cutting), or fewer
    teeth than given."""
    if teeth <= 1:
        return False
    df = f[1] - f[0]
    f_sp = tp / teeth
    k = np.arange(1, int(min(4 * teeth, f_top // f_sp)) + 1)
    k = k[k % teeth != 0]
    if teeth % 2 == 0:
        k = k[k % (teeth // 2) != 0]  # odd multiples of f_tp/2: a flip chatter sounds there
    if not len(k):
        return False
    _, other = _near_max(f, excess, k * f_sp, 1.5 * df)
    return bool(np.clip(ex[: min(len(ex), 4)], 0, 30).mean() < np.clip(other, 0.0, 30.0).mean() + margin_db)


def _half_comb(f, excess, level, tp: float, f_top: float) -> tuple[bool, bool]:
    """(the lines sit on the odd multiples of f_tp/2 like a forced series, and clearly so).

    A tooth count or a speed given twice too high puts the sound's odd tooth-passing
    harmonics on the odd multiples of the given f_tp/2, where a period-doubling chatter
    sounds too. A forced series is strongest at its fundamental and goes on; a flip
    chatter is strongest near its mode and its family f_c ± k f_tp fades within a few
    members. A series: the first three members stand out and the first is the strongest of
    the four (within 3 dB); clearly so when the fourth (3.5 f_tp) stands out too. Not asked
    for two teeth or fewer: the odd multiples of f_tp/2 are then the spindle's own
    (run-out) harmonics.
    """
    df = f[1] - f[0]
    targets = (np.arange(4) + 0.5) * tp
    if targets[2] >= f_top:
        return False, False
    targets = targets[targets < f_top]
    _, ex = _near_max(f, excess, targets, 1.5 * df)
    _, lv = _near_max(f, level, targets, 1.5 * df)
    series = bool(np.all(ex[:3] >= LINE_DB) and lv[0] >= lv.max() - 3.0)
    return series, series and len(ex) == 4 and bool(ex[3] >= LINE_DB)


def _line_trend(cut, sample_rate: float, hz: float, parts: int = 3) -> float:
    """Level change [dB] of the line at ``hz`` from the first to the last of ``parts`` equal parts of ``cut``."""
    n = len(cut) // parts
    if n < 64:
        return 0.0
    w = np.hanning(n)
    ff = np.fft.rfftfreq(n, 1.0 / sample_rate)
    near = np.abs(ff - hz) <= max(2.5 * sample_rate / n, 1.0)
    lv = [10 * np.log10(np.max(np.abs(np.fft.rfft(cut[i * n:(i + 1) * n] * w))[near] ** 2) + 1e-30)
          for i in (0, parts - 1)]
    return float(lv[1] - lv[0])


# --------------------------------------------------------------------------- analysis


def analyse_cut(recording, rpm: float, teeth: int, *, start_s: float | None = None, end_s: float | None = None,
                speed_tolerance: float = 0.15) -> CutAnalysis:
    """The verdict on one recorded cut: stable, chatter or unclear, with the chatter frequency and the speed heard.

    Parameters
    ----------
    recording : taptune.io.audio.Recording
    rpm : float
        Commanded spindle speed [rpm].
    teeth : int
        Number of teeth Z.
    start_s, end_s : float, optional
        The steady cut [s from the start]; found from the level when not given.
    speed_tolerance : float
        How far the speed heard may lie from the commanded one (fraction; an override).

    Returns
    -------
    CutAnalysis

    Raises
    ------
    InputError
        No cut in the recording, or no tooth-passing harmonics near the commanded speed
        (a wrong speed or tooth count), or a cut too short to analyse.
    """
    name = recording.path or "the recording"
    if not (np.isfinite(rpm) and rpm > 0):
        raise InputError(f"--rpm must be > 0, got {rpm:g}")
    if not (int(teeth) == teeth and teeth >= 1):
        raise InputError(f"--teeth must be a whole number >= 1, got {teeth!r}")
    fs = float(recording.sample_rate)
    mono = np.asarray(recording.samples, dtype=float)
    mono = mono.mean(axis=1) if mono.ndim == 2 else mono
    mono = mono - np.mean(mono)
    duration = len(mono) / fs
    levels = frame_levels(mono, fs)
    frame_n = int(round(FRAME_S * fs))
    warnings = []
    if start_s is not None or end_s is not None:
        a = 0.0 if start_s is None else float(start_s)
        b = duration if end_s is None else float(end_s)
        if not (0 <= a < b <= duration + 1e-9):
            raise InputError(f"{name}: --from/--to must satisfy 0 <= from < to <= {duration:.2f} s, got {a:g}…{b:g}")
        i0, i1 = int(a / FRAME_S), int(np.ceil(b / FRAME_S))
        idle = np.zeros(len(levels), bool)
        margin = int(round(0.25 / FRAME_S))
        idle[: max(i0 - margin, 0)] = True
        idle[min(i1 + margin, len(levels)):] = True
        quiet = levels < np.percentile(levels[i0:i1], 10) - CUT_CONTRAST_DB if i1 > i0 else idle
        idle &= quiet
        contrast = True
    else:
        if len(levels) < 3:
            raise InputError(f"{name}: {duration:.2f} s is too short for a cut (record at least 2 s of steady cutting)")
        (i0, i1), idle, contrast = find_cut(levels)
    i1 = min(i1, len(levels))
    if (i1 - i0) * FRAME_S < MIN_CUT_S:
        raise InputError(f"{name}: the steady cut lasts only {(i1 - i0) * FRAME_S:.2f} s; record at least 2 s "
                         f"of steady cutting (or give --from/--to around it)")
    cut = mono[i0 * frame_n:i1 * frame_n]
    nper = int(min(MAX_SEGMENT_S * fs, max(0.25 * fs, 2 * len(cut) / (MIN_AVERAGES + 1))))
    nper = min(nper, len(cut))
    f, p = _welch(cut, fs, nper)
    band = (f >= F_LOW_HZ) & (f <= min(F_HIGH_HZ, 0.45 * fs))
    f, p = f[band], p[band]
    level = 10 * np.log10(p + 1e-30)
    df = f[1] - f[0]
    bg = _background(level, max(int(round(40.0 / df)), 15))
    excess = level - bg
    if np.max(level) < -100:
        raise InputError(f"{name}: silent (no cut in it)")

    idle_db, idle_s = None, 0.0
    runs = [r for r in _segments(mono, fs, idle, frame_n) if len(r) >= nper]
    if runs:
        spectra = [_welch(r, fs, nper)[1][band] for r in runs]
        weights = np.array([len(r) for r in runs], float)
        idle_db = 10 * np.log10(np.average(spectra, axis=0, weights=weights) + 1e-30)
        idle_s = float(weights.sum() / fs)

    tp0 = rpm * teeth / 60.0
    f_top = float(f[-1])
    if tp0 * (1 - speed_tolerance) > f_top / 2:
        raise InputError(f"--rpm {rpm:g} with --teeth {teeth}: the tooth-passing frequency {tp0:.0f} Hz lies "
                         f"above what {name} can show ({f_top:.0f} Hz)")
    # The lines of the cut; the strongest anchor the chatter's family (its spacing is the tooth passing too).
    is_peak = (excess >= LINE_DB) & (level >= np.r_[level[1:], -np.inf]) & (level > np.r_[-np.inf, level[:-1]])
    peaks = np.flatnonzero(is_peak)
    anchors = f[peaks[np.argsort(-level[peaks])][:3]] if len(peaks) else np.zeros(0)
    # The harmonics alone first; a chatter that drowns them still gives the speed by its family's spacing.
    lines = _line_list(f, level, excess)
    tp, h, ex = _speed_heard(f, excess, level, lines, tp0, f_top, speed_tolerance)
    if np.sum(ex[:6] >= LINE_DB) < 2:
        tp, h, ex = _speed_heard(f, excess, level, lines, tp0, f_top, speed_tolerance, anchors)
    found = int(np.sum(ex >= LINE_DB))
    fam = _family_lines(f, excess, anchors, tp, teeth)
    where = (f"near {tp0:.1f} Hz = {teeth} teeth × {rpm:g} rpm / 60 (±{100 * speed_tolerance:g} %); "
             "check --rpm and --teeth, and that the recording holds the cut")
    n_in = int(np.sum(tp * h[:6] < f_top))
    weak = np.sum(ex[:6] >= LINE_DB) < min(4, n_in - 1) and fam < 2
    other = _elsewhere(lines, df, tp, tp0, f_top, speed_tolerance) if weak else None
    if other is not None:
        raise InputError(f"{name}: the sound's tooth passing is at {other:.1f} Hz ({60 * other / teeth:.0f} rpm with "
                         f"{teeth} teeth), not {where}")
    if np.sum(ex[:6] >= LINE_DB) + fam < 2:
        if not contrast:
            raise InputError(f"{name}: no cut in it (no tooth-passing harmonics, no louder cutting part) {where}")
        # A cut louder than the idle whose forces barely vary (slotting with many teeth): no
        # line to hear the speed by; take the commanded one.
        tp = tp0
        warnings.append(f"{name}: no tooth-passing line heard (a cut with an even force, e.g. slotting with "
                        f"{teeth} teeth); the speed is taken as commanded")
        h = np.arange(1, len(h) + 1)
        _, ex = _near_max(f, excess, tp * h, 1.5 * df)
    else:
        problem = _comb_problem(f, excess, tp, teeth, ex)
        if problem:
            raise InputError(f"{name}: {problem} {where}")
        series, clearly = _half_comb(f, excess, level, tp, f_top) if teeth >= 3 else (False, False)
        if series:
            likely = (f"{teeth // 2} teeth at {rpm:g} rpm, or " if teeth % 2 == 0 else "") + \
                f"{teeth} teeth at {rpm / 2:g} rpm"
            what = (f"the lines sit on every multiple of {tp / 2:.1f} Hz, half the tooth passing of --rpm {rpm:g} "
                    f"with --teeth {teeth}: likely {likely}")
            if clearly:
                raise InputError(f"{name}: {what}; check --rpm and --teeth")
            warnings.append(f"{name}: {what} (else a period-doubling chatter); check --rpm and --teeth")
        # Without a louder cutting part the tooth-passing lines must stand out clearly from the
        # spindle's others; with one, they must at least not be weaker (run-out can be strong).
        if fam < 2 and _idle_like(f, excess, tp, teeth, ex, f_top, 0.0 if contrast else 6.0):
            what = "fewer teeth than given cut, or " if contrast else ""
            raise InputError(f"{name}: the tooth-passing harmonics stand no higher than the other spindle harmonics "
                             f"({what}the spindle turns and no tooth cuts) {where}")
    f_sp = tp / teeth
    tol = max(1.5 * df, 2e-3 * f_sp)

    # What each line is.
    pf = np.array([_peak_value(f, level, i)[0] for i in peaks])
    pl = np.array([_peak_value(f, level, i)[1] for i in peaks])
    _, tooth_lv = _near_max(f, level, tp * h, tol)
    tooth_ok = ex >= LINE_DB
    forced = float(np.max(np.where(tooth_ok, tooth_lv, -np.inf))) if tooth_ok.any() else float(np.max(tooth_lv))
    # Spindle harmonics (tooth passing among them) are forced; with an even tooth count the
    # odd multiples of f_tp/2 are spindle harmonics too, but they are where a flip chatter
    # sounds, so they stay candidates unless the idle part has them.
    r_sp = pf / f_sp
    on_spindle = np.abs(pf - np.round(r_sp) * f_sp) <= tol
    half = np.round(2 * pf / tp)
    on_half = (np.abs(pf - half * tp / 2) <= tol) & (half % 2 == 1)
    forced_line = on_spindle & ~on_half
    excluded = np.zeros(len(pf), bool)
    if idle_db is not None and len(pf):
        _, idle_lv = _near_max(f, idle_db, pf, tol)
        excluded |= idle_lv >= pl - IDLE_MARGIN_DB
    for fm in MAINS_HZ:
        fund = fm * np.arange(1, 4)
        _, hum = _near_max(f, excess, fund, max(tol, 0.5))
        if np.max(hum) >= LINE_DB:
            _, hum_lv = _near_max(f, level, fund, max(tol, 0.5))
            on_mains = np.abs(pf - np.round(pf / fm) * fm) <= max(tol, 0.5)
            excluded |= on_mains & (pl <= np.max(hum_lv) + 3.0)
    cand = ~forced_line & ~excluded

    chatter_hz = level_db = None
    family, family_db = (), ()
    verdict = "stable"
    if cand.any():
        j = np.flatnonzero(cand)[np.argmax(pl[cand])]
        # The tooth passing aliases the chatter into f_c + k f_tp, and sound weighs the higher
        # members up (it follows the surfaces' velocity, not their displacement): of the
        # strongest line and its next members (k = ±1) within FAMILY_DB of it, the one
        # strongest in displacement (level − 20 log10 f) is the chatter.
        k = np.round((pf - pf[j]) / tp)
        near = cand & (np.abs(k) <= 1) & (np.abs(pf - pf[j] - k * tp) <= tol) & (pl >= pl[j] - FAMILY_DB)
        i = np.flatnonzero(near)
        strongest, j = j, int(i[np.argmax(pl[i] - 20 * np.log10(pf[i]))])
        chatter_hz = float(pf[j])
        # The verdict and the level go by the loudest line of the chatter.
        level_db = float(pl[strongest] - forced)
        prominence = float(excess[peaks[strongest]])
        k = np.round((pf - chatter_hz) / tp)
        members = cand & (k != 0) & (np.abs(pf - chatter_hz - k * tp) <= tol) & (pl >= pl[j] - 30)
        order = np.flatnonzero(members)[np.argsort(-pl[members])]
        family = tuple(float(pf[i]) for i in order)
        family_db = tuple(float(pl[i] - pl[j]) for i in order)
        # A regenerative chatter holds or grows over the cut; a ring that dies out is a stable cut's.
        dying = _line_trend(cut, fs, float(pf[strongest])) < -DECAY_DB
        if dying:
            warnings.append(f"the line at {pf[strongest]:.0f} Hz dies out over the cut: a stable cut ringing, "
                            "not chatter")
            verdict = "unclear" if level_db >= 0.0 else "stable"
        elif level_db >= CHATTER_DB and prominence >= CHATTER_PROMINENCE_DB:
            verdict = "chatter"
        elif level_db >= STABLE_DB or (len(family) >= 2 and level_db >= STABLE_DB - 10):
            verdict = "unclear"
    excluded_hz = tuple(float(x) for x in pf[excluded])
    if abs(tp / tp0 - 1) > 0.02:
        warnings.append(f"the spindle turns at {60 * f_sp:.0f} rpm, {100 * (tp / tp0 - 1):+.1f} % off the commanded "
                        f"{rpm:g} rpm (an override?)")
    if not contrast and start_s is None and end_s is None:
        warnings.append(f"{name}: no quieter idle part found; the whole recording is taken as the cut, and "
                        "steady tones of the machine cannot be told from chatter by their presence at idle")
    if recording.lossy:
        warnings.append(f"{name}: lossy {recording.codec} recording; weak lines may be lost by the codec")
    return CutAnalysis(
        verdict=verdict, chatter_hz=chatter_hz, chatter_level_db=level_db, family_hz=family, family_level_db=family_db,
        spindle_rpm=60 * f_sp, commanded_rpm=float(rpm), teeth=int(teeth), tooth_passing_hz=tp,
        forced_level_db=forced, harmonics_found=found, cut_s=(i0 * FRAME_S, i1 * FRAME_S), idle_s=idle_s,
        freq_hz=f, level_db=level, background_db=bg, idle_db=idle_db, excluded_hz=excluded_hz,
        warnings=tuple(warnings))


# --------------------------------------------------------------------------- the next speed by rule


def smith_tlusty_speeds(chatter_hz: float, teeth: int, rpm: float, *, min_rpm: float = 0.0,
                        max_rpm: float | None = None, count: int = 5) -> list[float]:
    """Speeds [rpm] that put the tooth-passing frequency or a sub-multiple on the chatter frequency.

    n_j = 60 f_c / (Z j), j = 1, 2, … (Smith & Tlusty 1990): at these speeds successive
    waves on the surface are in phase and the regeneration stops. Within
    [``min_rpm``, ``max_rpm``] (no upper limit when None, then at most twice ``rpm``),
    nearest to the current speed ``rpm`` first, at most ``count``.
    """
    if isinstance(teeth, bool) or int(teeth) != teeth or teeth < 1:
        raise InputError(f"the number of teeth must be a whole number >= 1, got {teeth!r}")
    if not (np.isfinite(rpm) and rpm > 0 and np.isfinite(chatter_hz) and chatter_hz > 0):
        raise InputError(f"the spindle speed and the chatter frequency must be > 0, got {rpm!r} rpm, {chatter_hz!r} Hz")
    top = 2.0 * rpm if max_rpm is None else max_rpm
    j_min = max(1, int(np.ceil(60 * chatter_hz / (teeth * top) - 1e-9)))
    out = []
    j = j_min
    while True:
        n = 60 * chatter_hz / (teeth * j)
        if n < min_rpm or n < 0.2 * rpm or j > j_min + 200:
            break
        if n <= top:
            out.append(float(n))
        j += 1
    out.sort(key=lambda n: abs(n - rpm))
    return out[:count]
