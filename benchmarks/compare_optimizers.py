"""How far is taptune's GA from strong references, per evaluation, on real identification problems?

Each method gets the same objective (docs/physics.md §4, reduced evaluator), the same
least-squares polish and the same near-optimal set (archive members plus the extreme pushes of
:mod:`taptune.identify.uncertainty`), so only the global stage differs:

* ``taptune GA``: :func:`taptune.identify.identify` as shipped (islands, polishes, set);
* ``CMA-ES BIPOP``: pycma with bi-population restarts (``pip install cma``, the ``dev``
  extra) on the unit cube;
* ``DE``: ``scipy.optimize.differential_evolution`` (best1bin, Latin-hypercube start).

Problems: the in-family cases of ``bench_identify.py`` (bundled examples and, when present,
``../shared/cases-dev``) and, with ``--realism N``, the first N validation cases of the
realism corpus (holders outside the model family; needs ``benchmarks/realism`` from the
realism work, found here or in ``--realism-root``). Per method the table prints the
evaluations, the objective reached (median; J of the best set member on the reduced
model), the transfer error at the other stick-outs (median, max), the share of truths
inside the reported band, the band's mean half-width and the CPU seconds.

Run: ``python benchmarks/compare_optimizers.py [--budget N] [--realism N] [--seed N]``.
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from dataclasses import replace
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))
sys.path.insert(1, str(REPO / "benchmarks"))

import numpy as np  # noqa: E402

from taptune.identify import IdentifyOptions, identify, predict, search  # noqa: E402
from taptune.identify.core import bending_peaks  # noqa: E402
from taptune.identify.objective import Objective, make_target  # noqa: E402
from taptune.identify.optimize import Archive, polish_least_squares  # noqa: E402
from taptune.identify.pipeline import analyse_for_assembly  # noqa: E402
from taptune.io.assembly import load_assembly  # noqa: E402
from taptune.io.audio import read_audio  # noqa: E402
from taptune.model.params import from_p, to_p, unit_to_p  # noqa: E402
from taptune.model.reduced import FastEvaluator  # noqa: E402


def in_family():
    """(name, analysis, assembly, [(target assembly, truth f1–f3)]) of bench_identify's cases."""
    from bench_identify import cases

    for name, wav, toml, other in cases():
        asm = load_assembly(toml)
        queries = [(load_assembly(path) if path else asm.with_stickout(so * 1e-3), truth)
                   for so, (truth, path) in sorted(other.items())]
        yield name, analyse_for_assembly(read_audio(wav), asm), asm, queries


def realism(n: int, root: Path):
    """The first n validation cases of the realism corpus (outside the model family)."""
    sys.path.insert(2, str(root))
    from benchmarks.realism.audio import record
    from benchmarks.realism.corpus import make_corpus

    for case in make_corpus("validation", n):
        queries = [(case.described_at(q.stickout_mm), q.truth.bending_hz) for q in case.queries]
        try:
            analysis = analyse_for_assembly(record(case), case.described)
            bending_peaks(analysis)[1]
        except Exception as err:  # a case whose labels fail says nothing about the optimisers
            print(f"  (skipped {case.name}: {err})")
            continue
        yield f"real {case.name}", analysis, case.described, queries


def cma_bipop(f, budget, rng):
    import cma

    x, es = cma.fmin2(f, 0.5 * np.ones(7), 0.3, options={
        "bounds": [0, 1], "maxfevals": budget, "seed": int(rng.integers(1, 2**31)), "verbose": -9,
        "tolfun": 1e-6}, restarts=9, bipop=True)
    return np.clip(es.result.xbest if es.result.xbest is not None else x, 0, 1)


def differential_evolution(f, budget, rng):
    from scipy.optimize import differential_evolution as de

    popsize = 10  # × 7 parameters per generation
    r = de(f, [(0.0, 1.0)] * 7, popsize=popsize, maxiter=max(1, budget // (popsize * 7) - 1), tol=1e-3,
           init="latinhypercube", polish=False, seed=np.random.default_rng(rng.integers(2**31)))
    return r.x


def reference(global_stage, budget):
    """identify()'s polish and near-optimal set around another global optimiser."""

    def run(analysis, assembly, options):
        target = make_target(analysis.freq_hz, analysis.magnitude, bending_peaks(analysis), options.objective)
        objective = Objective([target], [FastEvaluator(assembly)], options.objective)
        archive = Archive()

        def f(u):
            u = np.clip(np.asarray(u, dtype=float), 0, 1)
            value = objective(unit_to_p(u))
            archive.add(u, np.array([value]))
            return value

        u0 = global_stage(f, budget, np.random.default_rng(options.seed))
        u, value, _ = polish_least_squares(lambda x: objective.residuals(unit_to_p(x)), u0, options.polish_evaluations,
                                           archive=archive)
        au, af = archive.arrays()
        keep = af <= value + options.polish_band + search.near_band(value, options, search.n_modes(objective))
        best = search.RunResult(u, value, 0, au[keep], af[keep])
        with search.Workers(objective, replace(options, jobs=1)) as workers:
            members, extra = search.near_optimal_set(objective, workers, [best], best, options)
        return [from_p(unit_to_p(m)) for m in members], objective.evaluations + extra

    return run


def shipped(analysis, assembly, options):
    r = identify([analysis], [assembly], options)
    return list(r.param_sets), r.evaluations


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--budget", type=int, default=6000, help="global-stage evaluations of the references")
    ap.add_argument("--realism", type=int, default=0, help="also the first N realism validation cases")
    ap.add_argument("--realism-root", default=str(REPO), help="worktree holding benchmarks/realism")
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args()
    problems = list(in_family())
    if args.realism:
        problems += list(realism(args.realism, Path(args.realism_root)))
    methods = {"taptune GA": shipped, "CMA-ES BIPOP": reference(cma_bipop, args.budget),
               "DE best1bin": reference(differential_evolution, args.budget)}
    options = IdentifyOptions(seed=args.seed, jobs=1)
    print(f"{len(problems)} problems; references: {args.budget} global evaluations, then the same polish and set; "
          f"load average {os.getloadavg()[0]:.1f}")
    print(f"{'method':14s} {'group':9s} {'evals':>6s} {'J med':>7s} {'err med [%]':>11s} {'err max [%]':>11s} "
          f"{'inside':>6s} {'± [%]':>6s} {'CPU [s]':>7s}")
    for name, method in methods.items():
        rows = {"in-family": [], "realism": []}
        for label, analysis, assembly, queries in problems:
            c0 = time.process_time()
            sets, evaluations = method(analysis, assembly, options)
            cpu = time.process_time() - c0
            target = make_target(analysis.freq_hz, analysis.magnitude, bending_peaks(analysis), options.objective)
            j = Objective([target], [FastEvaluator(assembly)], options.objective)(to_p(sets[0]))
            err, inside, width = [], [], []
            for asm, truth in queries:
                p = predict(sets, asm)
                f, s, t = np.array(p.bending_hz), np.array(p.bending_hz_spread), np.array(truth)
                err.extend(np.abs(f / t - 1) * 100)
                inside.extend(np.abs(f - t) <= s)
                width.extend(s / f * 100)
            rows["realism" if label.startswith("real") else "in-family"].append((evaluations, j, err, inside, width, cpu))
        for group, r in rows.items():
            if not r:
                continue
            err = np.concatenate([x[2] for x in r])
            print(f"{name:14s} {group:9s} {np.median([x[0] for x in r]):6.0f} {np.median([x[1] for x in r]):7.3f} "
                  f"{np.median(err):11.3f} {err.max():11.3f} {np.mean(np.concatenate([x[3] for x in r])):6.0%} "
                  f"{np.mean(np.concatenate([x[4] for x in r])):6.3f} {np.median([x[5] for x in r]):7.2f}", flush=True)


if __name__ == "__main__":
    main()
