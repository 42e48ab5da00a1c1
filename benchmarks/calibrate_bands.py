"""Calibrate the model-form term of the prediction bands on the realism corpus, and measure them.

For every case of a split (benchmarks/realism: holders outside the model family, described
as a careful user would): ``benchmarks.realism.run.run_case`` records, analyses, labels
and identifies (one recording); then each query stick-out is predicted again from the
stored near-optimal sets with the band's set and geometry parts alone. The model-form coefficient c_mode of ``c × f × (1 + Δ/10 mm)``
(taptune/identify/bands.py) is the split-conformal quantile, at level ⌈0.9 (n + 1)⌉ / n, of
each prediction's smallest c that covers its error. Measured on another split with the
constants in bands.py: transfer error, coverage and half-width, and the labels
(run.py's judge).

Run (minutes; identifications are cached in --cache):
``python benchmarks/calibrate_bands.py --split calibration --n 24``  (prints c_mode)
``python benchmarks/calibrate_bands.py --split validation --n 24``   (measures)
``python benchmarks/calibrate_bands.py --records benchmarks/realism/baseline_calibration.json``
(the identifications stored by ``python -m benchmarks.realism.run``)
"""

from __future__ import annotations

import argparse
import json
import math
import os
import sys
import tempfile
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

import numpy as np  # noqa: E402

from taptune.identify import bands, predict  # noqa: E402


def records(split: str, n: int, cache: Path) -> list[dict]:
    """benchmarks.realism.run records (identification and labels) of the first n cases, cached."""
    from benchmarks.realism.run import run_case

    out = []
    for i in range(n):
        path = cache / f"{split}-{i:03d}.json"
        if path.exists():
            out.append(json.loads(path.read_text()))
            continue
        rec = run_case(split, i)
        path.write_text(json.dumps(rec))
        out.append(rec)
        print(f"  {rec['name']}: cpu {rec.get('cpu_s', 0):.0f} s", flush=True)
    return out


def band_method(model_form=None, rows_out=None):
    """``band(sets, assembly, record)`` for run.reevaluate: the product's band with these
    model-form coefficients (None: bands.MODEL_FORM); collects per-mode components in rows_out."""
    from benchmarks.realism.corpus import case_of

    def band(sets, asm, rec):
        case = case_of(rec)
        p = predict(sets, asm, relative_floor=rec["identification"]["relative_floor"],
                    identified=[case.described], model_form=model_form)
        if rows_out is not None:
            q = next(q for q in case.queries if abs(q.stickout_mm - asm.stickout * 1e3) < 1e-6)
            b = p.band
            for m, (f, t) in enumerate(zip(p.bending_hz, q.truth.bending_hz)):
                rows_out.append({"mode": m + 1, "f": f, "err": abs(f - t), "set": b.set_hz[m],
                                 "geom": b.geometry_hz[m], "delta": b.delta_stickout_mm})
        return p

    return band


def conformal(rows_, level: float = bands.COVERAGE) -> list[float]:
    """c_mode: the ⌈level (n + 1)⌉-th smallest per-prediction requirement, per mode."""
    out = []
    for m in (1, 2, 3):
        need = []
        for r in rows_:
            if r["mode"] != m:
                continue
            extra = max(r["err"] ** 2 - r["set"] ** 2 - r["geom"] ** 2, 0.0)
            need.append(math.sqrt(extra) / (r["f"] * (1 + r["delta"] / bands.DELTA_REF_MM)))
        need.sort()
        k = min(math.ceil(level * (len(need) + 1)), len(need)) - 1
        out.append(need[k] if need else 0.0)
    return out


def stats(rows_, coefficients) -> str:
    """Transfer error, coverage and half-width of the band with model-form ``coefficients``."""
    err, half, inside = [], [], {1: [], 2: [], 3: []}
    for r in rows_:
        model = coefficients[r["mode"] - 1] * r["f"] * (1 + r["delta"] / bands.DELTA_REF_MM)
        h = float(bands.compose(r["set"], r["geom"], model))
        err.append(r["err"] / r["f"])
        half.append(h / r["f"])
        inside[r["mode"]].append(r["err"] <= h)
    cover = np.mean([v for m in inside.values() for v in m])
    return (f"{len(rows_)} predictions: |error| median {100 * np.median(err):.3f} %, max {100 * np.max(err):.3f} %; "
            f"coverage {cover:.1%} (modes {', '.join(f'{np.mean(v):.0%}' for v in inside.values())}); "
            f"half-width median {100 * np.median(half):.3f} % (p90 {100 * np.quantile(half, 0.9):.3f} %)")


def main() -> None:
    from benchmarks.realism.run import print_summary, reevaluate, summarise

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--split", default="calibration")
    ap.add_argument("--n", type=int, default=24)
    ap.add_argument("--cache", default=str(Path(tempfile.gettempdir()) / "taptune-calibrate-bands"))
    ap.add_argument("--records", help="a benchmarks.realism.run results JSON to use instead of identifying")
    ap.add_argument("--rows", help="per-prediction components (set, geometry, error): read if present, else written")
    args = ap.parse_args()
    if args.rows and Path(args.rows).exists():
        rows_ = json.loads(Path(args.rows).read_text())
    else:
        if args.records:
            recs = json.loads(Path(args.records).read_text())["cases"][: args.n]
            args.split = recs[0]["split"]
        else:
            cache = Path(args.cache)
            cache.mkdir(exist_ok=True)
            recs = records(args.split, args.n, cache)
        print_summary(summarise(recs), f"{args.split}: as identified (run.py's own predictions)")
        rows_ = []
        reevaluate(recs, band_method((0.0, 0.0, 0.0), rows_))
        if args.rows:
            Path(args.rows).write_text(json.dumps(rows_))
    print("set + geometry only:     ", stats(rows_, (0.0, 0.0, 0.0)))
    c = conformal(rows_)
    print("split-conformal c_mode (90 %) of these rows:", [round(x, 6) for x in c])
    print("with them (in-sample):   ", stats(rows_, c))
    print(f"with bands.MODEL_FORM {bands.MODEL_FORM}:", stats(rows_, bands.MODEL_FORM))


if __name__ == "__main__":
    main()
