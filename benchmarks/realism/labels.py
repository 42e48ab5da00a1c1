"""Bending labels on the realism corpus, without identification (cheap: seconds per case).

Run: ``python -m benchmarks.realism.labels [--split validation] [--tier harsh] [--n 24] [--guidance-only]``.

For each case: record it, analyse it with the DESCRIBED assembly as the product does
before fitting (:func:`taptune.identify.pipeline.analyse_for_assembly`: model guidance,
then the label decision by the fast model unless ``--guidance-only``) and judge the labels
against the truth's audible modes (:func:`benchmarks.realism.run.judge_labels`: a mode is
audible when its noise-free peak stands ≥ 6 dB over the noise between taps). Prints the
cases' labels, the audible modes labelled right, missed (and why: no peak picked, or a
peak there given another label) and labelled wrong, and the wrong labels on inaudible
modes (a false label).
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
sys.path.insert(0, str(Path(__file__).resolve().parents[2]))

from benchmarks.realism.audio import audibility_margins, record  # noqa: E402
from benchmarks.realism.corpus import TIERS, make_case  # noqa: E402
from benchmarks.realism.run import judge_labels  # noqa: E402


def label_case(split: str, index: int, tier: str, decide: bool) -> tuple[object, list[dict]]:
    """(case, judged labels) of one corpus case."""
    from taptune.identify.pipeline import analyse_for_assembly

    case = make_case(split, index, tier=tier)
    rec = record(case)
    analysis = analyse_for_assembly(rec, case.described, decide_labels=decide)
    return case, judge_labels(case, analysis, audibility_margins(case, analysis))


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--split", default="validation", choices=("calibration", "validation", "infamily"))
    ap.add_argument("--tier", default="harsh", choices=TIERS)
    ap.add_argument("--n", type=int, default=24)
    ap.add_argument("--start", type=int, default=0)
    ap.add_argument("--guidance-only", action="store_true", help="the guidance's labels, without the fast-model decision")
    args = ap.parse_args(argv)
    t0 = time.process_time()
    audible = right = missed_no_peak = missed_mislabelled = wrong = false_labels = 0
    for i in range(args.start, args.start + args.n):
        case, labels = label_case(args.split, i, args.tier, not args.guidance_only)
        row = []
        for lab in labels:
            mark = ("ok" if lab["right"] else "WRONG" if lab["wrong_peak"] else
                    "miss(peak)" if lab["peak_at_truth"] is not None else "miss") if lab["audible"] else \
                ("FALSE" if lab["wrong_peak"] else "-")
            margin = "" if lab["margin_db"] is None else f"{lab['margin_db']:.0f}dB"
            row.append(f"f{lab['mode']} {lab['truth_hz']:.0f} {margin} {mark}")
            if lab["audible"]:
                audible += 1
                right += lab["right"]
                wrong += lab["wrong_peak"]
                if lab["labelled_hz"] is None:
                    missed_no_peak += lab["peak_at_truth"] is None
                    missed_mislabelled += lab["peak_at_truth"] is not None
            else:
                false_labels += lab["wrong_peak"]
        print(f"{case.name:28s} " + " | ".join(row), flush=True)
    print(f"\n{args.split}, {args.tier} tier, {args.n} cases, "
          f"{'guidance only' if args.guidance_only else 'guidance + fast-model decision'}: "
          f"audible bending modes labelled right {right}/{audible} ({100 * right / max(audible, 1):.0f} %); "
          f"missed {missed_no_peak} without a picked peak, {missed_mislabelled} with a peak given another label; "
          f"wrong peak {wrong}; false labels on inaudible modes {false_labels}  "
          f"(cpu {time.process_time() - t0:.0f} s)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
