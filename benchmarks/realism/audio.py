"""Tap recordings of corpus cases, their files for the CLI, and which bending modes are audible.

:func:`record` renders the truth's tip receptance (both bending planes, as the tap and
microphone see them) through ``taptune.signal.synth`` and then does what that module does
not: a phone's steep low-pass and quantisation to the file's bit depth.

Audibility (:func:`audible_modes`) is a rule on the recording, not on the pipeline: a
bending mode is audible when the NOISE-FREE rendering of the same taps (same level, same
local modes, no noise or hum or quantisation), averaged over the same tap segments as
the analysis, has a local maximum within ±0.4 % of the mode (of either plane) that
stands ≥ 6 dB above the noise floor between the taps of the real recording (median of
the between-tap spectrum over ±250 Hz), below 0.98 × Nyquist.
"""

from __future__ import annotations

import json
from dataclasses import replace
from pathlib import Path

import numpy as np

from benchmarks.realism.truth import truth_receptance
from taptune.io.audio import Recording, make_recording
from taptune.signal.synth import synthesize_recording, tap_grid

AUDIBLE_DB = 6.0
AUDIBLE_WINDOW = 0.004
FLOOR_HALF_WIDTH_HZ = 250.0


def _render(case, nuisances, rng, path: str = "") -> Recording:
    setup = case.recording
    grid = tap_grid(nuisances.sample_rate)
    h = truth_receptance(case.true_assembly, case.holder, grid)
    rec = synthesize_recording(grid, h, nuisances, rng, extra_modes=setup.extra_modes, path=path)
    x = rec.samples
    if setup.phone_lp_hz:
        from scipy.signal import butter, sosfilt

        sos = butter(8, setup.phone_lp_hz, fs=nuisances.sample_rate, output="sos")
        x = sosfilt(sos, x, axis=0)
    return make_recording(x, rec.sample_rate, path=path, subtype="FLOAT")


def _quantise(x, bits: int) -> np.ndarray:
    full = 2.0 ** (bits - 1) - 1
    return np.clip(np.round(x * full), -full - 1, full) / full


def record(case, seed: int | None = None, path: str = "") -> Recording:
    """The tap recording of ``case`` (deterministic in ``seed``, default the case's seed)."""
    rng = np.random.default_rng(case.seed if seed is None else seed)
    rec = _render(case, case.recording.nuisances, rng, path)
    bits = case.recording.bits
    return make_recording(_quantise(rec.samples, bits), rec.sample_rate, path=path, subtype=f"PCM_{bits}")


def clean_recording(case) -> Recording:
    """The same taps without noise, hum, or quantisation (for the audibility rule)."""
    nu = replace(case.recording.nuisances, snr_db=None, hum_hz=None)
    return _render(case, nu, None)


def audible_modes(case, analysis, clean: Recording | None = None) -> list[bool]:
    """Which of the truth's bending modes 1–3 are audible in the recording (module docstring).

    Parameters
    ----------
    case : Case
    analysis : SpectrumAnalysis
        The product's analysis of :func:`record` (its used taps and noise spectrum).
    clean : Recording, optional
        :func:`clean_recording` of the case (rendered here when not given).
    """
    return [m >= AUDIBLE_DB for m in audibility_margins(case, analysis, clean)]


def audibility_margins(case, analysis, clean: Recording | None = None) -> list[float]:
    """Per bending mode 1–3: how far [dB] the noise-free peak stands above the noise floor.

    ``-inf`` when the noise-free spectrum has no local maximum within ±0.4 % of the mode
    (of either plane) or the mode lies above 0.98 × Nyquist.
    """
    from taptune.signal.analysis import SpectrumOptions
    from taptune.signal.spectrum import fft_length, spectra, tap_segments
    from taptune.signal.taps import to_mono

    o = SpectrumOptions()
    clean = clean or clean_recording(case)
    fs = clean.sample_rate
    used = [t for t in analysis.taps if t.used]
    n_disp = int(round(o.segment_s * fs)) + int(round(o.pre_onset_s * fs))
    n_fft = fft_length(n_disp, fs, o.max_bin_hz)
    freq, spec = spectra(tap_segments(to_mono(clean.samples, fs), fs, used, -o.pre_onset_s, n_disp, o.fade_fraction),
                         fs, n_fft)
    mag = np.abs(spec).mean(axis=0)
    noise = analysis.noise_magnitude
    if noise is None or len(noise) != len(mag):
        raise RuntimeError(f"{case.name}: no between-tap noise spectrum to judge audibility")
    out = []
    for n in range(3):
        best = -np.inf
        for f in {case.truth.plane_hz[0][n], case.truth.plane_hz[1][n]}:
            if f >= 0.98 * fs / 2:
                continue
            win = np.flatnonzero(np.abs(freq / f - 1) <= AUDIBLE_WINDOW)
            k = win[np.argmax(mag[win])]
            if not win[0] < k < win[-1]:
                continue
            floor = float(np.median(noise[np.abs(freq - f) <= FLOOR_HALF_WIDTH_HZ]))
            best = max(best, 20 * np.log10(mag[k] / max(floor, 1e-300)))
        out.append(float(best))
    return out


def write_case(case, folder) -> Path:
    """Write ``<name>.wav`` (the recording), ``<name>.toml`` (described), ``<name>.truth.json``.

    Also one ``<name>_so<stick-out>.toml`` per query (the described assembly there), so
    ``taptune identify`` / ``taptune predict`` can be run on the case. Returns the folder.
    """
    from taptune.io.assembly import assembly_to_toml
    from taptune.io.audio import write_audio

    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    rec = record(case, path=str(folder / f"{case.name}.wav"))
    write_audio(rec.path, rec.samples, rec.sample_rate, rec.subtype)
    (folder / f"{case.name}.toml").write_text(assembly_to_toml(case.described), encoding="utf-8")
    for q in case.queries:
        (folder / f"{case.name}_so{q.stickout_mm:g}.toml").write_text(
            assembly_to_toml(case.described_at(q.stickout_mm)), encoding="utf-8")
    (folder / f"{case.name}.truth.json").write_text(json.dumps(case.to_dict(), indent=1), encoding="utf-8")
    return folder


def write_check_pairs(n: int, folder) -> Path:
    """Write the held-out ``taptune check`` pairs (:func:`~benchmarks.realism.corpus.check_pairs`).

    One sub-folder per pair, ``pair<k>/``, holding ``reference.wav/.toml``,
    ``other.wav/.toml`` and ``expected.json`` (``{"verdict": "consistent"|"differs", ...}``).
    """
    from taptune.io.assembly import assembly_to_toml
    from taptune.io.audio import write_audio

    from benchmarks.realism.corpus import check_pairs

    folder = Path(folder)
    for k, (ref, other, verdict) in enumerate(check_pairs(n)):
        sub = folder / f"pair{k:02d}"
        sub.mkdir(parents=True, exist_ok=True)
        for tag, case in (("reference", ref), ("other", other)):
            rec = record(case, path=str(sub / f"{tag}.wav"))
            write_audio(rec.path, rec.samples, rec.sample_rate, rec.subtype)
            (sub / f"{tag}.toml").write_text(assembly_to_toml(case.described), encoding="utf-8")
        info = {"verdict": verdict, "reference": ref.name, "other": other.name,
                "reference_truth": ref.truth.to_dict(), "other_truth": other.truth.to_dict(),
                "contact_factor": other.holder.params.k_tt / ref.holder.params.k_tt}
        (sub / "expected.json").write_text(json.dumps(info, indent=1), encoding="utf-8")
    return folder
