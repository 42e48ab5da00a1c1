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
"""

from __future__ import annotations

import argparse
import json
import math
import os
import sys
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

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
    from benchmarks.realism.corpus import make_case

    def band(sets, asm, rec):
        case = make_case(rec["split"], rec["index"])
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


def main() -> None:
    from benchmarks.realism.run import print_summary, reevaluate, summarise

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--split", default="calibration")
    ap.add_argument("--n", type=int, default=24)
    ap.add_argument("--cache", default=str(REPO / ".calibrate_cache"))
    args = ap.parse_args()
    cache = Path(args.cache)
    cache.mkdir(exist_ok=True)
    recs = records(args.split, args.n, cache)
    print_summary(summarise(recs), f"{args.split}: as identified (run.py's own predictions)")
    rows_ = []
    base = reevaluate(recs, band_method((0.0, 0.0, 0.0), rows_))
    print_summary(summarise(base), f"{args.split}: set + geometry only")
    if args.split == "calibration":
        c = conformal(rows_)
        print("model-form coefficients c_mode (split-conformal, 90 %):", [round(x, 6) for x in c])
        print_summary(summarise(reevaluate(recs, band_method(tuple(c)))), f"{args.split}: with them (in-sample)")
    print_summary(summarise(reevaluate(recs, band_method())), f"{args.split}: bands.MODEL_FORM {bands.MODEL_FORM}")


if __name__ == "__main__":
    main()
