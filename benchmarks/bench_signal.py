"""Time to analyse a 3 s, 96 kHz stereo tap recording (target: well under 0.2 s).

Run: ``OPENBLAS_NUM_THREADS=1 python benchmarks/bench_signal.py [--repeat N]``. Prints the
median and best wall time of ``analyse_recording`` (5 taps, three bending modes, an
interface mode, an axial mode, hum, noise, reflections), with and without model guidance,
and the time of its stages. CPU time is printed too: on a shared machine the wall time
also measures the neighbours.
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from dataclasses import replace
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

import numpy as np  # noqa: E402

from taptune.signal.analysis import SpectrumOptions, analyse_recording, find_spectral_peaks  # noqa: E402
from taptune.signal.synth import Nuisances, modal_receptance, synthesize_recording, tap_grid  # noqa: E402

BENDING = ((3520.0, 0.004, 1.0), (10950.0, 0.002, 0.6), (15300.0, 0.003, 0.8))


def recording():
    nu = Nuisances(sample_rate=96000, duration_s=3.0, channels=2, tap_times_s=(0.2, 0.75, 1.3, 1.85, 2.4),
                   tap_strengths=(1.0, 0.7, 0.85, 0.6, 0.9), snr_db=45.0, reflections=((0.7e-3, 0.25), (8e-3, 0.05)))
    grid = tap_grid(nu.sample_rate)
    h = modal_receptance(grid, [(f, z, a * (2 * np.pi * f) ** 2 * 2 * z / f) for f, z, a in BENDING])
    return synthesize_recording(grid, h, nu, np.random.default_rng(0),
                                extra_modes=((9710.0, 0.0016, 2.0), (16650.0, 0.0025, 0.6)))


def timed(fn, repeat):
    """Median and best wall time, and median CPU time of this process [s]."""
    wall, cpu = [], []
    for _ in range(repeat):
        t0, c0 = time.perf_counter(), time.process_time()
        fn()
        wall.append(time.perf_counter() - t0)
        cpu.append(time.process_time() - c0)
    return float(np.median(wall)), float(np.min(wall)), float(np.median(cpu))


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=15)
    args = ap.parse_args(argv)
    rec = recording()
    expected = np.array([3700.0, 11100.0, 16000.0])
    bounds = np.column_stack([expected * 0.3, expected * 1.1])
    analyse_recording(rec)  # warm-up (imports, FFT plans)
    print(f"recording: {rec.duration_s:.1f} s, {rec.sample_rate} Hz, {rec.channels} channels, 5 taps")
    for label, fn in [
        ("analyse_recording (no model)", lambda: analyse_recording(rec)),
        ("analyse_recording (model guidance)", lambda: analyse_recording(rec, expected_hz=expected, bounds_hz=bounds)),
        ("  taps + spectra + peak picking", lambda: find_spectral_peaks(rec, SpectrumOptions())),
        ("  with 1 Hz bins -> 0.5 Hz bins", lambda: analyse_recording(rec, options=replace(SpectrumOptions(), max_bin_hz=0.5))),
    ]:
        med, best, cpu = timed(fn, args.repeat)
        print(f"{label:38s} median {1000 * med:7.1f} ms   best {1000 * best:7.1f} ms   cpu {1000 * cpu:7.1f} ms")
    a = analyse_recording(rec, expected_hz=expected, bounds_hz=bounds)
    errs = ", ".join(f"f{p.mode} {100 * (p.hz / BENDING[p.mode - 1][0] - 1):+.4f} %" for p in a.bending_peaks)
    print(f"bending errors: {errs}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
