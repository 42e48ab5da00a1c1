"""Do observed cuts narrow the lobes' band, and rightly? (``taptune.machine.observed``)

``python -m benchmarks.cut.bench_observations [--trials N] [--cuts K] [--seed S]``

The tool is the 2-mode end mill of bench_cut (3 teeth, half immersion, down-milling). Its
model is off: the near-optimal parameter sets are 17 tool-point FRFs with every mode
frequency scaled by 0.96–1.04 (what a ±2–4 % band of the bending frequencies does to the
tool point), while the true tool's scale is drawn in 0.97–1.03. K cuts at random speeds and
depths near the predicted limit are simulated (the milling simulation with the regenerative
delay, linear: growth per tooth period < 1 is stable) and their verdicts weigh the sets.

Printed, before and after the weighing: the band's relative width (q95 − q5)/q50 over the
speeds, how often the true limit (the lobes of the true FRF) lies inside the band, and how
often the band's median predicts the verdict of 200 new random cuts right (truth: the true lobes).
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from benchmarks.cut.bench_cut import CONFIGS, KRC, KTC
from taptune.machine.lobes import stability_lobes
from taptune.machine.observed import set_weights, weighted_band
from taptune.machine.simulate import simulate_milling

SCALES = np.linspace(0.96, 1.04, 17)


def lobes_of(cfg, scale: float, rpm) -> np.ndarray:
    f = np.linspace(100, 6000, 5901)
    mx, my = cfg["mx"].scaled(freq_factor=scale), cfg["my"].scaled(freq_factor=scale)
    lb = stability_lobes(f, mx.frf(f), my.frf(f), teeth=cfg["teeth"], ktc=KTC, krc=KRC, diameter=cfg["diameter"],
                         ae=cfg["ae"], milling=cfg["milling"], rpm=rpm)
    return np.asarray(lb.a_lim)


def simulated_verdict(cfg, scale: float, rpm: float, depth: float) -> str:
    mx, my = cfg["mx"].scaled(freq_factor=scale), cfg["my"].scaled(freq_factor=scale)
    run = simulate_milling(mx, my, teeth=cfg["teeth"], ktc=KTC, krc=KRC, diameter=cfg["diameter"], ae=cfg["ae"],
                           milling=cfg["milling"], rpm=rpm, depth=[depth], duration_s=0.3, fs=4000,
                           feed_per_tooth=0.0, steps=40, rng=np.random.default_rng(1), contact_loss=False)
    return "chatter" if float(np.atleast_1d(run.growth)[0]) > 1.0 else "stable"


def main(argv=None) -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--trials", type=int, default=10)
    p.add_argument("--cuts", type=int, default=4)
    p.add_argument("--seed", type=int, default=0)
    args = p.parse_args(argv)
    cfg = CONFIGS[0]
    rng = np.random.default_rng(args.seed)
    rpm = np.arange(5000.0, 14001.0, 20.0)
    sets = np.array([lobes_of(cfg, s, rpm) for s in SCALES])
    flat = np.full(len(SCALES), 1 / len(SCALES))
    before = weighted_band(sets, flat)
    stats = {k: [] for k in ("width0", "width1", "cover0", "cover1", "right0", "right1", "top_scale_err")}
    t0 = time.time()
    for trial in range(args.trials):
        true_scale = float(rng.uniform(0.97, 1.03))
        truth = lobes_of(cfg, true_scale, rpm)
        idx = rng.integers(len(rpm), size=args.cuts)
        depths = before[1, idx] * rng.uniform(0.6, 1.5, size=args.cuts)
        verdicts = [simulated_verdict(cfg, true_scale, rpm[i], d) for i, d in zip(idx, depths)]
        w = set_weights(sets[:, idx], depths, verdicts)
        after = weighted_band(sets, w)
        for tag, band in (("0", before), ("1", after)):
            stats["width" + tag].append(np.median((band[2] - band[0]) / band[1]))
            stats["cover" + tag].append(np.mean((truth >= band[0] * 0.999) & (truth <= band[2] * 1.001)))
            test = rng.integers(len(rpm), size=200)
            d = truth[test] * np.exp(rng.uniform(-0.4, 0.4, size=200))
            stats["right" + tag].append(np.mean((d < band[1, test]) == (d < truth[test])))
        stats["top_scale_err"].append(abs(SCALES[np.argmax(w)] - true_scale))
        print(f"  trial {trial}: true scale {true_scale:.4f}, {sum(v == 'chatter' for v in verdicts)}/{args.cuts} "
              f"chatter, most likely set {SCALES[np.argmax(w)]:.3f}, width {stats['width0'][-1]:.2f} -> "
              f"{stats['width1'][-1]:.2f} ({time.time() - t0:.0f} s)", flush=True)
    print(f"\n{args.trials} trials, {args.cuts} observed cuts each")
    print(f"band width (q95-q5)/q50, median over speeds: {np.mean(stats['width0']):.2f} -> {np.mean(stats['width1']):.2f}")
    print(f"true limit inside the band: {100 * np.mean(stats['cover0']):.0f} % -> {100 * np.mean(stats['cover1']):.0f} % of speeds")
    print(f"new cuts' verdicts right by the band's median: {100 * np.mean(stats['right0']):.0f} % -> "
          f"{100 * np.mean(stats['right1']):.0f} %")
    print(f"most likely set's frequency scale off the truth by {100 * np.mean(stats['top_scale_err']):.2f} % (mean)")


if __name__ == "__main__":
    main()
