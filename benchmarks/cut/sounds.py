"""Sounds of milling cuts for the tests and the benchmarks of ``taptune cut``.

A cut's vibration (tool-point displacement x, y [m] and cutting forces [N] on a time
grid: from the milling simulation with the regenerative delay, or a parametric one made
of lines) is turned into what a phone at the machine door hears:

- the vibration's acceleration (a radiating tool and spindle) and the cutting force
  (the workpiece and table radiate it), each with a random gain;
- spindle-rotation harmonics (run-out, unbalance), machine fans and spindle-bearing tones
  that also sound at idle, a mains hum;
- broadband coolant and chip noise during the cut, a quieter floor at idle;
- idle (spindle running, in air) before and after the cut, with the tool's entry and exit;
- optionally a phone codec (AAC through PyAV) at the end.

Everything is seeded; :class:`CutTruth` keeps what was put in (the chatter frequency,
its level above the forced vibration, the speed really turned).
"""

from __future__ import annotations

import io
from dataclasses import dataclass

import numpy as np

from taptune.io.audio import Recording

FS = 44100


@dataclass(frozen=True)
class CutTruth:
    """What a synthetic cut really is."""

    rpm: float  # the speed really turned
    commanded_rpm: float
    teeth: int
    chatter_hz: float | None  # the chatter frequency in the vibration (None: stable)
    chatter_db: float | None  # its level above the strongest forced (tooth-passing) line of the vibration [dB]
    kind: str  # "stable", "chatter", "growing", ...


def lines_vibration(t, rpm: float, teeth: int, *, chatter_hz: float | None = None, chatter_db: float = 20.0,
                    growth_s: float | None = None, harmonics: int = 8, family_db: float = -15.0, rng=None):
    """A parametric cut's vibration [arbitrary units] on ``t`` [s from the cut's start].

    Tooth-passing harmonics h·f_tp falling ~6 dB per harmonic with random phases; a chatter
    line at ``chatter_hz`` ``chatter_db`` above the first harmonic, with its family
    f_c ± f_tp, f_c ± 2 f_tp at ``family_db`` and below; ``growth_s`` lets the chatter grow
    from nothing (time constant [s]) and saturate.
    """
    rng = np.random.default_rng(rng)
    f_tp = rpm * teeth / 60.0
    x = np.zeros_like(t)
    for h in range(1, harmonics + 1):
        x += 10 ** (-6 * (h - 1) / 20) * 10 ** (rng.normal(0, 3) / 20) * np.cos(2 * np.pi * h * f_tp * t + rng.uniform(0, 2 * np.pi))
    if chatter_hz is not None:
        env = np.ones_like(t)
        if growth_s is not None:
            # A logistic growth: small at the start of the cut, saturated by its middle.
            t_mid = 0.4 * t[-1]
            env = 1.0 / (1.0 + np.exp(-(t - t_mid) / growth_s))
        a = 10 ** (chatter_db / 20)
        x += a * env * np.cos(2 * np.pi * chatter_hz * t + rng.uniform(0, 2 * np.pi))
        for k, lv in ((1, family_db), (-1, family_db - 3), (2, family_db - 8), (-2, family_db - 10)):
            fk = chatter_hz + k * f_tp
            if fk > 20:
                x += a * env * 10 ** (lv / 20) * np.cos(2 * np.pi * fk * t + rng.uniform(0, 2 * np.pi))
    return x


def _coloured_noise(n: int, rng, fs: float, corner_hz: float = 2000.0) -> np.ndarray:
    """Broadband noise with a gentle roll-off above ``corner_hz`` (coolant, chips)."""
    white = rng.standard_normal(n)
    spec = np.fft.rfft(white)
    f = np.fft.rfftfreq(n, 1 / fs)
    spec /= np.sqrt(1 + (f / corner_hz) ** 2)
    return np.fft.irfft(spec, n)


def shop_sound(cut_signal, rpm: float, teeth: int, *, fs: int = FS, idle_before_s: float = 1.0,
               idle_after_s: float = 0.8, noise_db: float = -30.0, fans: int = 2, hum_hz: float | None = 50.0,
               runout_db: float = -20.0, codec: str | None = None, level: float = 0.3, rng=None,
               ramp_s: float = 0.15, normalise: bool = True) -> np.ndarray:
    """The phone's recording of a cut whose sound during the cut is ``cut_signal`` (at ``fs``).

    ``noise_db`` is the coolant/chip noise level relative to the cut signal's RMS (over
    the whole band; relative to 1 with ``normalise=False``, when the cut signal comes in
    its own units), ``runout_db`` the spindle-rotation harmonics relative to it; fans and
    bearing tones (at fixed frequencies off the spindle harmonics) and the hum sound all
    the time. Entry and exit are ``ramp_s`` ramps of the cut's amplitude. Returns mono
    float samples peaking at ``level``.
    """
    rng = np.random.default_rng(rng)
    s = np.asarray(cut_signal, float)
    if normalise:
        s = s / (np.sqrt(np.mean(s**2)) + 1e-30)
    n_cut, n0, n1 = len(s), int(idle_before_s * fs), int(idle_after_s * fs)
    n = n0 + n_cut + n1
    t = np.arange(n) / fs
    env = np.zeros(n)
    env[n0:n0 + n_cut] = 1.0
    r = max(int(ramp_s * fs), 1)
    env[n0:n0 + r] = np.linspace(0, 1, r)
    env[n0 + n_cut - r:n0 + n_cut] = np.linspace(1, 0, r)
    out = np.zeros(n)
    out[n0:n0 + n_cut] = s
    out *= env
    # The cut's noise (coolant, chips) follows the cut; a quieter floor is always there.
    out += 10 ** (noise_db / 20) * env * _coloured_noise(n, rng, fs, rng.uniform(1500, 5000))
    out += 10 ** ((noise_db - 15) / 20) * _coloured_noise(n, rng, fs, 3000.0)
    f_sp = rpm / 60.0
    for h in range(1, 6):
        out += 10 ** ((runout_db - 4 * (h - 1)) / 20) * np.sqrt(2) * np.cos(2 * np.pi * h * f_sp * t + rng.uniform(0, 6.3))
    for _ in range(fans):
        f_fan = rng.uniform(150, 3000)
        out += 10 ** (rng.uniform(-30, -20) / 20) * np.sqrt(2) * np.cos(2 * np.pi * f_fan * t + rng.uniform(0, 6.3))
    if hum_hz:
        for h, lv in ((1, -26), (2, -34), (3, -30), (5, -40)):
            out += 10 ** (lv / 20) * np.sqrt(2) * np.cos(2 * np.pi * h * hum_hz * t + rng.uniform(0, 6.3))
    out *= level / np.max(np.abs(out))
    if codec:
        out = codec_roundtrip(out, fs, codec)
    return out


def codec_roundtrip(x, fs: int, codec: str = "aac", bit_rate: int = 96_000) -> np.ndarray:
    """``x`` encoded with a phone's codec and decoded again (PyAV, in memory)."""
    import av

    buf = io.BytesIO()
    with av.open(buf, "w", format="mp4" if codec == "aac" else "ogg") as container:
        stream = container.add_stream(codec, rate=fs, layout="mono")
        stream.bit_rate = bit_rate
        frame = av.AudioFrame.from_ndarray(np.asarray(x, np.float32)[None, :], format="flt", layout="mono")
        frame.sample_rate = fs
        for packet in stream.encode(frame):
            container.mux(packet)
        for packet in stream.encode(None):
            container.mux(packet)
    buf.seek(0)
    chunks = []
    with av.open(buf, "r") as container:
        for frame in container.decode(audio=0):
            a = frame.to_ndarray()
            chunks.append(a.reshape(-1) if a.shape[0] == 1 else a.mean(axis=0))
    y = np.concatenate(chunks).astype(float)
    return y[: len(x)] if len(y) >= len(x) else np.pad(y, (0, len(x) - len(y)))


def as_recording(x, fs: int = FS, lossy: bool = False) -> Recording:
    return Recording(np.asarray(x, float)[:, None], fs, "", "aac" if lossy else "FLOAT")


def lines_cut(rpm: float, teeth: int, *, chatter_hz=None, chatter_db=20.0, growth_s=None, seconds=3.0,
              override: float = 1.0, codec=None, seed=0, **shop) -> tuple[Recording, CutTruth]:
    """A parametric cut (lines, see :func:`lines_vibration`) as a recording, and its truth."""
    rng = np.random.default_rng(seed)
    actual = rpm * override
    t = np.arange(int(seconds * FS)) / FS
    vib = lines_vibration(t, actual, teeth, chatter_hz=chatter_hz, chatter_db=chatter_db, growth_s=growth_s, rng=rng)
    x = shop_sound(vib, actual, teeth, codec=codec, rng=rng, **shop)
    kind = "stable" if chatter_hz is None else ("growing" if growth_s else "chatter")
    return as_recording(x, lossy=bool(codec)), CutTruth(actual, rpm, teeth, chatter_hz,
                                                        None if chatter_hz is None else chatter_db, kind)


def vibration_levels(x, fs: float, rpm: float, teeth: int) -> tuple[float | None, float | None]:
    """(chatter frequency [Hz], its level above the strongest tooth-passing line [dB]) of a vibration signal.

    The second half of ``x`` (steady), Hann window; the chatter is the strongest line
    off the spindle harmonics. None, None when ``x`` holds no line off them above the noise.
    """
    y = np.asarray(x, float)[len(x) // 2:]
    y = (y - y.mean()) * np.hanning(len(y))
    spec = np.abs(np.fft.rfft(y, 4 * len(y))) ** 2
    f = np.fft.rfftfreq(4 * len(y), 1 / fs)
    f_sp, f_tp = rpm / 60.0, rpm * teeth / 60.0
    df = f[1] - f[0]
    band = (f > 20) & (f < 10000)
    w = max(6 * fs / len(y), 3 * df)  # main-lobe half-width of the Hann window, padded
    near_sp = np.abs(f - np.round(f / f_sp) * f_sp) <= w
    near_tp = np.abs(f - np.round(f / f_tp) * f_tp) <= w
    forced = spec[band & near_tp & (f > f_tp / 2)].max()
    off = band & ~near_sp
    if not off.any():
        return None, None
    i = np.flatnonzero(off)[np.argmax(spec[off])]
    return float(f[i]), float(10 * np.log10(spec[i] / forced))


def simulate_batch(modes_x, modes_y, *, teeth: int, ktc: float, krc: float, diameter: float, ae: float,
                   milling: str, rpm: float, depths, seconds: float = 1.6, feed_per_tooth: float = 0.06e-3,
                   steps: int = 48, seed: int = 0) -> dict:
    """The milling simulation of cuts at ``rpm`` and each of ``depths`` [m]: the tool's vibration
    (x + 0.7 y [m]) and force (fx + 0.5 fy [N]) at :data:`FS`, and the growth per tooth period
    of the linear delay equation (< 1 stable). Plain arrays, so that a benchmark can keep them."""
    from taptune.machine.simulate import simulate_milling

    # At least 25 steps per period of the fastest mode (a coarser step diverges at large depths).
    f_max = max(max(modes_x.freq_hz), max(modes_y.freq_hz) if modes_y is not None else 0.0)
    steps = max(steps, int(np.ceil(25 * 60.0 / (rpm * teeth) * f_max)))
    common = dict(teeth=teeth, ktc=ktc, krc=krc, diameter=diameter, ae=ae, milling=milling, rpm=rpm,
                  depth=list(depths), fs=FS, feed_per_tooth=feed_per_tooth, steps=steps)
    run = simulate_milling(modes_x, modes_y, duration_s=seconds, rng=np.random.default_rng(seed), contact_loss=True,
                           **common)
    # Without feed: the free vibration alone gives the multiplier (module bench_cut.truly_stable).
    linear = simulate_milling(modes_x, modes_y, duration_s=0.4, rng=np.random.default_rng(seed + 1),
                              contact_loss=False, **(common | {"feed_per_tooth": 0.0}))
    x, y = np.atleast_2d(run.x_m), np.atleast_2d(run.y_m)
    fx, fy = np.atleast_2d(run.fx_n), np.atleast_2d(run.fy_n)
    return {"rpm": rpm, "teeth": teeth, "depths": list(depths), "vibration": x + 0.7 * y, "force": fx + 0.5 * fy,
            "growth": np.atleast_1d(linear.growth).astype(float)}


def render_cuts(batch: dict, *, commanded_rpm: float | None = None, seed: int = 0, codec=None,
                **shop) -> list[tuple[Recording, CutTruth, float]]:
    """Per depth of a :func:`simulate_batch`: (recording, truth, growth). The sound is the tool's
    acceleration and the cutting force, with random gains, in a shop (:func:`shop_sound`); the
    entry transient of the simulation (it starts at full depth) is left out."""
    rng = np.random.default_rng(seed)
    rpm, teeth = batch["rpm"], batch["teeth"]
    out = []
    for vib, force, growth in zip(batch["vibration"], batch["force"], batch["growth"]):
        skip = int(0.1 * FS)
        vib, force = vib[skip:], force[skip:]
        # Each part in units of its robust scale over the steady two thirds (a median, so that
        # a run whose chatter bursts once is not scaled by that burst), bursts clipped at 8×.
        # A part that barely varies stays quiet: the scale is never below 1 % of the static
        # deflection's (for the acceleration: × (2π f_tp)²) or of the mean force. An ideal
        # 4-tooth slot's force is constant; its simulated vibration is arithmetic noise
        # (~1e-21 m, a steady tone), which a scale of its own would blow up into a chatter.
        f_tp = rpm * teeth / 60.0

        def robust(x, floor):
            x = x - x.mean()
            scale = max(1.4826 * np.median(np.abs(x[len(x) // 3:])), 1e-3 * np.std(x), floor) + 1e-30
            return np.clip(x / scale, -8, 8)

        acc = np.gradient(np.gradient(vib)) * FS**2
        g = 10 ** (rng.uniform(-6, 6) / 20)
        sound = robust(acc, 0.01 * (2 * np.pi * f_tp) ** 2 * abs(np.mean(vib))) + g * robust(force, 0.01 * abs(np.mean(force)))
        # A unit cut level (a quiet cut is not turned up to it).
        sound = sound / max(float(np.sqrt(np.mean(sound**2))), 1.0)
        f_c, level = vibration_levels(vib, FS, rpm, teeth)
        chatter = bool(growth > 1.0)
        rec = shop_sound(sound, rpm, teeth, rng=rng, codec=codec, normalise=False, **shop)
        out.append((as_recording(rec, lossy=bool(codec)),
                    CutTruth(rpm, commanded_rpm or rpm, teeth, f_c if chatter else None, level if chatter else None,
                             "chatter" if chatter else "stable"), float(growth)))
    return out


def simulated_cuts(modes_x, modes_y, *, teeth: int, ktc: float, krc: float, diameter: float, ae: float, milling: str,
                   rpm: float, depths, seconds: float = 1.6, feed_per_tooth: float = 0.06e-3, steps: int = 48,
                   seed: int = 0, codec=None, override: float = 1.0, **shop) -> list[tuple[Recording, CutTruth, float]]:
    """Cuts commanded at ``rpm``, turned at ``rpm`` × ``override``, at each of ``depths`` [m]:
    :func:`simulate_batch` then :func:`render_cuts`."""
    batch = simulate_batch(modes_x, modes_y, teeth=teeth, ktc=ktc, krc=krc, diameter=diameter, ae=ae,
                           milling=milling, rpm=rpm * override, depths=depths, seconds=seconds,
                           feed_per_tooth=feed_per_tooth, steps=steps, seed=seed)
    return render_cuts(batch, commanded_rpm=rpm, seed=seed, codec=codec, **shop)
