"""Tap twice: does a joint identification from two stick-outs meet what one tap cannot?

For every holder of a realism split (outside the model family, :mod:`benchmarks.realism.corpus`)
the holder is tapped at its recorded stick-out and again at its first query stick-out
(clamped anew, the stick-out read off the ruler again: :func:`~benchmarks.realism.corpus.elsewhere`),
the two taps are identified jointly (``identify_recordings`` with both, as ``taptune identify
a.wav b.wav`` does) and the holder predicts its *other* query stick-out, the one no tap
saw, as the library predicts it (both identified assemblies, the modes either tap
measured). The single-tap predictions of the same query come from the stored results of
``benchmarks.realism.run`` for comparison (same holders, same query).

Each record also keeps ``rows``: the band's set and geometry parts of every prediction
without the model-form term, on which ``benchmarks/calibrate_bands.py --joint`` calibrates
``bands.MODEL_FORM_JOINT`` and measures it. The stored ``two_taps_*.json`` were made
before that constant existed: their ``predictions`` carry the one-tap coefficients (the
"before" of that calibration; ``--joint`` prints the "after").

Each record keeps the joint fit's ``identification`` (measured and model frequencies per
tap, ``relative_floor``): how well one parameter set meets both taps, the evidence a second
tap adds. Measured 2026-11-27 (``two_taps_infamily_{calibration,validation}.json``: 24
holders the model describes, stick-outs stated to ±0.05 mm, ``--split infamily
--stickout-error 0.05``, indices 12–23 / 0–11; ``two_taps_<tier>_<split>_12.json``: the
first 12 holders of each tier and split; ``calibrate_bands.py --joint --evidence``): none
of the 48 holders outside the family agreed (5+ of 6 frequencies heard, all met within
0.1 %), 13 of 24 in the family did (errors ≤ 0.11 %). With all six frequencies heard, the
joint fit met holders the model describes to
0.008–0.064 % (one at 0.79 %: a mislabelled peak) and predicted 10 mm further within
0.09 %; holders outside the family to 0.31–3.6 % (all six heard; 0.13 % and more with
five, 11 holders of 24), and with two or three frequencies the joint fit meets them either
way (0.004–3.0 %, errors up to 27 %). One tap cannot show this (its three
frequencies are met by five parameters whatever the holder: ``calibrate_bands.py
--evidence``). With the stick-outs read to ±0.05 mm (``--stickout-error 0.05``), 6 of 30
holders outside the family agreed (calibration split), within 0.30 % 10 mm further:
``bands.MODEL_FORM_AGREED``; the predictions pass ``agreed`` (``bands.taps_agree``).

Run (≈ 3 min wall for 48 holders on 2 cores)::

    python -m benchmarks.realism.two_taps --tier issue --split validation --n 48 --jobs 2 \
        --single benchmarks/realism/results_issue_validation*.json --out two_taps_issue.json
"""

from __future__ import annotations

import argparse
import glob
import json
import os
import sys
import time
from concurrent.futures import ProcessPoolExecutor
from dataclasses import replace

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np  # noqa: E402

from benchmarks.realism.corpus import RULER_MM, TIERS, elsewhere, make_case  # noqa: E402
from benchmarks.realism.run import _stats, predictions  # noqa: E402


def run_case(split: str, index: int, tier: str, seed: int = 0, stickout_error_mm: float = RULER_MM) -> dict:
    """Identify one holder from two taps and predict its second query; a JSON-ready record
    (stick-outs read to ``stickout_error_mm``, as :func:`~benchmarks.realism.corpus.make_case`)."""
    from benchmarks.realism.audio import record
    from taptune.errors import TaptuneError
    from taptune.identify import IdentifyOptions, predict
    from taptune.identify.bands import measured_modes, taps_agree
    from taptune.identify.pipeline import identify_recordings

    case = make_case(split, index, tier=tier, stickout_error_mm=stickout_error_mm)
    out = {"name": case.name, "kinds": list(case.kinds)}
    if len(case.queries) < 2:
        return {**out, "failed": "fewer than two query stick-outs"}
    first, other = case.queries
    t0 = time.process_time()
    try:
        second = elsewhere(case, first.stickout_mm)  # the true tool may not fit the bore there
        _, result = identify_recordings([record(case), record(second)], [case.described, second.described],
                                        IdentifyOptions(seed=seed, jobs=1))
    except TaptuneError as err:
        return {**out, "failed": str(err)}
    out["cpu_s"] = round(time.process_time() - t0, 3)
    # What the joint fit shows: how well one parameter set meets both taps' peaks.
    out["identification"] = {"bending_measured_hz": [list(m) for m in result.bending_measured_hz],
                             "bending_model_hz": [list(m) for m in result.bending_model_hz],
                             "relative_floor": result.relative_floor}
    measured = measured_modes(result.bending_measured_hz)
    # Per mode: measured in either tap (the realism run's "measured" flag, for one tap).
    either = [next((m[n] for m in result.bending_measured_hz if m[n] is not None), None) for n in range(3)]
    identified = [case.described, second.described]
    agreed = taps_agree(result.bending_measured_hz, result.relative_floor, [a.stickout for a in identified],
                        [a.tolerances.stickout for a in identified])
    out["predictions"] = predictions(replace(case, queries=(other,)), lambda asm: predict(
        result.param_sets, asm, relative_floor=result.relative_floor, identified=identified,
        measured_modes=measured, agreed=agreed), either)
    # The band's parts without the model-form term, for calibrating it on joint identifications
    # (benchmarks/calibrate_bands.py: the smallest c that covers each error).
    bare = predict(result.param_sets, case.described_at(other.stickout_mm), relative_floor=result.relative_floor,
                   identified=identified, measured_modes=measured, model_form={g: 0.0 for g in ("pinned", "free", "unknown")})
    b = bare.band
    out["rows"] = [{"case": case.name, "tier": tier, "split": split, "mode": n + 1, "f": bare.bending_hz[n],
                    "err": abs(bare.bending_hz[n] - other.truth.bending_hz[n]), "set": b.set_hz[n],
                    "geom": b.geometry_hz[n], "delta": b.delta_stickout_mm, "group": b.model_form_groups[n],
                    "measured": either[n] is not None, "recordings": 2, "floor": result.relative_floor,
                    "n_measured": int(sum(measured))} for n in range(3)]
    return out


def single_predictions(paths, names_stickouts) -> list[dict]:
    """The one-tap predictions of the same holders at the same query stick-outs (stored results)."""
    out = []
    for p in paths:
        for rec in json.load(open(p, encoding="utf-8"))["cases"]:
            so = names_stickouts.get(rec["name"])
            if so is not None:
                out += [q for q in rec.get("predictions", []) if abs(q["stickout_mm"] - so) < 1e-6]
    return out


def line(title: str, s: dict) -> str:
    return (f"{title:28s} n {s['n']:3d}  |err| median {s['error_median_pct']:.3f} %  p90 {s['error_p90_pct']:.2f} %  "
            f"max {s['error_max_pct']:.2f} %  covered {s['coverage']:.1%}  ± median {s['half_width_median_pct']:.2f} %")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--split", default="validation", choices=("calibration", "validation", "infamily"))
    ap.add_argument("--tier", default="harsh", choices=TIERS)
    ap.add_argument("--n", type=int, default=24)
    ap.add_argument("--start", type=int, default=0)
    ap.add_argument("--jobs", type=int, default=1)
    ap.add_argument("--single", nargs="*", default=[], help="results JSONs of the one-tap run of the same cases")
    ap.add_argument("--out", help="write the records and the summary as JSON")
    ap.add_argument("--stickout-error", type=float, default=RULER_MM, metavar="MM",
                    help=f"largest stick-out reading error [mm], stated in the assembly (default {RULER_MM}: a ruler)")
    args = ap.parse_args(argv)
    t0 = time.time()
    idx = range(args.start, args.start + args.n)
    with ProcessPoolExecutor(max(args.jobs, 1)) as pool:
        records = list(pool.map(run_case, [args.split] * args.n, idx, [args.tier] * args.n, [0] * args.n,
                                [args.stickout_error] * args.n))
    ok = [r for r in records if "failed" not in r]
    two = [p for r in ok for p in r["predictions"]]
    summary = {"two_taps": _stats(two), "two_taps_measured": _stats([p for p in two if p["measured"]]),
               "failed": [r["name"] for r in records if "failed" in r]}
    print(f"{args.tier} tier, {args.split}, {len(ok)} holders: the query no tap saw")
    print(line("two taps, all modes", summary["two_taps"]))
    print(line("two taps, measured modes", summary["two_taps_measured"]))
    paths = [p for pattern in args.single for p in sorted(glob.glob(pattern))]
    if paths:
        one = single_predictions(paths, {r["name"]: r["predictions"][0]["stickout_mm"] for r in ok})
        summary["one_tap"] = _stats(one)
        summary["one_tap_measured"] = _stats([p for p in one if p["measured"]])
        print(line("one tap, all modes", summary["one_tap"]))
        print(line("one tap, measured modes", summary["one_tap_measured"]))
    print(f"wall {time.time() - t0:.0f} s, load {os.getloadavg()[0]:.1f}")
    if args.out:
        from taptune.io.atomic import atomic_write_bytes

        atomic_write_bytes(args.out, json.dumps({"meta": vars(args), "summary": summary, "cases": records},
                                                indent=1).encode("utf-8"))
    return 0


if __name__ == "__main__":
    sys.exit(main())
