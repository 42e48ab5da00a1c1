"""Speed of the fast reduced evaluator against the full converged model, one core.

Run: ``OPENBLAS_NUM_THREADS=1 python benchmarks/bench_model.py [--repeat N] [--count N]``.
On the reference assembly (assets/er32_hsk63_d16.toml) prints:

* the build time of :class:`~taptune.model.reduced.FastEvaluator` (full model included);
* ``N evaluations/s`` of what the optimiser needs per candidate (f1–f3, ζ1–ζ3 and the
  tip receptance on a 201-point, 1 Hz window), one call per candidate, over random
  points of the search space (wall clock, and per CPU-second);
* the same through ``evaluate_many`` in batches of 48 (a GA generation), timed
  interleaved with the single calls in the same runs, and the ratio per CPU-second;
* the time of one full converged solution (modes + tip receptance on 201 points).

Times are medians of ``--repeat`` runs (the machine may be shared: the best run is
printed too).
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

import numpy as np  # noqa: E402
from threadpoolctl import threadpool_limits  # noqa: E402

from taptune.io.assembly import load_assembly  # noqa: E402
from taptune.model import build_model, solve_modes, tip_receptance  # noqa: E402
from taptune.model.params import NOMINAL, P_LOWER, P_UPPER, from_p  # noqa: E402
from taptune.model.reduced import FastEvaluator  # noqa: E402


def timed(fn, repeat: int) -> np.ndarray:
    """Wall times [s] of ``repeat`` calls of fn."""
    out = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        out.append(time.perf_counter() - t0)
    return np.array(out)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=7, help="runs per timing (median reported)")
    parser.add_argument("--count", type=int, default=500, help="candidates per throughput run")
    args = parser.parse_args()

    assembly = load_assembly(REPO / "assets" / "er32_hsk63_d16.toml")
    rng = np.random.default_rng(0)
    points = P_LOWER + rng.random((args.count, 7)) * (P_UPPER - P_LOWER)
    window = 4797.0 + np.arange(-100.0, 101.0)

    # Warm up imports and caches so that the first timed build is not an import.
    FastEvaluator(assembly)

    c0 = time.process_time()
    build = timed(lambda: FastEvaluator(assembly), args.repeat)
    build_cpu = (time.process_time() - c0) / args.repeat
    ev = FastEvaluator(assembly)
    print(f"reduced model: {ev.size} DOFs (component basis {ev.component_size}, full model {ev.fe.n_dofs})")
    print(f"build of the evaluator (full model included): median {1e3 * np.median(build):.0f} ms, "
          f"best {1e3 * build.min():.0f} ms, {1e3 * build_cpu:.0f} ms CPU")

    def single():
        for p in points:
            ev.evaluate(p, window)

    def batched():
        for k in range(0, len(points), 48):
            ev.evaluate_many(points[k : k + 48], window)

    # Single and batched runs alternate, so that a change of the machine's load hits both.
    times = {single: ([], []), batched: ([], [])}
    for _ in range(args.repeat):
        for fn, (wall, cpu) in times.items():
            t0, c0 = time.perf_counter(), time.process_time()
            fn()
            wall.append(time.perf_counter() - t0)
            cpu.append(time.process_time() - c0)
    wall, cpu = (np.array(x) for x in times[single])
    print(f"{args.count / np.median(wall):.0f} evaluations/s "
          f"(f1–f3, ζ1–ζ3 and H on 201 points per candidate; wall median; "
          f"best run {args.count / wall.min():.0f}; "
          f"{args.count / np.median(cpu):.0f} per CPU-second, which a busy machine affects less)")
    b_wall, b_cpu = (np.array(x) for x in times[batched])
    print(f"{args.count / np.median(b_wall):.0f} evaluations/s batched (evaluate_many, 48 candidates per call "
          f"as a GA generation; best run {args.count / b_wall.min():.0f}; "
          f"{args.count / np.median(b_cpu):.0f} per CPU-second: {np.median(cpu) / np.median(b_cpu):.2f}× the single calls)")
    iterations = np.array([ev.evaluate(p, window).iterations for p in points])
    print(f"inverse iterations per candidate: mean {iterations.mean():.2f}, max {iterations.max()}, "
          f"dense fallbacks {np.count_nonzero(iterations == 0)}")

    fe = build_model(assembly)
    modes = solve_modes(fe, NOMINAL, n_modes=3)
    full_window = modes.frequency_hz[0] + np.arange(-100.0, 101.0)

    def full():
        solve_modes(fe, NOMINAL, n_modes=3)
        tip_receptance(fe, NOMINAL, full_window)

    full_t = timed(full, args.repeat)
    print(f"full converged solution ({fe.n_dofs} DOFs, modes + tip receptance on 201 points): "
          f"median {1e3 * np.median(full_t):.1f} ms, best {1e3 * full_t.min():.1f} ms")
    params = from_p(points[0])
    direct_t = timed(lambda: tip_receptance(fe, params, full_window, method="direct"), max(1, args.repeat // 2))
    print(f"full direct receptance on 201 points: median {1e3 * np.median(direct_t):.1f} ms")


if __name__ == "__main__":
    with threadpool_limits(limits=1):
        main()
