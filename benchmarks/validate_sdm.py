"""Semi-discretization against the time-domain simulation (an independent route to the same limit).

A 2-mode end mill (modes near 2.9 and 4.3 kHz, x and y slightly different), 2 teeth,
Ø20 mm, a/D = 1, 0.1 and 0.05, up- and down-milling. At speeds spread over
5,000–25,000 rpm the SDM limit a_s is computed (``stability_lobes(method="sdm")``); the
simulation (no loss of contact: the linear delay equation) runs a batch of depths around
it and the depth where its growth per tooth period crosses 1 is interpolated (a_t). Prints
per case the median and largest |a_t / a_s − 1| and whether both call the chatter flip or
Hopf alike; speeds where the SDM hands over to the zero-order lobes are counted apart.

    nice -n 10 python benchmarks/validate_sdm.py [--speeds 6]
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--speeds", type=int, default=6)
    args = parser.parse_args()

    import numpy as np

    from taptune.machine import stability_lobes
    from taptune.machine.simulate import ModalSet, simulate_milling

    x = ModalSet([2900.0, 4300.0], [0.012, 0.02], [2.0e7, 6.0e7])
    y = ModalSet([2880.0, 4350.0], [0.012, 0.02], [1.8e7, 6.5e7])
    f = np.arange(200.0, 9000.0, 2.0)
    rng = np.random.default_rng(1)
    speeds = np.sort(rng.uniform(5000.0, 25000.0, args.speeds)).round(-1)
    factors = np.array([0.9, 0.95, 0.98, 1.02, 1.05, 1.1])
    for ae_ratio in (1.0, 0.1, 0.05):
        for milling in ("down", "up"):
            cut = dict(teeth=2, ktc=902e6, krc=243e6, diameter=20e-3, ae=ae_ratio * 20e-3, milling=milling)
            lobes = stability_lobes(f, x.frf(f), y.frf(f), rpm=speeds, method="sdm", modes=(x, y), **cut)
            zoa_used = lobes.warnings and any("zero-order" in w for w in lobes.warnings)
            errs, same_kind, handed = [], 0, 0
            for rpm, a_s, kind in zip(speeds, lobes.a_lim, lobes.instability):
                if zoa_used and rpm < float(lobes.warnings[-1].split("below ")[1].split(" rpm")[0]) + 1:
                    handed += 1
                    continue
                run = simulate_milling(x, y, rpm=rpm, depth=a_s * factors, duration_s=80 * 60 / (2 * rpm), fs=5000,
                                       feed_per_tooth=1e-4, contact_loss=False, **cut)
                g = np.log(run.growth)
                cross = np.flatnonzero((g[:-1] < 0) & (g[1:] >= 0))
                if cross.size == 0:
                    errs.append(np.inf if g[0] >= 0 else np.inf)
                    continue
                i = cross[0]
                a_t = np.interp(0.0, g[i:i + 2], a_s * factors[i:i + 2])
                errs.append(abs(a_t / a_s - 1))
                same_kind += bool(run.flip[i + 1]) == (kind == "flip")
            errs = np.array(errs)
            print(f"a/D {ae_ratio:g} {milling:4}: {errs.size} speeds, median |a_t/a_s - 1| "
                  f"{np.median(errs) if errs.size else float('nan'):.3%}, max {errs.max() if errs.size else float('nan'):.3%}, "
                  f"same kind {same_kind}/{errs.size}; {handed} speed(s) left to the ZOA", flush=True)


if __name__ == "__main__":
    main()
