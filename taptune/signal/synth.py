"""Tap-sound synthesis: a recording "from the model plus the workshop" for tests and examples.

The sound of tap k is ``s_k · F_k(f) · H(f) · (if/f_ref)^p · R(f) · M(f)`` in the
frequency domain: the half-sine contact force spectrum F (duration 50–100 µs), the tip
receptance H (from the model, or :func:`modal_receptance`), a radiation tilt (p = 2 is
accelerance; sound pressure follows surface acceleration), reflections
``R = 1 + Σ g·exp(−i2πf·d)`` and the microphone's high- and low-pass M. Each tap is
placed by an inverse FFT at its (fractional) time; then the level is set, and hum, white
noise at a given SNR, clipping, a DC offset and a second channel are added.
Everything random comes from the caller's ``numpy.random.Generator``.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from taptune.io.audio import Recording, make_recording
from taptune.signal.peaks import find_peaks


@dataclass(frozen=True)
class Nuisances:
    """Settings of a synthetic recording (times in s, frequencies in Hz, levels in dB).

    Attributes
    ----------
    sample_rate : int
    duration_s : float
    tap_times_s : tuple of float
        Onsets of the taps.
    tap_strengths : tuple of float
        Relative force of each tap (same length as ``tap_times_s``).
    contact_s : float or tuple of float
        Half-sine contact duration, one for all taps or one per tap.
    double_hits : tuple of (int, float, float)
        (tap index, delay [s], relative strength) of a second impact after a tap.
    radiation_exponent : float
        p of the radiation tilt (if/f_ref)^p.
    mic_hp_hz, mic_lp_hz : float or None
        Microphone corner frequencies (2nd-order Butterworth each); None = flat.
    reflections : tuple of (float, float)
        (delay [s], gain) pairs.
    hum_hz : float or None
        Mains frequency (50 or 60); None = no hum.
    hum_harmonics : int
    hum_rel_db : float
        Hum amplitude relative to the loudest tap's peak [dB].
    snr_db : float or None
        Loudest tap's peak amplitude over the noise RMS [dB]; None = no noise.
    level : float
        Peak amplitude of the loudest tap before clipping (full scale 1).
    clip : float or None
        Clipping level (full scale 1); None = none.
    dc_offset : float
    channels : int
        1 or 2; the second channel hears the taps with ``gain2`` and a fractional
        ``delay2_samples``, with its own noise.
    gain2, delay2_samples : float
    """

    sample_rate: int = 48000
    duration_s: float = 2.0
    tap_times_s: tuple = (0.2, 0.75, 1.3)
    tap_strengths: tuple = (1.0, 0.8, 0.6)
    contact_s: float | tuple = 70e-6
    double_hits: tuple = ()
    radiation_exponent: float = 1.0
    mic_hp_hz: float | None = 100.0
    mic_lp_hz: float | None = 16000.0
    reflections: tuple = ((0.8e-3, 0.2),)
    hum_hz: float | None = 50.0
    hum_harmonics: int = 4
    hum_rel_db: float = -35.0
    snr_db: float | None = 40.0
    level: float = 0.5
    clip: float | None = None
    dc_offset: float = 0.0
    channels: int = 1
    gain2: float = 0.8
    delay2_samples: float = 0.1
    extra: dict = field(default_factory=dict)


def modal_receptance(freq_hz, modes) -> np.ndarray:
    """Receptance [m/N] from modes with hysteretic damping, on a frequency grid.

    Parameters
    ----------
    freq_hz : ndarray, shape (m,)
    modes : sequence of (f_hz, zeta, residue)
        Undamped frequency [Hz], damping ratio ζ = η/2 and modal residue [1/kg]:
        ``H = Σ r / (ω_r²(1 + 2iζ) − ω²)``; the eigenvalue's ``sqrt(Re λ)/2π`` is f_hz
        exactly, as in the model.

    Returns
    -------
    ndarray, shape (m,), complex
    """
    w = 2 * np.pi * np.asarray(freq_hz, dtype=np.float64)
    h = np.zeros(w.shape, dtype=complex)
    for f, z, r in modes:
        wr = 2 * np.pi * f
        h += r / (wr**2 * (1 + 2j * z) - w**2)
    return h


def half_sine_spectrum(freq_hz, contact_s: float) -> np.ndarray:
    """Spectrum of a unit-impulse half-sine force of duration ``contact_s`` [s], shape of freq."""
    w = 2 * np.pi * np.asarray(freq_hz, dtype=np.float64)
    wc = np.pi / contact_s
    # ∫ sin(wc t) e^{-iwt} dt over [0, T], normalised to 1 at f = 0.
    with np.errstate(divide="ignore", invalid="ignore"):
        f = wc * (1 + np.exp(-1j * w * contact_s)) / (wc**2 - w**2)
    near = np.abs(w - wc) < 1e-6 * wc
    f = np.where(near, -0.5j * contact_s, f)
    return f * wc / 2


def _butter2(freq_hz, corner_hz, high: bool) -> np.ndarray:
    s = 1j * np.asarray(freq_hz, dtype=np.float64) / corner_hz
    if high:
        s = np.where(s == 0, 1e-12j, s)
        s = 1 / s
    return 1 / (s**2 + np.sqrt(2) * s + 1)


def without_rigid_body(freq_hz, receptance) -> np.ndarray:
    """The receptance less its rigid-body part −a/ω² (a free-free body's mass line).

    A free body pushed by the tap moves off as a whole; that motion radiates no sound
    at audio frequencies but would dominate a synthesised signal. Below a quarter of the
    first resonance ``H·ω² = −a + b·ω²`` (mass line plus static flexibility) gives ``a``
    by least squares.

    Parameters
    ----------
    freq_hz, receptance : ndarray, shape (m,)

    Returns
    -------
    ndarray, shape (m,), complex
    """
    f = np.asarray(freq_hz, dtype=np.float64)
    h = np.asarray(receptance, dtype=complex)
    w2 = (2 * np.pi * f) ** 2
    # The first resonance: the first peak of the accelerance above 20 Hz.
    above = np.flatnonzero(f >= 20.0)
    peaks, _ = find_peaks(np.abs(h[above]) * w2[above])
    f1 = f[above[peaks[0]]] if peaks.size else f[-1]
    low = (f >= 20.0) & (f < 0.25 * f1)
    if np.count_nonzero(low) < 3:
        return h
    a = np.column_stack([np.ones(np.count_nonzero(low)), w2[low]])
    coef, *_ = np.linalg.lstsq(a, (h[low] * w2[low]).astype(complex), rcond=None)
    out = h.copy()
    nz = w2 > 0
    out[nz] = h[nz] - coef[0] / w2[nz]
    out[~nz] = coef[1]
    return out


def tap_grid(sample_rate: int, ring_s: float = 1.0) -> np.ndarray:
    """The frequency grid [Hz] on which to give the receptance: rFFT bins of ``ring_s``.

    A mode with ζ = 0.1 % at 1 kHz has decayed by 50 dB after 1 s, so 1 s holds any
    tap's ring-down.
    """
    n = int(round(ring_s * sample_rate))
    return np.fft.rfftfreq(n, 1.0 / sample_rate)


def _peak_of(freq_hz, spec, f_min: float = 20.0) -> float:
    """Height of the highest resonance peak of |spec| above ``f_min`` [Hz] (not the
    rigid-body rise towards f = 0)."""
    mag = np.abs(spec[freq_hz >= f_min])
    idx, _ = find_peaks(mag)
    return float(np.max(mag[idx])) if idx.size else float(np.max(mag, initial=0.0))


def synthesize_recording(freq_hz, receptance, nuisances: Nuisances = Nuisances(), rng=None, *,
                         extra_modes=(), path: str = "", f_ref_hz: float = 1000.0,
                         rigid_body: str = "remove") -> Recording:
    """Synthesise a tap recording from a tip receptance and workshop nuisances.

    Parameters
    ----------
    freq_hz : ndarray, shape (m,)
        Grid of ``receptance`` [Hz]; :func:`tap_grid` gives the one used inside
        (another grid is interpolated onto it, which smears resonances narrower than
        its spacing: prefer ``tap_grid``).
    receptance : ndarray, shape (m,), complex
        Tip receptance H(f) [m/N].
    nuisances : Nuisances
    rng : numpy.random.Generator
        Noise, hum phases; required when there is noise or hum.
    extra_modes : sequence of (f_hz, zeta, rel_peak)
        Peaks that are not in the receptance (interface local modes, axial/torsional
        modes, table resonances): each is a mode whose peak in the radiated spectrum is
        ``rel_peak`` times the highest resonance peak of the receptance's.
    path : str
        Stored as the recording's path.
    f_ref_hz : float
        Reference frequency of the radiation tilt.
    rigid_body : {"remove", "keep"}
        Whether to take a free-free receptance's rigid-body mass line out first
        (:func:`without_rigid_body`): it does not radiate but would swamp the signal.

    Returns
    -------
    Recording
        Samples (n, channels) float64, subtype ``"FLOAT"``.
    """
    n_ = nuisances
    fs = int(n_.sample_rate)
    grid = tap_grid(fs)
    f_in = np.asarray(freq_hz, dtype=np.float64)
    h_in = np.asarray(receptance, dtype=complex)
    if f_in.shape == grid.shape and np.allclose(f_in, grid):
        h = h_in.copy()
    else:
        h = (np.interp(grid, f_in, h_in.real, left=0, right=0)
             + 1j * np.interp(grid, f_in, h_in.imag, left=0, right=0))
    if rigid_body == "remove":
        h = without_rigid_body(grid, h)
    tilt = (1j * grid / f_ref_hz) ** n_.radiation_exponent
    radiated = h * tilt
    top = _peak_of(grid, radiated)
    for f, z, rel in extra_modes:
        one = modal_receptance(grid, [(f, z, 1.0)]) * tilt
        radiated = radiated + one * (rel * top / _peak_of(grid, one))
    room = np.ones_like(grid, dtype=complex)
    for d, g in n_.reflections:
        room += g * np.exp(-2j * np.pi * grid * d)
    mic = np.ones_like(grid, dtype=complex)
    if n_.mic_hp_hz:
        mic *= _butter2(grid, n_.mic_hp_hz, high=True)
    if n_.mic_lp_hz:
        mic *= _butter2(grid, n_.mic_lp_hz, high=False)
    base = radiated * room * mic
    n_ring = 2 * (grid.size - 1)
    n_total = int(round(n_.duration_s * fs))
    x = np.zeros(n_total + n_ring)
    contacts = np.broadcast_to(np.atleast_1d(n_.contact_s), (len(n_.tap_times_s),))
    impacts = [(t, s, c) for t, s, c in zip(n_.tap_times_s, n_.tap_strengths, contacts)]
    for i, delay, rel in n_.double_hits:
        impacts.append((n_.tap_times_s[i] + delay, n_.tap_strengths[i] * rel, contacts[i]))
    # A hysteretic receptance is slightly non-causal: its inverse FFT has a small
    # precursor at the end of the buffer; start each tap's buffer 1 ms early to keep it.
    lead = int(round(1e-3 * fs))
    for t, s, c in impacts:
        k0 = int(np.floor(t * fs))
        frac = t * fs - k0
        spec = s * base * half_sine_spectrum(grid, c) * np.exp(-2j * np.pi * grid * (frac + lead) / fs)
        ir = np.fft.irfft(spec, n=n_ring)
        a = k0 - lead
        lo = max(a, 0)
        x[lo:a + n_ring] += ir[lo - a:]
    x = x[:n_total]
    peak = float(np.max(np.abs(x))) or 1.0
    x *= n_.level / peak
    t_axis = np.arange(n_total) / fs
    if n_.hum_hz:
        amp = n_.level * 10 ** (n_.hum_rel_db / 20)
        for k in range(1, n_.hum_harmonics + 1):
            x += amp / k * np.sin(2 * np.pi * k * n_.hum_hz * t_axis + rng.uniform(0, 2 * np.pi))
    chans = [x]
    if n_.channels == 2:
        # Fractional delay by a linear phase on the whole signal.
        spec = np.fft.rfft(x)
        f = np.fft.rfftfreq(n_total, 1 / fs)
        shift = np.exp(-2j * np.pi * f * n_.delay2_samples / fs)
        chans.append(n_.gain2 * np.fft.irfft(spec * shift, n=n_total))
    out = []
    for c in chans:
        if n_.snr_db is not None:
            c = c + rng.normal(0.0, n_.level * 10 ** (-n_.snr_db / 20), c.size)
        if n_.clip is not None:
            c = np.clip(c, -n_.clip, n_.clip)
        out.append(c + n_.dc_offset)
    return make_recording(np.column_stack(out), fs, path=path, subtype="FLOAT")
