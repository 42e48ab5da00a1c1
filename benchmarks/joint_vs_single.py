"""How much does a joint fit of several recordings narrow the prediction at a new stick-out?

One holder (recordings/er32_d16: the reference assembly, assets/er32_hsk63_d16.toml, with known
true parameters), synthetic tap recordings at two or three stick-outs (model + workshop
nuisances, :mod:`taptune.synthetic`). Each recording is identified alone, then all of
them jointly; every result predicts f1–f3 at a stick-out none of them was recorded at.
The table gives the prediction, its ± spread (near-optimal set, docs/physics.md §5) and
the error against the truth, per mode.

    OPENBLAS_NUM_THREADS=1 python benchmarks/joint_vs_single.py [--recorded 48.5 58.5] [--target 68.5]
        [--seeds 0 1] [--population 64 --generations 90]

Timings depend on what else the machine runs; the spreads and errors do not (fixed seeds).
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
import time
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

import numpy as np  # noqa: E402

REPO = Path(__file__).resolve().parents[1]
CASE = REPO / "recordings" / "er32_d16.toml"
TRUTH = REPO / "recordings" / "er32_d16.truth.json"


def true_params():
    import json

    from taptune.model.params import HolderParams

    return HolderParams.from_dict(json.loads(TRUTH.read_text())["true_params"])


def recordings_at(stickouts_mm, params, folder: Path, noise_seed: int):
    """One synthetic recording per stick-out (default nuisances of taptune.synthetic at 96 kHz)."""
    from taptune.io.assembly import load_assembly
    from taptune.io.audio import read_audio
    from taptune.synthetic import write_tap_recording

    base = load_assembly(CASE)
    assemblies, recordings = [], []
    for k, s in enumerate(stickouts_mm):
        asm = base.with_stickout(s * 1e-3)
        path = folder / f"er32_{s:g}mm.wav"
        write_tap_recording(path, asm, params, seed=noise_seed + k, sample_rate=96000)
        assemblies.append(asm)
        recordings.append(read_audio(path))
    return recordings, assemblies


def fit_and_predict(recordings, assemblies, target, options):
    """(prediction at ``target``, seconds) of a fit of these recordings."""
    from taptune.identify import predict
    from taptune.identify.pipeline import identify_recordings

    t0 = time.perf_counter()
    _, result = identify_recordings(recordings, assemblies, options)
    return predict(result.param_sets, target), time.perf_counter() - t0, result


def main(argv=None) -> int:
    from dataclasses import replace

    from taptune.identify import GAOptions, IdentifyOptions, predict
    from taptune.io.assembly import load_assembly

    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--recorded", type=float, nargs="+", default=[48.5, 58.5], help="recorded stick-outs [mm]")
    ap.add_argument("--target", type=float, default=68.5, help="stick-out to predict [mm]")
    ap.add_argument("--seeds", type=int, nargs="+", default=[0], help="optimiser seeds (one table row block each)")
    ap.add_argument("--population", type=int, default=GAOptions().population)
    ap.add_argument("--generations", type=int, default=GAOptions().generations)
    ap.add_argument("--jobs", type=int, default=None, help="processes per identification")
    args = ap.parse_args(argv)

    params = true_params()
    target = load_assembly(CASE).with_stickout(args.target * 1e-3)
    truth = np.array(predict([params], target).bending_hz)
    print(f"holder er32_d16 (true parameters from {TRUTH.name}); recorded at {args.recorded} mm; "
          f"predicted at {args.target:g} mm")
    print(f"truth at {args.target:g} mm: f1–f3 = {', '.join(f'{f:.1f}' for f in truth)} Hz\n")
    header = (f"{'seed':>4}  {'fit':<22} {'f1 ± spread [Hz]':>18} {'f2 ± spread [Hz]':>18} {'f3 ± spread [Hz]':>18}"
              f"  {'err f1/f2/f3 [%]':>20}  {'spread f1/f2/f3 [%]':>21}  {'s':>5}")
    print(header)
    print("-" * len(header))
    summary = {}
    with tempfile.TemporaryDirectory() as tmp:
        recordings, assemblies = recordings_at(args.recorded, params, Path(tmp), noise_seed=100)
        for seed in args.seeds:
            options = IdentifyOptions(seed=seed, jobs=args.jobs,
                                      ga=replace(GAOptions(), population=args.population, generations=args.generations))
            fits = [(f"single {s:g} mm", [r], [a]) for s, r, a in zip(args.recorded, recordings, assemblies)]
            fits.append(("joint " + "+".join(f"{s:g}" for s in args.recorded), recordings, assemblies))
            for label, recs, asms in fits:
                pred, seconds, _ = fit_and_predict(recs, asms, target, options)
                f, spread = np.array(pred.bending_hz), np.array(pred.bending_hz_spread)
                err = 100 * (f / truth - 1)
                rel_spread = 100 * spread / truth
                summary.setdefault(label.split()[0], []).append((np.abs(err), rel_spread))
                cells = "".join(f"{fi:>11.1f} ± {si:<5.1f}" for fi, si in zip(f, spread))
                print(f"{seed:>4}  {label:<22} {cells}  {'/'.join(f'{e:+.2f}' for e in err):>20}  "
                      f"{'/'.join(f'{s:.2f}' for s in rel_spread):>21}  {seconds:5.0f}")
    print("\nmean over seeds (and single recordings): |error| and ± spread in % of the truth, f1/f2/f3")
    for kind, values in summary.items():
        err = np.mean([v[0] for v in values], axis=0)
        spread = np.mean([v[1] for v in values], axis=0)
        print(f"  {kind:<7} |error| {'/'.join(f'{e:.2f}' for e in err)}   spread {'/'.join(f'{s:.2f}' for s in spread)}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
