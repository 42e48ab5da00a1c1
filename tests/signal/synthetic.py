"""Synthetic tap recordings with known truth, shared by the signal and CLI tests."""

from dataclasses import replace

import numpy as np

from taptune.signal.synth import Nuisances, modal_receptance, synthesize_recording, tap_grid

#: Three bending modes of a typical HSK-A63 assembly: (f [Hz], ζ, relative peak height).
BENDING = ((3520.0, 0.004, 1.0), (10950.0, 0.002, 0.6), (15300.0, 0.003, 0.8))
#: An interface local mode (louder than the bending peaks) and an axial/torsional mode.
LOCAL = ((9710.0, 0.0016, 2.0),)
SPURIOUS = ((16650.0, 0.0025, 0.6),)
WORKSHOP = Nuisances(sample_rate=48000, duration_s=2.0, tap_times_s=(0.2, 0.75, 1.3),
                     tap_strengths=(1.0, 0.7, 0.85), snr_db=45.0, mic_hp_hz=110.0,
                     mic_lp_hz=15500.0, reflections=((0.7e-3, 0.25), (8.0e-3, 0.05)),
                     hum_hz=50.0, hum_harmonics=4, hum_rel_db=-30.0)


def receptance(freq_hz, modes=BENDING):
    """Modal receptance whose radiated peaks (tilt f¹) have the given relative heights."""
    # Peak |H| of one mode is r / (ω² · 2ζ); times f for the radiation tilt.
    return modal_receptance(freq_hz, [(f, z, h * (2 * np.pi * f) ** 2 * 2 * z / f) for f, z, h in modes])


def workshop_recording(seed=0, modes=BENDING, extra=LOCAL + SPURIOUS, **changes):
    """A recording of ``modes`` plus ``extra`` peaks with the WORKSHOP nuisances (changed)."""
    nu = replace(WORKSHOP, **changes)
    grid = tap_grid(nu.sample_rate)
    return synthesize_recording(grid, receptance(grid, modes), nu, np.random.default_rng(seed),
                                extra_modes=extra)


def expected_and_bounds(modes=BENDING, shift=(1.06, 1.02, 1.05)):
    """Model guidance a few % off the truth (as nominal parameters are) and wide bounds."""
    f = np.array([m[0] for m in modes]) * np.array(shift)
    return f, np.column_stack([0.3 * f, 1.12 * f])


# --- Sounds that are not taps, and real-world tap effects (issue 22) -------------------

def machinery(seed=0, fs=48000, seconds=3.0, level=0.3):
    """A running machine: a spindle's tooth-passing tone and harmonics wandering in
    phase, broadband cutting noise modulated at the spindle speed, and chip clicks."""
    rng = np.random.default_rng(seed)
    n = int(fs * seconds)
    t = np.arange(n) / fs
    spindle = 200.0  # 12 000 rpm
    x = np.zeros(n)
    for h in range(1, 12):
        wander = np.cumsum(rng.normal(0, 2e-3, n))
        x += np.sin(2 * np.pi * 4 * spindle * h * t + wander) / h
    noise = rng.normal(0, 1.0, n) * (1 + 0.6 * np.sin(2 * np.pi * spindle * t))
    x += 0.8 * noise
    for k in rng.choice(n - 200, size=int(6 * seconds), replace=False):
        x[k:k + 40] += rng.normal(0, 4.0, 40) * np.exp(-np.arange(40) / 8.0)
    return level * x / np.max(np.abs(x))


def speech_like(seed=0, fs=48000, seconds=3.0, level=0.3, f0_hz=(120.0, 120.0), attack_s=None,
                spacing_s=0.25, length_s=(0.06, 0.2)):
    """Voiced syllables (a glottal pulse train through three formants, 4 per second,
    60-200 ms each) with a plosive burst before some of them, over room noise. Each
    syllable's pitch is drawn from ``f0_hz`` (low, high) [Hz] and glides by up to ±15 %
    over it, as a voice's does (the default: a monotone 120 Hz). ``attack_s``: the vowels
    swell in over this raised-cosine rise [s], as real ones do over 20-50 ms (default: a
    sin^0.5 rise, sharp). Syllables start every ``spacing_s`` and last ``length_s`` (low,
    high) [s]: connected speech runs them into each other."""
    rng = np.random.default_rng(seed)
    n = int(fs * seconds)
    x = rng.normal(0, 1e-3, n)
    f = np.fft.rfftfreq(n, 1 / fs)
    formants = sum(1 / (1 + ((f - fc) / bw) ** 2) for fc, bw in ((700, 90), (1200, 110), (2600, 160)))
    starts = np.arange(0.2, seconds - 0.3, spacing_s)
    for start in starts + rng.uniform(-0.03, 0.03, starts.size):
        a, length = int(start * fs), int(rng.uniform(*length_s) * fs)
        f0 = rng.uniform(*f0_hz)
        glide = f0 * (1 + rng.uniform(-0.15, 0.15) * np.linspace(0, 1, length)) if f0_hz[1] > f0_hz[0] \
            else np.full(length, f0)
        pulses = np.zeros(n)
        pulses[a + np.flatnonzero(np.diff(np.floor(np.cumsum(glide) / fs)) > 0)] = 1.0
        voiced = np.fft.irfft(np.fft.rfft(pulses) * formants, n)
        env = np.sin(np.pi * np.arange(length) / length) ** 0.5
        if attack_s:
            rise = min(int(attack_s * fs), length // 2)
            env[:rise] *= 0.5 - 0.5 * np.cos(np.pi * np.arange(rise) / rise)
        x[a:a + length] += voiced[a:a + length] / np.max(np.abs(voiced)) * env
        if rng.random() < 0.5:  # a plosive: a short noise burst just before the vowel
            b = a - int(0.02 * fs)
            x[b:b + 200] += rng.normal(0, 0.5, 200) * np.exp(-np.arange(200) / 50)
    return level * x / np.max(np.abs(x))


def music_like(seed=0, fs=48000, seconds=3.0, level=0.3):
    """Sustained harmonic notes (organ or bowed strings: 40 ms attacks, held 0.3-0.6 s)
    overlapping each other."""
    rng = np.random.default_rng(seed)
    n = int(fs * seconds)
    t = np.arange(n) / fs
    x = rng.normal(0, 1e-3, n)
    start = 0.05
    while start < seconds - 0.2:
        f0 = 220 * 2 ** (rng.integers(0, 24) / 12)
        length = rng.uniform(0.3, 0.6)
        env = np.clip((t - start) / 0.04, 0, 1) * np.clip((start + length - t) / 0.05, 0, 1)
        x += env * sum(np.sin(2 * np.pi * f0 * h * t + rng.uniform(0, 6.3)) / h for h in range(1, 8))
        start += rng.uniform(0.15, 0.35)
    return level * x / np.max(np.abs(x))


#: A guitar-like body: (f [Hz], ζ, amplitude): low, well-damped plate and air modes.
BODY = ((164.0, 0.012, 1.0), (239.0, 0.015, 0.45), (317.0, 0.012, 0.5), (611.0, 0.02, 0.2),
        (794.0, 0.02, 0.08), (1120.0, 0.015, 0.05), (1805.0, 0.01, 0.03), (2600.0, 0.01, 0.02))


def struck(force, modes=BODY, fs=48000, seconds=0.6):
    """Sound of modes (f, ζ, amplitude) driven by the force samples ``force`` (a tap's contact)."""
    n = int(fs * seconds)
    t = np.arange(n) / fs
    h = sum(a * np.exp(-z * 2 * np.pi * f * t) * np.sin(2 * np.pi * f * np.sqrt(1 - z * z) * t) for f, z, a in modes)
    return np.convolve(force, h)[:n]


def knuckle_force(rng, fs=48000):
    """A knuckle's contact: 2-4 ms of skin and bone, a ragged pulse of a few overlapping
    half-sines (no clean spike), one contact all the same."""
    n = int(rng.uniform(2e-3, 4e-3) * fs)
    f = np.zeros(n)
    for _ in range(4):
        w = int(rng.uniform(0.2, 0.5) * n)
        a = int(rng.uniform(0, n - w))
        f[a:a + w] += rng.uniform(0.3, 1.0) * np.sin(np.pi * np.arange(w) / w)
    return f


def hand_taps(seed=0, times=(0.3, 1.1, 1.9, 2.7, 3.5, 4.3, 5.1, 5.9), strengths=None, modes=BODY, fs=48000,
              force=knuckle_force, noise=1e-4, level=0.5, seconds=None):
    """Knuckle taps on a body, each with its own ragged contact, at ``strengths`` (default 1)."""
    rng = np.random.default_rng(seed)
    seconds = seconds or times[-1] + 0.7
    x = rng.normal(0, noise, int(fs * seconds))
    for t0, s in zip(times, strengths or (1.0,) * len(times)):
        a = int(t0 * fs)
        y = struck(force(rng, fs), modes, fs, min(0.6, seconds - t0))
        x[a:a + y.size] += s * y / np.max(np.abs(y))
    return level * x / np.max(np.abs(x))
