"""How far each deviation takes a case outside the model family, without identifying anything.

A deviation that scales a mode's frequency by the same factor at every stick-out is
absorbed by the fit (the holder parameters soak it up); what no fit can absorb is how it
changes the TRANSFER RATIO f(query) / f(recorded). For every case and every deviation it
has, this prints the change of that ratio when the deviation is removed
(:func:`~benchmarks.realism.corpus.without`), per mode, in %.

Run: ``python -m benchmarks.realism.attribute --split validation --n 24``; with
``--paired baseline.json ablated.json …`` it compares pipeline runs with and without a
deviation (``run --ablate KIND``) on the cases that have it.
"""

from __future__ import annotations

import argparse
import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np  # noqa: E402

from benchmarks.realism.corpus import KINDS, make_case, without  # noqa: E402


def transfer_ratios(case) -> np.ndarray:
    """f(query) / f(recorded) of the truth, shape (n_queries, 3)."""
    rec = np.asarray(case.truth.bending_hz)
    return np.array([np.asarray(q.truth.bending_hz) / rec for q in case.queries])


def attribute(case) -> dict:
    """{kind: ratio change [%], shape (n_queries, 3)} for every deviation of the case but lowgrade."""
    base = transfer_ratios(case)
    return {k: 100 * (base / transfer_ratios(without(case, k)) - 1) for k in case.kinds if k != "lowgrade"}


def paired(base: list[dict], ablated: list[dict]) -> dict:
    """What one deviation costs the pipeline: measured-mode predictions of the cases that have
    it, with it (``base``, run records) and without it (``ablated``, ``run --ablate KIND``)."""
    kind = next(r["ablate"] for r in ablated if r.get("ablate"))
    by_name = {r["name"]: r for r in base}
    with_, without_ = [], []
    cases = 0
    for r in ablated:
        b = by_name.get(r["name"].replace(f"-no{kind}", ""))
        if b is None or kind not in b["kinds"] or "failed" in r or "failed" in b:
            continue
        cases += 1
        for pb, pa in zip(b["predictions"], r["predictions"]):
            if pb["measured"] and pa["measured"]:
                with_.append(pb)
                without_.append(pa)

    def stats(preds):
        err = np.abs([p["error_pct"] for p in preds])
        return {"error_median_pct": round(float(np.median(err)), 3), "error_p90_pct": round(float(np.percentile(err, 90)), 3),
                "error_max_pct": round(float(err.max()), 3), "coverage": round(float(np.mean([p["covered"] for p in preds])), 3)}

    return {"kind": kind, "cases": cases, "predictions": len(with_), "with": stats(with_), "without": stats(without_)}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--split", default="validation")
    ap.add_argument("--n", type=int, default=24)
    ap.add_argument("--paired", nargs="+", metavar="JSON",
                    help="a baseline results JSON then ablated ones (run --ablate KIND): what each deviation costs")
    args = ap.parse_args(argv)
    if args.paired:
        import json

        base = json.load(open(args.paired[0], encoding="utf-8"))["cases"]
        for path in args.paired[1:]:
            p = paired(base, json.load(open(path, encoding="utf-8"))["cases"])
            w, o = p["with"], p["without"]
            print(f"{p['kind']:9s} {p['cases']:2d} cases, {p['predictions']:3d} measured-mode predictions: |err| median "
                  f"{w['error_median_pct']:.3f} -> {o['error_median_pct']:.3f} %, p90 {w['error_p90_pct']:.2f} -> "
                  f"{o['error_p90_pct']:.2f}, max {w['error_max_pct']:.2f} -> {o['error_max_pct']:.2f}; coverage "
                  f"{w['coverage']:.0%} -> {o['coverage']:.0%}")
        return 0
    per_kind: dict[str, list] = {k: [] for k in KINDS if k != "lowgrade"}
    for i in range(args.n):
        case = make_case(args.split, i)
        att = attribute(case)
        print(f"{case.name:26s} " + "  ".join(f"{k} {np.abs(v).max():.2f}" for k, v in att.items()), flush=True)
        for k, v in att.items():
            per_kind[k].append(np.abs(v))
    print(f"\n|change of the transfer ratio| when the deviation is removed [%] ({args.split}, {args.n} cases)")
    print(f"{'deviation':10s} {'cases':>5s} {'mode 1 med':>10s} {'max':>6s} {'mode 2 med':>10s} {'max':>6s} {'mode 3 med':>10s} {'max':>6s}")
    for k, vals in per_kind.items():
        if not vals:
            continue
        v = np.concatenate(vals)  # (queries, 3)
        cols = " ".join(f"{np.median(v[:, m]):10.3f} {v[:, m].max():6.2f}" for m in range(3))
        print(f"{k:10s} {len(vals):5d} {cols}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
