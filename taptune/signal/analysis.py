"""From a recording to labeled peaks: the one call the front ends use.

``analyse_recording`` = mono mix → taps → per-tap spectra and their average → noise
spectrum between taps → peak picking → pole-fit refinement → labels. Model guidance
(``expected_hz``, ``bounds_hz``) comes from the caller as plain arrays: this layer never
imports the model.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass, field, replace

import numpy as np

from taptune.errors import InputError
from taptune.io.audio import RECOMMENDED_SAMPLE_RATE, Recording
from taptune.signal.bandwidth import effective_bandwidth, hidden_modes
from taptune.signal.labels import (NOTE_STATIONARY, LabelOptions, faint_windows, guided_windows, interface_bands,
                                   interface_growth, label_peaks)
from taptune.signal.peaks import (FIT_STARTS_S, Peak, harmonic_fundamental, leakage_lobes, pick_faint_peaks,
                                  pick_peaks, refine_peaks, tap_scatter)
from taptune.signal.spectrum import (fade_out, fft_length, noise_segments, smooth_floor, spectra,
                                     tap_segments, window_leakage_db)
from taptune.signal.taps import NEAR_FULL_SCALE, Tap, find_taps, full_scale_runs, sound_without_tap, to_mono


@dataclass(frozen=True)
class SpectrumOptions:
    """Every threshold of the analysis (what they guard against: docs/tap-test.md).

    Times in s, frequencies in Hz, levels in dB.
    """

    tap_smooth_s: float = 0.5e-3
    #: Onset threshold over the median envelope. 5x: a 0.5 ms envelope of Gaussian noise
    #: stays below ~1.7x its median, and taps at 20 dB SNR still clear it.
    tap_threshold: float = 5.0
    #: Knocks by hand come 0.14-0.3 s apart (see ``taps.find_taps``).
    min_tap_interval_s: float = 0.1
    #: An event this far below the loudest tap is no tap (a thump, a click, a codec's
    #: pre-echo): taps by hand vary by up to ~20 dB (see ``taps.find_taps``).
    faint_event_db: float = 24.0
    pre_onset_s: float = 2e-3
    segment_s: float = 0.25
    fade_fraction: float = 0.1
    max_bin_hz: float = 1.0
    double_hit_window_s: tuple[float, float] = (2e-3, 30e-3)
    prominence_db: float = 6.0
    #: A peak must stand this far above the noise floor (15 dB: a single tap's noise
    #: spectrum exceeds its median by 15 dB in ~1e-10 of the bins).
    min_snr_db: float = 15.0
    #: ... and this far above the median of its surroundings (see ``pick_peaks``).
    min_local_db: float = 12.0
    fmin_hz: float = 100.0
    fmax_hz: float | None = None
    max_peaks: int = 40
    #: Peaks less than this above the noise spectrum between taps are stationary.
    stationary_margin_db: float = 6.0
    fit_starts_s: tuple[float, ...] = FIT_STARTS_S
    target_rel_std: float = 1e-4
    fit_width_factor: float = 3.0
    grow_threshold_db: float = 10.0
    low_snr_db: float = 20.0
    band_table: str | None = None
    #: Guided search for faint bending modes the picking missed (model guidance only,
    #: :func:`~taptune.signal.peaks.pick_faint_peaks`): a local maximum this far over the
    #: robust local floor (8 dB: the 99.97 % point of an average of 3 Rayleigh-noise
    #: taps) ...
    faint_min_db: float = 8.0
    #: ... standing this far, and this fraction of the average's height, over its own
    #: floor in every tap (a mode rings in every tap alike; taps differ by ~3 dB) ...
    faint_tap_db: float = 3.0
    faint_tap_fraction: float = 0.5
    #: ... and resonance-shaped: F ratio of a one-mode fit over a flat floor.
    faint_f_ratio: float = 8.0
    #: Prominence of a faint candidate: noise ripple splits the top of a peak only 8 dB
    #: high by dips of a few dB (the maxima of one peak are then merged).
    faint_prominence_db: float = 3.0
    #: Flank width of the local floor [Hz].
    faint_ring_hz: float = 250.0
    faint_search: bool = True
    labels: LabelOptions = field(default_factory=LabelOptions)


@dataclass(frozen=True)
class SpectrumAnalysis:
    """Result of :func:`analyse_recording`.

    Attributes
    ----------
    file : str
    sample_rate : int
        [Hz].
    channels : int
    duration_s : float
    freq_hz : ndarray, shape (m,)
        Uniform grid [Hz] (bin spacing ≤ 1 Hz).
    magnitude : ndarray, shape (m,)
        Averaged linear magnitude |S| of the used taps (DFT sum, full scale 1).
    tap_magnitudes : ndarray, shape (k, m)
        Per used tap.
    noise_magnitude : ndarray, shape (m,) or None
        Averaged magnitude of segments without a tap (same length and fade).
    taps : list of Tap
        All detected taps (``used`` tells which entered the average).
    peaks : list of Peak
        Ascending in frequency, labeled.
    excluded_bands_hz : list of (lo, hi)
        Interface bands used for ``local`` labels.
    interface : str or None
    warnings : list of str
    bandwidth_hz : float or None
        Highest frequency the recording carries [Hz]: a codec's low-pass, else Nyquist
        (:func:`~taptune.signal.bandwidth.effective_bandwidth`).
    """

    file: str
    sample_rate: int
    channels: int
    duration_s: float
    freq_hz: np.ndarray
    magnitude: np.ndarray
    tap_magnitudes: np.ndarray
    noise_magnitude: np.ndarray | None
    taps: list[Tap]
    peaks: list[Peak]
    excluded_bands_hz: list[tuple[float, float]]
    interface: str | None
    warnings: list[str]
    bandwidth_hz: float | None = None

    @property
    def n_taps(self) -> int:
        """Taps in the average."""
        return sum(t.used for t in self.taps)

    @property
    def bending_peaks(self) -> list[Peak]:
        """Bending peaks in mode order."""
        return sorted((p for p in self.peaks if p.kind == "bending"), key=lambda p: p.mode)

    @property
    def bending_hz(self) -> list[float]:
        """Bending frequencies [Hz], ascending (modes found)."""
        return [p.hz for p in self.bending_peaks]

    def bending_by_mode(self) -> dict[int, float]:
        """{mode: frequency [Hz]} of the bending peaks found."""
        return {p.mode: p.hz for p in self.bending_peaks}

    def to_dict(self) -> dict:
        """JSON-ready dict (docs/cli.md keys first, then extras)."""
        return {
            "file": self.file,
            "sample_rate": int(self.sample_rate),
            "channels": int(self.channels),
            "taps": int(self.n_taps),
            "peaks": [p.to_dict() for p in self.peaks],
            "warnings": list(self.warnings),
            "bending_hz": [round(f, 4) for f in self.bending_hz],
            "bending_modes": [p.mode for p in self.bending_peaks],
            "excluded_bands_hz": [list(b) for b in self.excluded_bands_hz],
            "interface": self.interface,
            "duration_s": round(self.duration_s, 6),
            "tap_details": [t.to_dict() for t in self.taps],
            "bandwidth_hz": None if self.bandwidth_hz is None else round(float(self.bandwidth_hz), 1),
        }


def _fit_spectra_factory(mono, fs, taps, seg_n):
    """Cached ``start_s -> (freq, spec, oversample)`` for the pole fits.

    The fit models the exact DFT of a decaying sinusoid, so it needs no fine grid:
    a 25 % zero-padding keeps enough bins across the narrowest band and the FFTs cheap.
    """
    n_fft = fft_length(int(1.25 * seg_n), fs, max_bin_hz=np.inf)

    @functools.lru_cache(maxsize=None)
    def fit_spectra(start_s):
        shift = int(round(start_s * fs))
        n = max(seg_n - shift, 8)
        segs = tap_segments(mono, fs, taps, start_s, n, fade_fraction=0.0)
        f, spec = spectra(segs, fs, n_fft)
        return f, spec, n_fft / n

    return fit_spectra


def _peak_spectra(rec: Recording, o: SpectrumOptions):
    """Taps, averaged spectrum, per-tap spectra, noise spectrum and floor of a recording."""
    fs = rec.sample_rate
    name = rec.name
    x_raw = rec.samples
    if float(np.max(np.abs(x_raw))) == 0.0:
        raise InputError(f"{name}: the recording is silent (all samples are zero)")
    min_len = o.pre_onset_s + 0.02
    if rec.duration_s < min_len:
        raise InputError(f"{name}: {rec.duration_s * 1000:.1f} ms is shorter than one tap "
                         f"(need at least {min_len * 1000:.0f} ms)" + _read_notes(rec))
    mono = to_mono(x_raw, fs, o.tap_smooth_s)
    events = find_taps(mono, fs, raw=x_raw, subtype=rec.subtype, smooth_s=o.tap_smooth_s,
                       threshold=o.tap_threshold, min_interval_s=o.min_tap_interval_s,
                       pre_onset_s=o.pre_onset_s, segment_s=o.segment_s,
                       double_hit_window_s=o.double_hit_window_s, faint_db=o.faint_event_db)
    taps = [t for t in events if not t.rejected]
    if events and not taps:
        raise InputError(f"{name}: does not look like a tap: no sharp onset followed by a ring-down in "
                         f"{len(events)} sound event{'s' if len(events) > 1 else ''} (speech, music or a running "
                         "machine?); record taps on the tool tip in a quiet moment")
    if not taps:
        why = _unusable(rec)
        raise InputError(f"{name}: no tap found" + (f": {why}" if why else
                                                     " (the recording holds only noise or a steady sound)"))
    used = [t for t in taps if t.used]
    seg_n = int(round(o.segment_s * fs))
    if max(t.end - t.onset for t in used) < int(0.01 * fs):
        raise InputError(f"{name}: the tap is cut off after less than 10 ms: the recording is too short"
                         + _read_notes(rec))
    pre = -o.pre_onset_s
    n_disp = seg_n + int(round(o.pre_onset_s * fs))
    n_fft = fft_length(n_disp, fs, o.max_bin_hz)
    freq, spec = spectra(tap_segments(mono, fs, used, pre, n_disp, o.fade_fraction), fs, n_fft)
    tap_mag = np.abs(spec)
    mag = tap_mag.mean(axis=0)
    noise = noise_segments(mono, fs, events, n_disp)
    noise_mag = None
    if noise.shape[0]:
        noise_mag = np.abs(spectra(fade_out(noise, o.fade_fraction), fs, n_fft)[1]).mean(axis=0)
        floor = smooth_floor(freq, noise_mag, q=50)
    else:
        floor = smooth_floor(freq, mag, width_hz=1000.0, q=10)
    return mono, events, used, seg_n, n_disp, freq, tap_mag, mag, noise_mag, floor


def _read_notes(rec: Recording) -> str:
    """What reading the file found (a WAV cut short), to end an error message with ('' if nothing)."""
    prefix = f"{rec.name}: "
    return "".join(f"; {w.removeprefix(prefix)}" for w in rec.warnings)


def _unusable(rec: Recording) -> str:
    """Why a recording without a usable tap may hold none: cut short, too low a rate, an
    overloaded input ('' if none of these)."""
    why = [w.removeprefix(f"{rec.name}: ") for w in rec.warnings]
    fs = rec.sample_rate
    if fs < RECOMMENDED_SAMPLE_RATE:
        why.append(f"its sample rate is {fs} Hz, so its spectrum ends at {fs / 2:g} Hz, below what a tap analysis "
                   f"needs (bending modes ring at 3–20 kHz): record at {RECOMMENDED_SAMPLE_RATE} Hz or more "
                   "(48 kHz WAV), not with a phone's voice or call recorder")
    runs = full_scale_runs(rec.samples)
    if runs:
        why.append(f"it is clipped at full scale ({runs} flat tops of 3 or more samples): the input is overloaded; "
                   "lower the input gain and tap softer")
    return "; ".join(why)


def find_spectral_peaks(rec: Recording, o: SpectrumOptions = SpectrumOptions()) -> dict:
    """Detect the peaks of a recording (parabolic frequencies, unlabeled, unrefined).

    Returns
    -------
    dict
        ``taps, used, freq, tap_mag, mag, noise_mag``; ``rejected`` (the events that are
        no tap: faint, or without a ring-down); ``untapped`` (start times [s] of loud
        sounds without a tap's onset, :func:`~taptune.signal.taps.sound_without_tap`); ``peaks`` (list of Peak, kind
        "other", ascending), ``idx`` (their bins), ``over`` (their height over the floor
        [dB]), ``floor`` (the smoothed noise floor), ``top_db``, ``oversample`` (FFT bins per
        native bin of a tap segment), ``stationary`` (list of bool) and
        ``refine(peaks, effort, bins=None, snr=None) -> peaks`` (see
        :func:`~taptune.signal.peaks.refine_peaks`).
    """
    fs = rec.sample_rate
    mono, events, used, seg_n, n_disp, freq, tap_mag, mag, noise_mag, floor = _peak_spectra(rec, o)
    taps = [t for t in events if not t.rejected]
    fmax = min(o.fmax_hz or np.inf, 0.98 * fs / 2)
    idx, hz, lev, prom, snr, over = pick_peaks(freq, mag, floor, prominence_db=o.prominence_db,
                                            min_snr_db=o.min_snr_db, min_local_db=o.min_local_db,
                                            fmin_hz=o.fmin_hz, fmax_hz=fmax, max_peaks=o.max_peaks)
    # Window leakage of a long ring is no mode (peaks.leakage_lobes), judged out to 40
    # native bins (1/segment) from each louder peak: beyond, its side lobes are > 40 dB down.
    n_fft = 2 * (freq.size - 1)
    shortest = min(min(t.end - t.onset for t in used) + int(round(o.pre_onset_s * fs)), n_disp)
    leak, null = window_leakage_db(shortest, o.fade_fraction, n_fft, int(40 * n_fft / shortest))
    keep = ~leakage_lobes(idx, lev, leak, null)
    idx, hz, lev, prom, snr, over = idx[keep], hz[keep], lev[keep], prom[keep], snr[keep], over[keep]
    stationary = np.zeros(len(idx), dtype=bool)
    if noise_mag is not None:
        for k, i in enumerate(idx):
            near = float(np.max(noise_mag[max(i - 2, 0):i + 3]))
            stationary[k] = 20 * np.log10(mag[i] / max(near, 1e-300)) < o.stationary_margin_db
    scatter = tap_scatter(freq, tap_mag, idx)
    top = float(np.max(lev)) if len(lev) else 0.0
    peaks = [Peak(hz=float(hz[k]), level_db=float(lev[k] - top), kind="other",
                  scatter_hz=float(scatter[k]), prominence_db=float(prom[k]), snr_db=float(snr[k]))
             for k in range(len(idx))]
    fit_spectra = _fit_spectra_factory(mono, fs, used, seg_n)

    def refine(peaks_in: list[Peak], effort, bins=None, snr=None) -> list[Peak]:
        """Pole-fit refinement; ``bins``/``snr`` give the bins and heights over the floor
        of a peak list other than the picked one (e.g. with faint peaks added)."""
        hz_r, zeta, _ = refine_peaks(freq, mag, fit_spectra, fs, idx if bins is None else np.asarray(bins),
                                     [q.hz for q in peaks_in],
                                     seg_s=seg_n / fs, effort=effort, snr_db=over if snr is None else np.asarray(snr),
                                     starts_s=o.fit_starts_s,
                                     target_rel_std=o.target_rel_std,
                                     width_factor=o.fit_width_factor)
        return [replace(q, hz=float(hz_r[k]),
                        damping_ratio=None if np.isnan(zeta[k]) else float(zeta[k]))
                for k, q in enumerate(peaks_in)]

    return {"taps": taps, "rejected": [t for t in events if t.rejected], "used": used, "freq": freq,
            "untapped": sound_without_tap(mono, fs, events),
            "tap_mag": tap_mag, "mag": mag, "noise_mag": noise_mag, "peaks": peaks, "idx": idx, "over": over, "floor": floor,
            "top_db": top, "oversample": 2 * (freq.size - 1) / n_disp,
            "stationary": [bool(v) for v in stationary], "refine": refine, "leak_reach_hz": 40 * fs / shortest}


def _tap_warnings(taps: list[Tap], name: str, o: SpectrumOptions, rejected=()) -> list[str]:
    w = []
    n = len(taps)
    clipped = [t for t in taps if t.clipped]
    n_dbl = sum(t.double_hit for t in taps)
    n_used = sum(t.used for t in taps)
    if clipped:
        level = max(t.clip_level for t in clipped)
        how = ("clipped at full scale" if level >= NEAR_FULL_SCALE else
               f"flat-topped at {20 * np.log10(level):.1f} dBFS (a limiter or an overloaded preamp holds the peaks "
               "below full scale)")
        w.append(f"{name}: {how} in {len(clipped)} of {n} taps: the levels are unreliable; tap softer or "
                 "lower the input gain" + (" (the clipped taps are left out of the average)" if n_used < n
                                           else " (used anyway: no tap is clean)"))
    if n_dbl:
        w.append(f"{n_dbl} of {n} taps are double hits" + (": left out of the average" if n_used < n
                                                           else ": used anyway"))
    faint = [t for t in rejected if t.rejected == "faint"]
    if faint:
        below = 20 * np.log10(max(t.peak for t in taps) / max(max(t.peak for t in faint), 1e-300))
        w.append(f"{name}: {len(faint)} faint sound event{'s' if len(faint) > 1 else ''} "
                 f"({below:.0f} dB{' or more' if len(faint) > 1 else ''} below the loudest tap: a thump, a click?) "
                 f"{'are' if len(faint) > 1 else 'is'} not counted as a tap")
    other = [t for t in rejected if t.rejected != "faint"]
    if other:
        w.append(f"{name}: {len(other)} sound event{'s' if len(other) > 1 else ''} at "
                 f"{', '.join(f'{t.time_s:.2f}' for t in other[:5])} s {'do' if len(other) > 1 else 'does'} not look "
                 "like a tap (no ring-down after the onset: speech, music, a machine?): left out")
    if n_used == 1:
        w.append("a single tap: no tap-to-tap scatter; tap several times for a steadier average")
    best = max(t.snr_db for t in taps)
    if best < o.low_snr_db:
        w.append(f"low signal-to-noise ratio: the loudest tap is {best:.0f} dB above the noise "
                 f"(tap harder or move the microphone closer)")
    return w


def _bandwidth_warnings(name, expected_hz, bandwidth_hz, low_pass, recording) -> list[str]:
    """One warning per expected bending mode a codec's low-pass or the sample rate hides."""
    out = []
    fs = recording.sample_rate
    for mode, f, limit in hidden_modes(expected_hz, bandwidth_hz, fs):
        if not (low_pass and limit < 0.9 * fs / 2):
            out.append(f"{name}: sample rate {fs} Hz: bending mode {mode} expected near {f / 1000:.1f} kHz "
                       f"is above 0.9 x Nyquist; record at a higher rate (96 kHz)")
            continue
        source = f"{recording.codec.upper()} low-pass?" if recording.lossy else "a phone's or an app's low-pass?"
        cut = f"{bandwidth_hz / 1000:.1f} kHz ({source})"
        what = ("cannot be measured" if f >= bandwidth_hz
                else "sits at that edge, where the codec bends peaks")
        out.append(f"{name}: the recording carries nothing above {cut}; bending mode {mode} expected near "
                   f"{f / 1000:.1f} kHz {what} — record WAV at ≥ 44.1 kHz, or use a recorder app "
                   f"without compression")
    return out


#: Marks the faint-peak warning (:func:`faint_warning`), so a relabelling can replace it.
FAINT_MARK = "taken from faint peak"


def faint_warning(name: str, peaks: list[Peak]) -> str:
    """The warning naming the bending modes taken from faint peaks ('' without any)."""
    if not peaks:
        return ""
    plural = "s" if len(peaks) > 1 else ""
    what = "; ".join(f"mode {q.mode} at {q.hz:.0f} Hz, {q.snr_db:.0f} dB over the local floor"
                     for q in sorted(peaks, key=lambda q: q.mode or 0))
    return (f"{name}: bending mode{plural} {FAINT_MARK}{plural} ({what}): found only by the model-guided "
            f"search (there in every tap, resonance-shaped), so less sure; tap harder or nearer the "
            f"microphone to confirm")


def _faint_peaks(r: dict, labeled: list[Peak], expected_hz, bounds_hz, spread_hz, bands,
                 o: SpectrumOptions) -> list[tuple]:
    """Faint peaks in the guided windows of the missing bending modes.

    Returns (Peak, stationary, bin, height over the noise floor [dB]) per peak found.
    """
    found = {q.mode: q.hz for q in labeled if q.kind == "bending"}
    windows = guided_windows(expected_hz, bounds_hz, spread_hz, found, options=o.labels)
    if not windows:
        return []
    search = faint_windows(windows.values(), bands, labeled)
    freq = r["freq"]
    fmax = min(o.fmax_hz or np.inf, 0.98 * freq[-1])
    search = [(lo, min(hi, fmax)) for lo, hi in search if lo < fmax]
    cands = pick_faint_peaks(freq, r["mag"], r["tap_mag"], search, noise_mag=r["noise_mag"],
                             min_db=o.faint_min_db, tap_db=o.faint_tap_db, f_ratio=o.faint_f_ratio,
                             prominence_db=o.faint_prominence_db, tap_fraction=o.faint_tap_fraction,
                             ring_hz=o.faint_ring_hz, stationary_margin_db=o.stationary_margin_db,
                             oversample=r["oversample"], known_bins=r["idx"])
    scatter = tap_scatter(freq, r["tap_mag"], [c["idx"] for c in cands])
    out = []
    for c, sc in zip(cands, scatter):
        i = c["idx"]
        over_noise = float(20 * np.log10(r["mag"][i] / max(float(r["floor"][i]), 1e-300)))
        pk = Peak(hz=c["hz"], level_db=c["db"] - r["top_db"], kind="other", damping_ratio=c["zeta"],
                  scatter_hz=float(sc), prominence_db=c["prominence_db"], snr_db=c["over_db"], note="faint",
                  reliability="faint")
        out.append((pk, False, i, over_noise))
    return out


def _without_unfitted_lobes(peaks: list[Peak], reach_hz: float, below_db: float = 20.0) -> list[Peak]:
    """The peaks without the "other" ones that no pole fit could refine (no damping value)
    lying within ``reach_hz`` of a peak at least ``below_db`` louder: the leakage of a long
    ring that stands a little above the window's ideal side lobes (its ring beats or is
    reflected) is no decaying mode, so the fit fails on it. Stationary and faint peaks are
    not fitted at all and stay, as do labelled ones."""
    def lobe(q):
        return (q.kind == "other" and q.damping_ratio is None and q.reliability == "clear"
                and q.note != NOTE_STATIONARY
                and any(abs(o.hz - q.hz) <= reach_hz and o.level_db >= q.level_db + below_db for o in peaks))
    return [q for q in peaks if not lobe(q)]


def analyse_recording(recording: Recording, interface: str | None = "HSK-A63", expected_hz=None,
                      bounds_hz=None, options: SpectrumOptions = SpectrumOptions(),
                      interface_tap: Recording | None = None, spread_hz=None, found: dict | None = None) -> SpectrumAnalysis:
    """Find the taps, average their spectra, pick, refine and label the peaks.

    Parameters
    ----------
    recording : Recording
        Taps on the tool tip.
    interface : str or None
        Spindle interface (``Assembly.holder.interface``) for the local-mode band.
    expected_hz : array_like, shape (n,), optional
        Model bending frequencies [Hz] (nominal or library parameters).
    bounds_hz : array_like, shape (n, 2), optional
        Physical (lo, hi) bounds per bending mode [Hz] (``bending_bounds``).
    options : SpectrumOptions
    interface_tap : Recording, optional
        Taps on the interface itself: the peaks that grow there are its local modes.
    spread_hz : array_like, shape (n, k), optional
        How far each model bending frequency moves [Hz] per plausible spread of each
        holder parameter (:func:`~taptune.signal.labels.assign_bending`); sharper labels.
    found : dict, optional
        :func:`find_spectral_peaks` of ``recording`` with ``options``, when the caller
        has it already (it refines peaks again after a relabelling): not computed twice.

    Returns
    -------
    SpectrumAnalysis

    Raises
    ------
    InputError
        Silent, too short, no tap, or no peak at all.
    """
    o = options
    name = recording.name
    r = find_spectral_peaks(recording, o) if found is None else found
    peaks = r["peaks"]
    if not peaks:
        why = _unusable(recording)
        raise InputError(f"{name}: no spectral peak stands out of the noise" + (f": {why}" if why else ""))
    # What reading found (a WAV cut short) first, then the taps'.
    warnings = list(recording.warnings) + _tap_warnings(r["taps"], name, o, r.get("rejected", ()))
    untapped = r.get("untapped", ())
    if len(untapped) >= max(2, len(r["used"])):
        # More loud sounds swell in than taps start sharply: words, notes, a machine.
        warnings.append(f"{name}: does not look like a tap: {len(untapped)} loud sounds (at "
                        f"{', '.join(f'{t:.2f}' for t in untapped[:5])}{' …' if len(untapped) > 5 else ''} s) "
                        "swell in without a tap's sharp onset (speech, music or a running machine?); "
                        "record taps on the tool tip in a quiet moment")
    pitch = harmonic_fundamental([q.hz for q in peaks], [q.level_db for q in peaks])
    if pitch is not None:
        warnings.append(f"{name}: does not look like a tap: the loud peaks form a harmonic series on {pitch:.0f} Hz "
                        "(a voice or a musical note), while a tapped tool rings at unrelated frequencies")
    bands, w = interface_bands(interface, o.band_table)
    if w:
        warnings.append(w)
    growth = None
    if interface_tap is not None:
        ri = find_spectral_peaks(interface_tap, o)
        growth = interface_growth(peaks, ri["peaks"], stationary=r["stationary"])
    bandwidth, low_pass = effective_bandwidth(r["freq"], r["mag"], recording.sample_rate)
    if expected_hz is not None:
        warnings.extend(_bandwidth_warnings(name, expected_hz, bandwidth, low_pass, recording))
    stationary, bins, over = list(r["stationary"]), list(r["idx"]), list(r["over"])

    def label(pk, grow):
        return label_peaks(pk, bands=bands, expected_hz=expected_hz, bounds_hz=bounds_hz, spread_hz=spread_hz,
                           stationary=stationary, growth_db=grow, grow_threshold_db=o.grow_threshold_db,
                           options=o.labels)

    labeled, lw = label(peaks, growth)
    if expected_hz is not None and o.faint_search:
        faint = _faint_peaks(r, labeled, expected_hz, bounds_hz, spread_hz,
                             bands if growth is None else (), o)
        if faint:
            # The faint peaks join the candidates and the labels are decided again.
            merged = sorted([(q, s, b, v) for q, s, b, v in zip(peaks, stationary, bins, over)] + faint,
                            key=lambda t: t[0].hz)
            peaks = [t[0] for t in merged]
            stationary, bins, over = [t[1] for t in merged], [t[2] for t in merged], [t[3] for t in merged]
            if interface_tap is not None:
                growth = interface_growth(peaks, ri["peaks"], stationary=stationary)
            labeled, lw = label(peaks, growth)
    warnings.extend(lw)
    # Labels need percent accuracy, identification needs 0.01 %: the full refinement is
    # spent on the bending peaks only; stationary peaks keep their parabolic frequency,
    # faint ones that of their one-mode fit (a pole fit can lock onto a noise spike).
    effort = [0 if stat or q.reliability == "faint" else (2 if q.kind == "bending" else 1)
              for q, stat in zip(labeled, stationary)]
    refined = r["refine"](labeled, effort, bins, over)
    labeled = sorted((q if q.reliability == "faint" else rq for q, rq in zip(labeled, refined)), key=lambda q: q.hz)
    labeled = _without_unfitted_lobes(labeled, r.get("leak_reach_hz", 0.0))
    taken = [q for q in labeled if q.kind == "bending" and q.reliability == "faint"]
    if taken:
        warnings.append(faint_warning(name, taken))
    return SpectrumAnalysis(
        file=recording.path, sample_rate=recording.sample_rate, channels=recording.channels,
        duration_s=recording.duration_s, freq_hz=r["freq"], magnitude=r["mag"],
        tap_magnitudes=r["tap_mag"], noise_magnitude=r["noise_mag"], taps=r["taps"],
        peaks=labeled, excluded_bands_hz=list(bands) if growth is None else [],
        interface=interface, warnings=warnings, bandwidth_hz=bandwidth)
