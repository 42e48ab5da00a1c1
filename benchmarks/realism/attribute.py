"""How far each deviation takes a case outside the model family, without identifying anything.

A deviation that scales a mode's frequency by the same factor at every stick-out is
absorbed by the fit (the holder parameters soak it up); what no fit can absorb is how it
changes the TRANSFER RATIO f(query) / f(recorded). For every case and every deviation it
has, this prints the change of that ratio when the deviation is removed
(:func:`~benchmarks.realism.corpus.without`), per mode, in %.

Run: ``python -m benchmarks.realism.attribute --split validation --n 24``.
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


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--split", default="validation")
    ap.add_argument("--n", type=int, default=24)
    args = ap.parse_args(argv)
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
