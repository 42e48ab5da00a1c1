"""The floor of taptune's transfer error on the realism corpus: an ORACLE that skips the audio.

For every case the oracle takes the TRUE bending frequencies at the recorded stick-out
(``case.truth.bending_hz``, all three modes, noise-free) and fits the seven holder
parameters of the model the user's assembly FILE describes (nominal geometry, ruler-read
stick-out: ``case.described``, what the pipeline fits) to them: least squares in
log-frequency inside the bounds ``P_LOWER``/``P_UPPER``, from several starts, on the
product's fast evaluator (:func:`taptune.model.reduced.cached_evaluator`, as
``identify``). It then predicts every query as the pipeline does (full model at the
query's ruler-read stick-out in the file's geometry) and compares with the truth there.
No audio, no peak picking, no labels, no optimiser budget: what is left is what the
model and the description errors (profile, diameters, flute, hidden mass, doublet,
ruler) cost.

Three frequencies do not fix seven parameters (docs/physics.md §5): the exact fits form a
valley, and their predictions at other stick-outs differ (by up to 10 % even in the
in-family control). The oracle's prediction is the exact fit nearest the pipeline's own
choice (the fit started from the pipeline's best parameter set, else the valley member
nearest that start; the lowest misfit when the pipeline failed). ``valley_pct`` gives
the range of the predictions over every start that fits about as well (misfit within
``VALLEY_TOL`` of the best), ``chosen_pct`` the per-case best of them (a perfect choice
inside the sampled valley: the floor of any selection rule).

Variants (every prediction carries all of them, in % of the truth):

* ``ruler``    fit all three truth modes; predict at the query's described stick-out
  (the pipeline's situation without audio);
* ``exact_q``  the same fit; predict at the query's TRUE stick-out (no ruler at the query);
* ``exact``    fit at the TRUE recorded stick-out, predict at the TRUE query stick-out
  (the stick-out error removed on both sides; the rest of the description stays);
* ``fit_measured`` fit only the modes the real pipeline measured (its results record's
  ``identification.bending_measured_hz``), predict as ``ruler``;
* ``floor``    ONE parameter set fitted to the truth at the recording AND at the queries
  (described geometry, ruler-read stick-outs): what the best conceivable identification
  could do with this model and this description;
* ``floor_exact`` the same with every stick-out exact.

``ruler_pct`` (from the corpus) is how far the ruler error at the query alone moves the
true holder: a perfect model fed the ruler-read stick-out errs by that much.

Run::

    nice -n 5 python -m benchmarks.realism.oracle --tier issue --split validation --n 48 --jobs 2 \
        --out benchmarks/realism/oracle_issue_validation.json

It compares with the real pipeline's ``results_<tier>_<split>*.json`` (same cases).
"""

from __future__ import annotations

import argparse
import glob
import json
import os
import sys
import time
from concurrent.futures import ProcessPoolExecutor

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("OMP_NUM_THREADS", "1")

import numpy as np  # noqa: E402

from benchmarks.realism.corpus import TIERS, make_case  # noqa: E402
from benchmarks.realism.run import MODES  # noqa: E402

#: Least-squares starts per fit: the nominal holder, the pipeline's best set (when known)
#: and Latin-hypercube points of the unit cube.
STARTS = 12
#: A start belongs to the valley when its RMS log-misfit is within this of the best's
#: (1e-4 = 0.01 %, the frequencies measured ~ 0.05 %).
VALLEY_TOL = 1e-4
VARIANTS = ("ruler", "exact_q", "exact", "fit_measured", "floor", "floor_exact")
HERE = os.path.dirname(os.path.abspath(__file__))


def _starts(rng, n: int, extra=()) -> np.ndarray:
    """Unit-cube starts: ``extra`` (unit vectors) first, the nominal holder, then a Latin hypercube."""
    from taptune.model.params import NOMINAL, p_to_unit, to_p

    fixed = [np.clip(np.asarray(u, float), 0.0, 1.0) for u in extra] + [p_to_unit(to_p(NOMINAL))]
    m = max(n - len(fixed), 0)
    lhs = (rng.permuted(np.tile(np.arange(m), (7, 1)), axis=1).T + rng.uniform(size=(m, 7))) / max(m, 1)
    return np.vstack(fixed + [lhs]) if m else np.vstack(fixed)


def fit_frequencies(assemblies, targets_hz, modes=MODES, starts: int = STARTS, seed: int = 0,
                    extra_starts=()) -> list[dict]:
    """Least-squares fits of the seven parameters to bending frequencies, one per start.

    Parameters
    ----------
    assemblies : sequence of Assembly
        The geometries the model is built on (the described one, for the pipeline's view;
        several for a joint fit).
    targets_hz : sequence of sequence of float
        f1–f3 to fit per assembly [Hz] (only ``modes`` are used).
    modes : sequence of int
        Mode numbers (1-based) fitted.
    starts, seed : int
        Number of starts and the seed of their Latin hypercube.
    extra_starts : sequence of array_like
        Unit-cube vectors tried first (e.g. the pipeline's best fit).

    Returns
    -------
    list of dict
        Per start, best first: ``u`` (unit-cube optimum), ``misfit`` (RMS of
        log(f_model / f_target) over the fitted frequencies), ``start`` (its index; the
        extra starts first), ``u0`` (the start), ``nfev``.
    """
    from scipy.optimize import least_squares

    from taptune.model.params import unit_to_p
    from taptune.model.reduced import cached_evaluator

    evs = [cached_evaluator(a) for a in assemblies]
    idx = np.asarray(modes, dtype=int) - 1
    log_t = np.concatenate([np.log(np.asarray(t, dtype=float)[idx]) for t in targets_hz])
    window = np.array([1000.0])

    def residual(u):
        p = unit_to_p(u)
        f = np.concatenate([np.asarray(ev.evaluate(p, window).bending_hz)[idx] for ev in evs])
        return np.log(f) - log_t

    out = []
    for k, u0 in enumerate(_starts(np.random.default_rng(seed), starts, extra_starts)):
        try:
            r = least_squares(residual, u0, bounds=(0.0, 1.0), x_scale=1.0, diff_step=1e-5,
                              xtol=1e-12, ftol=1e-12, gtol=1e-12, max_nfev=400)
        except (np.linalg.LinAlgError, ValueError):
            continue
        out.append({"u": r.x, "misfit": float(np.sqrt(np.mean(r.fun**2))), "start": k, "u0": u0, "nfev": int(r.nfev)})
    return sorted(out, key=lambda s: s["misfit"])


def _frequencies(assembly, params) -> np.ndarray:
    """Full-model f1–f3 [Hz] of ``assembly`` with one parameter set (as ``predict``)."""
    from taptune.model import build_model, solve_modes

    return np.asarray(solve_modes(build_model(assembly), params, n_modes=3).frequency_hz[:3], dtype=float)


def _valley(fits: list[dict]) -> list[dict]:
    best = fits[0]["misfit"]
    return [f for f in fits if f["misfit"] <= best + VALLEY_TOL]


def _pick(fits: list[dict], from_pipeline: bool) -> dict:
    """The oracle's member: the exact fit nearest the pipeline's choice inside the valley
    (the fit started from the pipeline's best set; when that start ends in a worse local
    minimum, the valley member nearest the start), else the lowest misfit."""
    members = _valley(fits)
    start = next((f for f in fits if f["start"] == 0), None) if from_pipeline else None
    if start is None:
        return fits[0]
    if any(f is start for f in members):
        return start
    return min(members, key=lambda f: float(np.linalg.norm(f["u"] - start["u0"])))


def _predict_all(fits, at_assemblies, truths, from_pipeline: bool) -> dict:
    """Errors [%] at the query assemblies: of the picked fit (:func:`_pick`), and the
    range and per-case best over the valley members, each of shape (queries, 3)."""
    from taptune.model.params import from_p, unit_to_p

    def errors(f):
        return np.array([100 * (_frequencies(asm, from_p(unit_to_p(f["u"]))) / np.asarray(t) - 1)
                         for asm, t in zip(at_assemblies, truths)])

    pick = _pick(fits, from_pipeline)
    members = _valley(fits)
    err = np.array([errors(f) for f in members])
    # The per-case best member: smallest RMS error over the case's predictions.
    chosen = err[int(np.argmin(np.sqrt(np.mean(err.reshape(len(members), -1) ** 2, axis=1))))]
    return {"error": errors(pick), "low": err.min(0), "high": err.max(0), "chosen": chosen,
            "members": len(members), "pick_misfit": pick["misfit"]}


def pipeline_records(tier: str, split: str) -> dict:
    """The real pipeline's results records of ``tier``/``split`` by case index
    (``results_<tier>_<split>*.json``; in-family: ``results_infamily*.json``)."""
    pattern = "results_infamily*.json" if split == "infamily" else f"results_{tier}_{split}*.json"
    out = {}
    for path in sorted(glob.glob(os.path.join(HERE, pattern))):
        data = json.load(open(path, encoding="utf-8"))
        if data["meta"].get("tier", "harsh") != tier or data["meta"].get("ablate"):
            continue
        for rec in data["cases"]:
            out.setdefault(rec["index"], rec)
    return out


def oracle_case(split: str, index: int, tier: str, record: dict | None = None, starts: int = STARTS) -> dict:
    """The oracle's fits and predictions of one case (see the module docstring), JSON-ready.

    ``record``: the pipeline's results record of the case (its measured modes set the
    ``fit_measured`` variant, its best parameter set is the first start and picks the valley
    member); None skips ``fit_measured`` and picks the lowest misfit.
    """
    from taptune.model.params import HolderParams, from_p, p_to_unit, to_p, unit_to_p

    t0 = time.process_time()
    case = make_case(split, index, tier=tier)
    truth = case.truth.bending_hz
    q_truth = [q.truth.bending_hz for q in case.queries]
    extra, measured = (), None
    if record is not None and "failed" not in record:
        ident = record["identification"]
        extra = (p_to_unit(to_p(HolderParams(**ident["param_sets"][0]))),)
        measured = [f is not None for f in ident["bending_measured_hz"]]
    piped = bool(extra)
    at_ruler = [case.described_at(q.stickout_mm) for q in case.queries]
    at_exact = [case.described_at(q.true_stickout_mm) for q in case.queries]
    true_rec = case.described.with_stickout(case.true_assembly.stickout)
    out = {"name": case.name, "index": index, "split": split, "tier": tier, "kinds": list(case.kinds),
           "truth_hz": [round(f, 3) for f in truth], "pipeline_start": piped}
    fits = fit_frequencies([case.described], [truth], starts=starts, seed=index, extra_starts=extra)
    res = {"ruler": _predict_all(fits, at_ruler, q_truth, piped),
           "exact_q": _predict_all(fits, at_exact, q_truth, piped)}
    fits_x = fit_frequencies([true_rec], [truth], starts=starts, seed=index, extra_starts=extra)
    res["exact"] = _predict_all(fits_x, at_exact, q_truth, piped)
    if measured is not None:
        modes = tuple(n for n, m in zip(MODES, measured) if m)
        fits_m = fit_frequencies([case.described], [truth], modes=modes, starts=starts, seed=index, extra_starts=extra)
        res["fit_measured"] = _predict_all(fits_m, at_ruler, q_truth, piped)
        out["measured_modes"] = list(modes)
    # The floor: one parameter set fitted to the truth at the recording AND the queries.
    joint = max(starts // 2, 2)
    fits_f = fit_frequencies([case.described] + at_ruler, [truth] + q_truth, starts=joint, seed=index, extra_starts=extra)
    res["floor"] = _predict_all(fits_f[:1], at_ruler, q_truth, False)
    fits_fx = fit_frequencies([true_rec] + at_exact, [truth] + q_truth, starts=joint, seed=index, extra_starts=extra)
    res["floor_exact"] = _predict_all(fits_fx[:1], at_exact, q_truth, False)
    pick = from_p(unit_to_p(_pick(fits, piped)["u"]))
    out["fit"] = {"misfit_pct": round(100 * fits[0]["misfit"], 5),
                  "pick_misfit_pct": round(100 * res["ruler"]["pick_misfit"], 5), "starts": len(fits),
                  "valley": res["ruler"]["members"], "params": pick.to_dict(),
                  "model_hz": [round(f, 3) for f in _frequencies(case.described, pick)],
                  "exact_misfit_pct": round(100 * fits_x[0]["misfit"], 5),
                  "floor_misfit_pct": round(100 * fits_f[0]["misfit"], 5),
                  "floor_exact_misfit_pct": round(100 * fits_fx[0]["misfit"], 5)}
    preds = []
    pipe = {(p["stickout_mm"], p["mode"]): p for p in (record or {}).get("predictions", [])}
    for k, q in enumerate(case.queries):
        for n in MODES:
            p = {"stickout_mm": q.stickout_mm, "true_stickout_mm": round(q.true_stickout_mm, 4), "mode": n,
                 "truth_hz": round(q_truth[k][n - 1], 3),
                 "ruler_pct": round(100 * (q.ruler_hz[n - 1] / q_truth[k][n - 1] - 1), 5),
                 "measured": None if measured is None else bool(measured[n - 1])}
            for v, r in res.items():
                p[v] = {"error_pct": round(float(r["error"][k, n - 1]), 4)}
                if not v.startswith("floor"):  # one member: its valley is the prediction itself
                    p[v].update(valley_pct=[round(float(r["low"][k, n - 1]), 4), round(float(r["high"][k, n - 1]), 4)],
                                chosen_pct=round(float(r["chosen"][k, n - 1]), 4))
            if (q.stickout_mm, n) in pipe:
                pp = pipe[(q.stickout_mm, n)]
                p["pipeline"] = {"error_pct": pp["error_pct"], "half_width_pct": pp["half_width_pct"],
                                 "covered": pp["covered"]}
            preds.append(p)
    out["predictions"] = preds
    out["cpu_s"] = round(time.process_time() - t0, 2)
    return out


def _stats(err) -> dict:
    err = np.abs(np.asarray(err, dtype=float))
    if not err.size:
        return {"n": 0}
    # A perfectly adaptive band covering exactly 90 %: half-width |error| on the 90 % of
    # smallest errors, zero on the rest; its median half-width is the narrowest any band can have.
    k = int(np.ceil(0.9 * err.size))
    adaptive = np.concatenate([np.sort(err)[:k], np.zeros(err.size - k)])
    return {"n": int(err.size), "median_pct": round(float(np.median(err)), 4),
            "p90_pct": round(float(np.percentile(err, 90)), 4), "max_pct": round(float(err.max()), 4),
            "adaptive90_median_pct": round(float(np.median(adaptive)), 4),
            "share_le_0.4": round(float(np.mean(err <= 0.4)), 3), "share_le_2": round(float(np.mean(err <= 2.0)), 3)}


def summarise(records: list[dict]) -> dict:
    """|error| statistics per variant (and the pipeline's on the same predictions):
    all, per mode, the pipeline's measured modes; for ``valley`` the worse end of the
    valley and ``chosen`` the per-case best member.

    ``p90_pct`` of |error| is the half-width a band of constant relative width needs to
    cover 90 %; a perfectly adaptive band (half-width = |error| of each prediction) has a
    median half-width of ``median_pct``.
    """
    preds = [p for r in records for p in r["predictions"]]
    out = {"cases": len(records), "predictions": len(preds),
           "ruler_floor": _stats([p["ruler_pct"] for p in preds])}

    def block(sel):
        b = {}
        for v in VARIANTS:
            ps = [p for p in sel if v in p]
            b[v] = _stats([p[v]["error_pct"] for p in ps])
            if v.startswith("floor"):
                continue
            b[v + "_valley_worst"] = _stats([max(abs(x) for x in p[v]["valley_pct"]) for p in ps])
            b[v + "_chosen"] = _stats([p[v]["chosen_pct"] for p in ps])
        pp = [p for p in sel if "pipeline" in p]
        b["pipeline"] = _stats([p["pipeline"]["error_pct"] for p in pp])
        if pp:
            b["pipeline"]["coverage"] = round(float(np.mean([p["pipeline"]["covered"] for p in pp])), 3)
            b["pipeline"]["half_width_median_pct"] = round(float(np.median([p["pipeline"]["half_width_pct"] for p in pp])), 4)
        return b

    out["all"] = block(preds)
    out["measured_modes"] = block([p for p in preds if p["measured"]])
    out["by_mode"] = {str(n): block([p for p in preds if p["mode"] == n]) for n in MODES}
    out["fit_misfit_pct"] = {k: _stats([r["fit"][k] for r in records])
                             for k in ("misfit_pct", "pick_misfit_pct", "exact_misfit_pct", "floor_misfit_pct",
                                       "floor_exact_misfit_pct")}
    return out


def print_summary(s: dict, title: str) -> None:
    """One row per predictor: |error| median / p90 / max over all predictions and over the
    pipeline's measured modes, the median per mode, the share within 0.4 % and (``ad90``)
    the median half-width of a perfectly adaptive band covering 90 %."""
    m = s["fit_misfit_pct"]
    print(f"\n== oracle, {title}: {s['cases']} cases, {s['predictions']} predictions; RMS log-misfit of the "
          f"3-mode fit median {m['misfit_pct']['median_pct']:.3f} % (max {m['misfit_pct']['max_pct']:.3f}), "
          f"of the joint floor fit {m['floor_misfit_pct']['median_pct']:.3f} % (max {m['floor_misfit_pct']['max_pct']:.3f})")
    print(f"{'|error| %':30s} {'n':>4s} {'med':>6s} {'p90':>6s} {'max':>6s} | {'meas n':>6s} {'med':>6s} {'p90':>6s} "
          f"{'max':>6s} | {'m1 med':>6s} {'m2 med':>6s} {'m3 med':>6s} | {'<=0.4%':>6s} {'ad90':>6s}")
    names = [("pipeline", "pipeline (results files)")] + [(v, f"oracle {v}") for v in VARIANTS] + [
        ("ruler_chosen", "oracle ruler, best in valley"), ("ruler_valley_worst", "oracle ruler, worst in valley")]

    def cell(st, keys=("median_pct", "p90_pct", "max_pct")):
        return " ".join(f"{st[k]:6.3f}" if st.get("n") else f"{'-':>6s}" for k in keys)

    rf = s["ruler_floor"]
    print(f"{'ruler alone at the query':30s} {rf['n']:4d} {cell(rf)} |")
    for key, name in names:
        a, me = s["all"][key], s["measured_modes"][key]
        if not a.get("n"):
            continue
        modes = " ".join(cell(s["by_mode"][n][key], ("median_pct",)) for n in ("1", "2", "3"))
        print(f"{name:30s} {a['n']:4d} {cell(a)} | {me.get('n', 0):6d} {cell(me)} | {modes} | {a['share_le_0.4']:6.0%} {a['adaptive90_median_pct']:6.3f}")


def _compact(record: dict) -> dict:
    """A case record as :func:`oracle_case` writes it now (4 decimals; the one-member
    floor fits without valley), for records of earlier runs."""
    for p in record["predictions"]:
        for v in VARIANTS:
            if v in p:
                e = p[v]
                p[v] = {"error_pct": round(e["error_pct"], 4)}
                if not v.startswith("floor"):
                    p[v].update(valley_pct=[round(x, 4) for x in e["valley_pct"]], chosen_pct=round(e["chosen_pct"], 4))
    return record


def _write(path, data: dict) -> None:
    """Replace a results file atomically (a stored 20-minute run is never left half-written)."""
    from taptune.io.atomic import atomic_write_bytes

    atomic_write_bytes(path, json.dumps(data, separators=(",", ":")).encode("utf-8"))


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--split", default="validation", choices=("calibration", "validation", "infamily"))
    ap.add_argument("--tier", default="harsh", choices=TIERS)
    ap.add_argument("--n", type=int, default=48)
    ap.add_argument("--start", type=int, default=0)
    ap.add_argument("--starts", type=int, default=STARTS, help="least-squares starts per fit")
    ap.add_argument("--jobs", type=int, default=1)
    ap.add_argument("--out", default=None, help="results JSON")
    ap.add_argument("--indices", default=None, help="comma-separated case indices instead of --start/--n")
    ap.add_argument("--update", default=None, metavar="JSON",
                    help="replace these cases in an oracle results JSON and recompute its summary")
    ap.add_argument("--summary", default=None, metavar="JSON", help="only print the summary of an oracle results JSON")
    ap.add_argument("--rewrite", action="store_true", help="with --summary: store the recomputed summary")
    args = ap.parse_args(argv)
    if args.summary:
        data = json.load(open(args.summary, encoding="utf-8"))
        data["summary"] = summarise(data["cases"])
        print_summary(data["summary"], f"{data['meta']['tier']} tier, {data['meta']['split']}")
        if args.rewrite:
            _write(args.summary, data)
        return 0
    t0 = time.time()
    pipe = pipeline_records(args.tier, args.split)
    if args.indices:
        idx = [int(i) for i in args.indices.split(",")]
    else:
        idx = list(range(args.start, args.start + args.n))
    recs = [pipe.get(i) for i in idx]
    args_ = ([args.split] * len(idx), idx, [args.tier] * len(idx), recs, [args.starts] * len(idx))
    if args.jobs > 1:
        with ProcessPoolExecutor(args.jobs) as pool:
            records = list(pool.map(oracle_case, *args_))
    else:
        records = [oracle_case(*a) for a in zip(*args_)]
    for r in records:
        print(f"{r['name']:28s} misfit {r['fit']['misfit_pct']:.3f} %  valley {r['fit']['valley']:2d}  err% "
              + " ".join(f"{p['ruler']['error_pct']:+.2f}" for p in r["predictions"]) + f"  cpu {r['cpu_s']} s", flush=True)
    if args.update:
        data = json.load(open(args.update, encoding="utf-8"))
        new = {r["index"]: r for r in records}
        data["cases"] = [_compact(new.get(r["index"], r)) for r in data["cases"]]
        data["meta"]["updated_indices"] = sorted(set(data["meta"].get("updated_indices", [])) | set(new))
        data["summary"] = summarise(data["cases"])
        print_summary(data["summary"], f"{args.tier} tier, {args.split} (updated {args.update})")
        _write(args.update, data)
        return 0
    summary = summarise(records)
    print_summary(summary, f"{args.tier} tier, {args.split}")
    print(f"wall {time.time() - t0:.0f} s with {args.jobs} job(s)")
    if args.out:
        meta = {"split": args.split, "tier": args.tier, "n": args.n, "start": args.start, "starts": args.starts,
                "valley_tol": VALLEY_TOL, "pipeline_cases": sum(r is not None for r in recs),
                "wall_s": round(time.time() - t0, 1)}
        _write(args.out, {"meta": meta, "summary": summary, "cases": records})
    return 0


if __name__ == "__main__":
    sys.exit(main())
