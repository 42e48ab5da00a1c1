"""Which global optimiser finds the optimum more reliably per evaluation?

taptune's vectorised real-coded GA versus nlopt's evolutionary strategy (GN_ESCH) and
controlled random search (GN_CRS2_LM), each followed by the same BOBYQA polish, on
noise-free identification problems: the reference assembly (MODEL.md §13.4) with holder
parameters drawn inside the search space, "measured" spectrum = the model's own tip
receptance. Success = objective below 0.01 after the polish (every frequency within
0.05 % and the window shape within 0.5 % RMS).

Run: ``python benchmarks/compare_optimizers.py [problems] [budget]``.
"""

from __future__ import annotations

import os
import sys
import time

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
sys.path.insert(0, os.path.join(os.path.dirname(__file__), ".."))

import numpy as np  # noqa: E402

from taptune.identify.objective import Objective, make_target  # noqa: E402
from taptune.identify.optimize import GAOptions, genetic_algorithm, polish  # noqa: E402
from taptune.io.assembly import load_assembly  # noqa: E402
from taptune.model import build_model, solve_modes, tip_receptance  # noqa: E402
from taptune.model.params import from_p, unit_to_p  # noqa: E402
from taptune.model.reduced import FastEvaluator  # noqa: E402

REPO = os.path.join(os.path.dirname(__file__), "..")
SUCCESS = 0.01


def problem(assembly, rng):
    """A random holder inside a realistic part of the search space and its noise-free target."""
    u = rng.uniform([0.75, 0.3, 0.3, 0.3, 0.1, 0.1, 0.1], [0.95, 0.9, 0.9, 0.9, 0.9, 0.9, 0.9])
    params = from_p(unit_to_p(u))
    fe = build_model(assembly)
    freq = np.arange(0.5, 22000.0, 0.5)
    modes = solve_modes(fe, params, 3)
    target = make_target(freq, np.abs(tip_receptance(fe, params, freq)), {n + 1: f for n, f in enumerate(modes.frequency_hz[:3])})
    return target


def run_ga(objective, budget, rng):
    pop = 64
    ga = genetic_algorithm(lambda U: objective.batch(unit_to_p(U)), 7, rng, GAOptions(population=pop, generations=budget // pop - 1, patience=10**6))
    return ga.u


def run_nlopt(algorithm):
    def runner(objective, budget, rng):
        import nlopt

        opt = nlopt.opt(algorithm, 7)
        opt.set_lower_bounds(np.zeros(7))
        opt.set_upper_bounds(np.ones(7))
        opt.set_population(64)
        nlopt.srand(int(rng.integers(1 << 30)))
        best = [None, np.inf]

        def f(u, grad):
            value = objective(unit_to_p(u))
            if value < best[1]:
                best[0], best[1] = np.array(u), value
            return value

        opt.set_min_objective(f)
        opt.set_maxeval(budget)
        try:
            opt.optimize(rng.random(7))
        except (RuntimeError, ValueError):
            pass
        return best[0]

    return runner


def main():
    import nlopt

    n_problems = int(sys.argv[1]) if len(sys.argv) > 1 else 6
    budgets = [int(sys.argv[2])] if len(sys.argv) > 2 else [2000, 5000]
    assembly = load_assembly(os.path.join(REPO, "assets", "er32_hsk63_d16.toml"))
    evaluator = FastEvaluator(assembly)
    rng = np.random.default_rng(7)
    targets = [problem(assembly, rng) for _ in range(n_problems)]
    methods = {"taptune GA": run_ga, "nlopt GN_ESCH": run_nlopt(nlopt.GN_ESCH), "nlopt GN_CRS2_LM": run_nlopt(nlopt.GN_CRS2_LM)}
    print(f"{n_problems} noise-free problems, reference assembly; success = J < {SUCCESS} after a 300-evaluation BOBYQA polish")
    print(f"{'method':18s} {'budget':>7s} {'success':>8s} {'median J':>10s} {'s/run':>7s}")
    for budget in budgets:
        for name, method in methods.items():
            values, t0 = [], time.perf_counter()
            for i, target in enumerate(targets):
                objective = Objective([target], [evaluator])
                u = method(objective, budget, np.random.default_rng(100 + i))
                _, value, _ = polish(lambda x: objective(unit_to_p(x)), u, 300)
                values.append(value)
            values = np.array(values)
            print(f"{name:18s} {budget:7d} {np.mean(values < SUCCESS):8.0%} {np.median(values):10.3g} {(time.perf_counter() - t0) / len(targets):7.2f}")


if __name__ == "__main__":
    main()
