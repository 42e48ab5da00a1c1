"""Lobes: semi-discretization time, band time, and the Machine view's redraw after a slider move.

* SDM: a 2-direction tool point with 3 modes each (near 3, 4.3 and 6 kHz), 4 teeth,
  Ø20 mm, a/D = 0.05 down-milling, 500–24,000 rpm on a 10 rpm grid
  (:func:`taptune.machine.stability_lobes` with ``method="sdm"``, the modes given), then
  ``method="auto"`` (the SDM within its time budget, the zero-order lobes below).
* Band: 64 sampled tool points (±2 % on the modal frequencies) → safe depth per speed and
  safe pockets, from the central lobes (:func:`taptune.machine.band.lobe_band`).
* Machine view: one stick-out move of the view's preview (FRF + zero-order lobes +
  redraw), as ``benchmarks/bench_gui_machine.py`` times it; the SDM and the band follow
  in a worker.

    OPENBLAS_NUM_THREADS=1 QT_QPA_PLATFORM=offscreen nice -n 10 python benchmarks/bench_lobes.py [--repeat 3]

CPU seconds (this process and its worker processes) and wall seconds; the load average is
printed. The SDM splits the speeds into 2 ranges of about equal time, each computed in a forked process (from the main thread).
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("QT_QPA_PLATFORM", "offscreen")
REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))


def _cpu() -> float:
    """CPU seconds of this process and of its finished children (the SDM's worker processes)."""
    import resource

    kids = resource.getrusage(resource.RUSAGE_CHILDREN)
    return time.process_time() + kids.ru_utime + kids.ru_stime


def timed(fn, repeat: int):
    best_cpu, best_wall, out = float("inf"), float("inf"), None
    for _ in range(repeat):
        c0, w0 = _cpu(), time.perf_counter()
        out = fn()
        best_cpu, best_wall = min(best_cpu, _cpu() - c0), min(best_wall, time.perf_counter() - w0)
    return best_cpu, best_wall, out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=1, help="runs of each (the fastest is printed)")
    parser.add_argument("--no-gui", action="store_true", help="skip the Machine view")
    args = parser.parse_args()

    import numpy as np

    from taptune.machine import stability_lobes
    from taptune.machine.band import extended_grid, lobe_band, scale_samples
    from taptune.machine.simulate import ModalSet

    print(f"load average {os.getloadavg()[0]:.1f} on {os.cpu_count()} cores")
    x = ModalSet([2900.0, 4300.0, 6100.0], [0.012, 0.02, 0.03], [2.0e7, 6.0e7, 9.0e7])
    y = ModalSet([2880.0, 4350.0, 6000.0], [0.012, 0.02, 0.03], [1.8e7, 6.5e7, 9.0e7])
    f = np.arange(200.0, 9000.0, 2.0)
    cut = dict(teeth=4, ktc=902e6, krc=243e6, diameter=20e-3, ae=1e-3, milling="down")
    rpm = np.arange(500.0, 24000.0 + 1, 10.0)
    scales = scale_samples(0.02)
    ext, inner = extended_grid(rpm, scales)
    cpu, wall, lobes = timed(lambda: stability_lobes(f, x.frf(f), y.frf(f), rpm=ext, method="sdm", modes=(x, y),
                                                     **cut), args.repeat)
    print(f"SDM, 3+3 modes, {ext.size} speeds {ext[0]:g}–{ext[-1]:g} rpm: {cpu:.2f} s CPU, {wall:.2f} s wall "
          f"(method {lobes.method}; {len(lobes.warnings)} warning(s){': ' + lobes.warnings[0] if lobes.warnings else ''})")
    cpu_a, wall_a, auto = timed(lambda: stability_lobes(f, x.frf(f), y.frf(f), rpm=ext, method="auto", modes=(x, y),
                                                        **cut), args.repeat)
    print(f"auto (SDM within its time budget), same grid: {cpu_a:.2f} s CPU, {wall_a:.2f} s wall"
          f"{': ' + auto.warnings[-1] if auto.warnings else ''}")
    cpu, wall, band = timed(lambda: lobe_band(ext, lobes.a_lim, inner, scales, 0.9), args.repeat)
    print(f"band, {band.samples} sampled tool points, {rpm.size} speeds: {cpu:.3f} s CPU, {wall:.3f} s wall; "
          f"{len(band.safe_pockets)} safe pockets")
    cpu, wall, zoa = timed(lambda: stability_lobes(f, x.frf(f), y.frf(f), rpm=rpm, method="zoa", **cut), args.repeat)
    print(f"ZOA preview, same grid: {cpu:.2f} s CPU, {wall:.2f} s wall")
    if not args.no_gui:
        import subprocess

        out = subprocess.run([sys.executable, str(REPO / "benchmarks" / "bench_gui_machine.py"), "--moves", "5"],
                             capture_output=True, text=True, check=False)
        print("Machine view, one slider move (preview):")
        print(out.stdout.rstrip() or out.stderr.rstrip())


if __name__ == "__main__":
    main()
