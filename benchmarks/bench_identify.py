"""Wall time and evaluations of one identification, and prediction accuracy where truth is known.

Runs ``identify`` (analysis + evaluator build + GA islands + polishes + full-model check)
on the bundled example recordings and, when ``../shared/cases-dev`` is present, on the
development cases, then predicts their other stick-outs and compares with the truth.

Run: ``python benchmarks/bench_identify.py [--jobs N] [--seed N] [--repeat N]``.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

import numpy as np  # noqa: E402

from taptune.identify import IdentifyOptions, predict  # noqa: E402
from taptune.identify.pipeline import identify_recordings  # noqa: E402
from taptune.io.assembly import load_assembly  # noqa: E402
from taptune.io.audio import read_audio  # noqa: E402


def cases():
    """(name, wav, assembly, {stickout_mm: (truth f1-f3, assembly file or None)})."""
    demo = json.loads((REPO / "recordings" / "demo.json").read_text())
    for c in demo["cases"]:
        truth = json.loads((REPO / "recordings" / c["truth"]).read_text())["bending_hz_by_stickout"]
        yield (c["name"], REPO / "recordings" / c["recording"], REPO / "recordings" / c["assembly"],
               {float(s): (truth[f"{s:g}"], None) for s in c["predict_stickouts_mm"]})
    dev = REPO.parent / "shared" / "cases-dev"
    for d in sorted(dev.glob("d*")) if dev.is_dir() else []:
        truth = json.loads((d / "truth.json").read_text())
        other = {float(k): (v["bending_hz"], d / v["assembly_file"]) for k, v in truth["other_stickouts"].items()}
        yield (f"dev {d.name}", d / "tap.wav", d / "assembly.toml", other)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--jobs", type=int, default=None)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--repeat", type=int, default=1)
    args = ap.parse_args()
    print(f"{'case':16s} {'wall [s]':>8s} {'evals':>6s} {'fit err max [%]':>15s} {'pred err [%] f1 f2 f3 per stick-out':>40s} {'inside ±':>8s}")
    walls, errors, inside = [], [], []
    for name, wav, toml, other in cases():
        asm = load_assembly(toml)
        rec = read_audio(wav)
        times = []
        for _ in range(args.repeat):
            t0 = time.perf_counter()
            analyses, result = identify_recordings([rec], [asm], IdentifyOptions(seed=args.seed, jobs=args.jobs))
            times.append(time.perf_counter() - t0)
        walls.append(min(times))
        meas = np.array([np.nan if f is None else f for f in result.bending_measured_hz[0]])
        fit_err = np.nanmax(np.abs(np.array(result.bending_model_hz[0]) / meas - 1)) * 100
        texts = []
        for so, (truth, path) in sorted(other.items()):
            target = load_assembly(path) if path else asm.with_stickout(so * 1e-3)
            p = predict(result.param_sets, target)
            e = (np.array(p.bending_hz) / np.array(truth) - 1) * 100
            errors.extend(np.abs(e))
            inside.extend(np.abs(np.array(p.bending_hz) - truth) <= np.array(p.bending_hz_spread))
            texts.append(" ".join(f"{x:+.2f}" for x in e))
        print(f"{name:16s} {walls[-1]:8.2f} {result.evaluations:6d} {fit_err:15.3f} {' | '.join(texts):>40s} "
              f"{np.mean(inside[-3 * len(other):]):8.0%}")
    errors = np.array(errors)
    print(f"\nidentification wall time: median {np.median(walls):.2f} s, max {max(walls):.2f} s "
          f"(jobs={args.jobs or 'all cores'})")
    print(f"prediction error over {len(errors)} frequencies: median {np.median(errors):.3f} %, max {errors.max():.3f} %; "
          f"truth inside the reported ± band: {np.mean(inside):.0%}")


if __name__ == "__main__":
    main()
