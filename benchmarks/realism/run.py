"""Measure taptune on the realism corpus: labels, transfer error, band coverage, CPU time.

For every case: record the tap (truth outside the model family), analyse and identify with
the product pipeline and the DESCRIBED assembly, judge the bending labels against the
truth's audible modes, predict the query stick-outs with the product's ``predict`` and
compare with the truth there. Everything needed to re-evaluate band methods offline is
stored (the near-optimal ``param_sets`` of every identification).

Run::

    python -m benchmarks.realism.run --split validation --n 24 --out results.json [--jobs 1] [--tier issue] [--table]

``--split infamily`` is the control (truth = the product model, description exact).
``--tier issue`` measures the holders issue 9 describes (benchmarks.realism.corpus);
``--table`` prints one row per case (label, error and coverage per prediction).
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
from concurrent.futures import ProcessPoolExecutor

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("OMP_NUM_THREADS", "1")

import numpy as np  # noqa: E402

from benchmarks.realism.audio import AUDIBLE_DB  # noqa: E402
from benchmarks.realism.corpus import KINDS, RULER_MM, TIERS, case_of, make_case, without  # noqa: E402

MODES = (1, 2, 3)
LOUD_DB = 15.0


def judge_labels(case, analysis, margins) -> list[dict]:
    """Per truth bending mode: audible?, which peak got its label, and is that right.

    ``margins``: :func:`~benchmarks.realism.audio.audibility_margins` [dB].

    A bending label for mode n is right when its peak lies within the doublet's half
    split + 0.4 % of the truth's centre frequency.
    """
    out = []
    for n in MODES:
        centre = case.truth.bending_hz[n - 1]
        tol = 0.5 * abs(case.truth.split_hz[n - 1]) + 0.004 * centre
        labelled = [p for p in analysis.peaks if p.kind == "bending" and p.mode == n]
        hz = labelled[0].hz if labelled else None
        nearest = min(analysis.peaks, key=lambda p: abs(p.hz - centre)) if analysis.peaks else None
        near_ok = nearest is not None and abs(nearest.hz - centre) <= tol
        out.append({
            "mode": n,
            "truth_hz": round(centre, 3),
            "audible": bool(margins[n - 1] >= AUDIBLE_DB),
            "margin_db": round(margins[n - 1], 2) if np.isfinite(margins[n - 1]) else None,
            "labelled_hz": None if hz is None else round(hz, 3),
            "right": hz is not None and abs(hz - centre) <= tol,
            "wrong_peak": hz is not None and abs(hz - centre) > tol,
            "peak_at_truth": None if not near_ok else {"hz": round(nearest.hz, 3), "kind": nearest.kind,
                                                        "mode": nearest.mode, "level_db": round(nearest.level_db, 2)},
        })
    return out


def run_case(split: str, index: int, seed: int = 0, ablate: str | None = None, tier: str = "harsh",
             stickout_error_mm: float = RULER_MM) -> dict:
    """Identify one case and predict its queries; a JSON-ready record.

    ``ablate`` names a deviation of :data:`~benchmarks.realism.corpus.KINDS` to remove first
    (:func:`~benchmarks.realism.corpus.without`), to see what it costs; ``tier`` is the
    corpus tier (``harsh`` or ``issue``); ``stickout_error_mm`` the stick-out reading error
    (a gauge instead of the ruler, stated in the described assembly).
    """
    from benchmarks.realism.audio import audibility_margins, record
    from taptune.errors import TaptuneError
    from taptune.identify import IdentifyOptions
    from taptune.identify.pipeline import identify_recordings

    case = make_case(split, index, tier=tier, stickout_error_mm=stickout_error_mm)
    if ablate and ablate in case.kinds:
        case = without(case, ablate)
    out = {"index": index, "ablate": ablate, **case.to_dict()}
    t0 = time.process_time()
    rec = record(case)
    try:
        analyses, result = identify_recordings([rec], [case.described], IdentifyOptions(seed=seed, jobs=1))
    except TaptuneError as err:
        out.update(failed=str(err), cpu_s=round(time.process_time() - t0, 3), predictions=[])
        try:  # the labels can still be judged when the fit gave up on them
            from taptune.identify.pipeline import analyse_for_assembly

            analysis = analyse_for_assembly(rec, case.described)
            out["labels"] = judge_labels(case, analysis, audibility_margins(case, analysis))
        except TaptuneError:
            pass
        return out
    cpu = time.process_time() - t0
    analysis = analyses[0]
    out["labels"] = judge_labels(case, analysis, audibility_margins(case, analysis))
    out["peaks"] = [{"hz": round(p.hz, 2), "kind": p.kind, "mode": p.mode, "level_db": round(p.level_db, 2),
                     "scatter_hz": round(p.scatter_hz, 3)}
                    for p in analysis.peaks]
    out["identification"] = {
        "param_sets": [p.to_dict() for p in result.param_sets],
        "bending_measured_hz": list(result.bending_measured_hz[0]),
        "bending_model_hz": list(result.bending_model_hz[0]),
        "objective": result.objective,
        "objective_terms": [list(t) for t in result.objective_terms],
        "relative_floor": result.relative_floor,
        "evaluations": result.evaluations,
        "warnings": list(result.warnings) + list(analysis.warnings),
    }
    out["cpu_s"] = round(cpu, 3)
    t1 = time.process_time()
    out["predictions"] = predictions(case, lambda asm: product_predict(result.param_sets, asm, case, out["identification"]),
                                     result.bending_measured_hz[0])
    out["predict_cpu_s"] = round(time.process_time() - t1, 3)
    return out


def product_predict(param_sets, assembly, case, identification: dict):
    """Predict ``assembly`` as the library does (taptune.library.schema.Entry.predict): with
    the fit's misfit floor, the identified assembly (Δ stick-out) and the modes the tap
    measured, from a record's ``identification``."""
    from taptune.identify import predict
    from taptune.identify.bands import measured_modes

    return predict(param_sets, assembly, relative_floor=identification["relative_floor"], identified=[case.described],
                   measured_modes=measured_modes([identification["bending_measured_hz"]]))


def predictions(case, predict_at, measured_hz) -> list[dict]:
    """Compare ``predict_at(described assembly at a query) -> Prediction`` with the truth."""
    preds = []
    for q in case.queries:
        p = predict_at(case.described_at(q.stickout_mm))
        for n in MODES:
            truth, f, s = q.truth.bending_hz[n - 1], p.bending_hz[n - 1], p.bending_hz_spread[n - 1]
            preds.append({
                "stickout_mm": q.stickout_mm, "mode": n, "truth_hz": round(truth, 3), "predicted_hz": round(f, 3),
                "spread_hz": round(s, 3), "error_pct": round(100 * (f / truth - 1), 5),
                "ruler_pct": round(100 * (q.ruler_hz[n - 1] / truth - 1), 5),
                "half_width_pct": round(100 * s / f, 5), "covered": bool(abs(f - truth) <= s),
                "measured": measured_hz[n - 1] is not None,
            })
    return preds


def reevaluate(records: list[dict], band) -> list[dict]:
    """Records with their predictions redone by another band method, without re-identifying.

    Parameters
    ----------
    records : list of dict
        ``cases`` of a results JSON (:func:`run_case` records).
    band : callable
        ``band(param_sets: list[HolderParams], assembly, record) -> Prediction`` (anything
        with ``bending_hz`` and ``bending_hz_spread``), e.g.
        ``lambda sets, asm, rec: taptune.identify.predict(sets, asm)``.

    Returns
    -------
    list of dict
        Copies of the records with new ``predictions``; pass them to :func:`summarise`.
    """
    from taptune.model.params import HolderParams

    out = []
    for rec in records:
        if "failed" in rec:
            out.append(rec)
            continue
        case = case_of(rec)
        sets = [HolderParams(**p) for p in rec["identification"]["param_sets"]]
        measured = rec["identification"]["bending_measured_hz"]
        out.append({**rec, "predictions": predictions(case, lambda asm: band(sets, asm, rec), measured)})
    return out


def _stats(preds: list[dict]) -> dict:
    if not preds:
        return {"n": 0}
    err = np.abs([p["error_pct"] for p in preds])
    return {
        "n": len(preds),
        "error_median_pct": round(float(np.median(err)), 4),
        "error_p90_pct": round(float(np.percentile(err, 90)), 4),
        "error_max_pct": round(float(np.max(err)), 4),
        "coverage": round(float(np.mean([p["covered"] for p in preds])), 4),
        "half_width_median_pct": round(float(np.median([p["half_width_pct"] for p in preds])), 4),
        # What the ruler error at the query alone moves the truth (no model can beat it).
        "ruler_median_pct": round(float(np.median(np.abs([p.get("ruler_pct", 0.0) for p in preds]))), 4),
    }


def summarise(records: list[dict]) -> dict:
    """Labels, transfer error, band coverage and CPU over case records (see :func:`run_case`).

    Works on records whose predictions' ``predicted_hz``/``spread_hz``/``covered``/
    ``half_width_pct`` were recomputed by another band method.
    """
    ok = [r for r in records if "failed" not in r]
    labels = [lab for r in records for lab in r.get("labels", [])]
    audible = [lab for lab in labels if lab["audible"]]
    preds = [p for r in ok for p in r["predictions"]]
    out = {
        "cases": len(records),
        "failed": [r["name"] for r in records if "failed" in r],
        "labels": {
            "audible_modes": len(audible),
            "right": sum(lab["right"] for lab in audible),
            "audible_wrong_peak": sum(lab["wrong_peak"] for lab in audible),
            "audible_missed": sum(lab["labelled_hz"] is None for lab in audible),
            # The failure: the peak is there but got another label.
            "audible_peak_mislabelled": sum(not lab["right"] and lab["peak_at_truth"] is not None for lab in audible),
            "audible_no_peak": sum(lab["peak_at_truth"] is None for lab in audible),
            "inaudible_labelled_wrong": sum(lab["wrong_peak"] for lab in labels if not lab["audible"]),
            # Modes ≥ 15 dB over the floor: loud enough for the product's peak picker.
            "loud_modes": sum(lab.get("margin_db") is not None and lab["margin_db"] >= LOUD_DB for lab in labels),
            "loud_right": sum(lab["right"] for lab in labels
                              if lab.get("margin_db") is not None and lab["margin_db"] >= LOUD_DB),
        },
        "transfer": _stats(preds),
        "transfer_measured_modes": _stats([p for p in preds if p["measured"]]),
        "by_mode": {str(n): _stats([p for p in preds if p["mode"] == n]) for n in MODES},
        "by_kind": {k: _stats([p for r in ok if k in r["kinds"] for p in r["predictions"]]) for k in KINDS},
        "cpu_s_identify": {
            "median": round(float(np.median([r["cpu_s"] for r in ok])), 3) if ok else None,
            "max": round(float(np.max([r["cpu_s"] for r in ok])), 3) if ok else None,
            "total": round(float(np.sum([r["cpu_s"] for r in records])), 2),
        },
    }
    return out


def print_summary(s: dict, title: str) -> None:
    lab, t = s["labels"], s["transfer"]
    print(f"\n== {title}: {s['cases']} cases" + (f", failed: {', '.join(s['failed'])}" if s["failed"] else ""))
    print(f"labels right / audible bending modes: {lab['right']}/{lab['audible_modes']} "
          f"(wrong peak {lab['audible_wrong_peak']}, missed {lab['audible_missed']}; "
          f"peak there but mislabelled {lab['audible_peak_mislabelled']}, no peak picked {lab['audible_no_peak']}; "
          f"inaudible modes given a wrong peak: {lab['inaudible_labelled_wrong']})")
    print(f"labels right / modes >= {LOUD_DB:g} dB over the noise floor: {lab['loud_right']}/{lab['loud_modes']}")
    print(f"{'predictions':24s} {'n':>4s} {'|err| med %':>11s} {'p90 %':>7s} {'max %':>7s} {'covered':>8s} {'±med %':>7s}"
          f" {'ruler med %':>11s}")

    def row(name, st):
        if st["n"]:
            print(f"{name:24s} {st['n']:4d} {st['error_median_pct']:11.3f} {st['error_p90_pct']:7.3f} "
                  f"{st['error_max_pct']:7.3f} {st['coverage']:8.0%} {st['half_width_median_pct']:7.3f}"
                  f" {st['ruler_median_pct']:11.3f}")

    row("all", t)
    row("measured modes only", s["transfer_measured_modes"])
    for n, st in s["by_mode"].items():
        row(f"mode {n}", st)
    for k, st in s["by_kind"].items():
        row(f"with {k}", st)
    c = s["cpu_s_identify"]
    print(f"CPU per identification: median {c['median']} s, max {c['max']} s; total {c['total']} s")


def print_table(records: list[dict]) -> None:
    """One row per case: deviations, labels (right/audible), then each prediction's
    error [%] (``!`` outside its band) and the median half-width [%]."""
    print(f"\n{'case':28s} {'deviations':44s} {'labels':>6s} {'±med%':>6s}  errors % per query x mode (! = not covered)")
    for r in records:
        audible = [lab for lab in r.get("labels", []) if lab["audible"]]
        labels = f"{sum(lab['right'] for lab in audible)}/{len(audible)}"
        kinds = ",".join(k for k in r["kinds"] if k not in ("stickout", "profile", "diameters", "flute"))
        kinds = (r.get("truth_holder", {}).get("profile", {}).get("kind", "") + " " + kinds).strip()
        if "failed" in r:
            print(f"{r['name']:28s} {kinds:44s} {labels:>6s} {'':>6s}  FAILED {r['failed'][:60]}")
            continue
        preds = r["predictions"]
        half = float(np.median([p["half_width_pct"] for p in preds])) if preds else float("nan")
        errs = " ".join(f"{p['error_pct']:+.2f}{'' if p['covered'] else '!'}{'' if p['measured'] else '?'}"
                        for p in preds)
        print(f"{r['name']:28s} {kinds:44s} {labels:>6s} {half:6.2f}  {errs}")
    print("(? = mode not measured in the tap)")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--split", default="validation", choices=("calibration", "validation", "infamily"))
    ap.add_argument("--n", type=int, default=24)
    ap.add_argument("--start", type=int, default=0, help="first case index")
    ap.add_argument("--seed", type=int, default=0, help="identification seed")
    ap.add_argument("--jobs", type=int, default=1, help="cases identified in parallel processes")
    ap.add_argument("--out", default=None, help="results JSON")
    ap.add_argument("--ablate", default=None, choices=KINDS, help="remove this deviation from every case")
    ap.add_argument("--tier", default="harsh", choices=TIERS, help="corpus tier (issue: the holders of issue 9)")
    ap.add_argument("--table", action="store_true", help="print one row per case")
    ap.add_argument("--stickout-error", type=float, default=RULER_MM, metavar="MM",
                    help=f"largest stick-out reading error [mm] (default {RULER_MM}: a ruler; e.g. 0.05: a gauge, "
                         "stated as the assembly's stickout_tolerance)")
    args = ap.parse_args(argv)
    if not args.stickout_error >= 0:
        ap.error("--stickout-error must be >= 0 mm")
    t0 = time.time()
    indices = range(args.start, args.start + args.n)
    if args.jobs > 1:
        with ProcessPoolExecutor(args.jobs) as pool:
            records = list(pool.map(run_case, [args.split] * args.n, indices, [args.seed] * args.n,
                                    [args.ablate] * args.n, [args.tier] * args.n, [args.stickout_error] * args.n))
    else:
        records = []
        for i in indices:
            records.append(run_case(args.split, i, args.seed, args.ablate, args.tier, args.stickout_error))
            r = records[-1]
            print(f"{r['name']:28s} {','.join(r['kinds']):45s} cpu {r['cpu_s']:6.2f} s  "
                  + ("FAILED " + r["failed"] if "failed" in r else
                     "err% " + " ".join(f"{p['error_pct']:+.2f}{'' if p['covered'] else '!'}" for p in r["predictions"])),
                  flush=True)
    summary = summarise(records)
    if args.table:
        print_table(records)
    print_summary(summary, f"{args.split}, {args.tier} tier (seed {args.seed})")
    print(f"wall {time.time() - t0:.0f} s with {args.jobs} job(s), load {os.getloadavg()[0]:.1f}")
    if args.out:
        import taptune

        meta = {"split": args.split, "tier": args.tier, "ablate": args.ablate, "stickout_error_mm": args.stickout_error, "taptune": os.path.dirname(taptune.__file__),
                "code": os.environ.get("REALISM_CODE", ""), "n": args.n, "start": args.start, "seed": args.seed, "jobs": args.jobs,
                "wall_s": round(time.time() - t0, 1), "load": round(os.getloadavg()[0], 2)}
        write_results(args.out, {"meta": meta, "summary": summary, "cases": records})
    return 0


def write_results(path: str, data: dict, limit: int = 200_000) -> int:
    """Write a results JSON, kept under ``limit`` bytes for the repository: indented when
    it fits, else the parameter sets rounded to 9 significant digits (predictions move by
    ~1e-9), no indentation, and without the truth holder's and the recording's description
    (:func:`~benchmarks.realism.corpus.case_of` rebuilds both). Replaced atomically: a
    stored run (``calibrate_bands --rewrite-results`` rewrites them in place) is never left
    half-written. Returns the size [bytes]."""
    from taptune.io.atomic import atomic_write_bytes

    text = json.dumps(data, indent=1)
    if len(text) > limit:
        for rec in data["cases"]:
            rec.pop("truth_holder", None)
            rec.pop("recording", None)
            ident = rec.get("identification")
            if ident:
                ident["param_sets"] = [{k: float(f"{v:.9g}") for k, v in p.items()} for p in ident["param_sets"]]
        text = json.dumps(data, separators=(",", ":"))
    atomic_write_bytes(path, text.encode("utf-8"))
    return len(text)


if __name__ == "__main__":
    sys.exit(main())
