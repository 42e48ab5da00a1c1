"""Semi-discretization before/after a change: the same cuts through an older ``sdm.py`` and this one.

Cases: the 1-DOF milling benchmark (Insperger & Stépán 2004: 2 teeth, f_n 922 Hz, ζ 0.011,
k 1.34e6 N/m, K_t 6e8, K_n 2e8 N/m²) at a/D = 1, 0.1, 0.05 down-milling; a 2-mode end mill
(2.9 and 4.3 kHz) at a/D = 1, 0.1, 0.05, down and up; the 3+3-mode tool point of
``bench_lobes.py`` (4 teeth, a/D 0.05). Every case runs ``stability_lobes(method="sdm")``
on a 10 rpm grid over 5,000–25,000 rpm (``--low`` adds 500–5,000 rpm to the "after" run
only: the old code left it to the zero-order lobes). Prints per case the median and 95th
percentile of |a_after / a_before − 1| over speeds both computed, the share of speeds whose
flip/Hopf label differs (speeds the old code left to the zero-order lobes are left
out), the lowest limit of each and CPU seconds of each.

    nice -n 10 python benchmarks/compare_sdm.py --before-rev 70c0c84 [--cases bench05,mill05d]
"""

from __future__ import annotations

import argparse
import importlib.util
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))


def _cases():
    from taptune.machine.simulate import ModalSet

    bench = (ModalSet([922.0], [0.011], [1.34e6]), None)
    mill = (ModalSet([2900.0, 4300.0], [0.012, 0.02], [2.0e7, 6.0e7]),
            ModalSet([2880.0, 4350.0], [0.012, 0.02], [1.8e7, 6.5e7]))
    tool3 = (ModalSet([2900.0, 4300.0, 6100.0], [0.012, 0.02, 0.03], [2.0e7, 6.0e7, 9.0e7]),
             ModalSet([2880.0, 4350.0, 6000.0], [0.012, 0.02, 0.03], [1.8e7, 6.5e7, 9.0e7]))
    out = {}
    for r, tag in ((1.0, "1"), (0.1, "10"), (0.05, "05")):
        out[f"bench{tag}"] = (bench, dict(teeth=2, ktc=6e8, krc=2e8, diameter=20e-3, ae=r * 20e-3, milling="down"))
        for m in ("down", "up"):
            out[f"mill{tag}{m[0]}"] = (mill, dict(teeth=2, ktc=902e6, krc=243e6, diameter=20e-3, ae=r * 20e-3,
                                                  milling=m))
    out["tool3"] = (tool3, dict(teeth=4, ktc=902e6, krc=243e6, diameter=20e-3, ae=1e-3, milling="down"))
    return out


def _load_before(rev: str):
    text = subprocess.run(["git", "-C", str(REPO), "show", f"{rev}:taptune/machine/sdm.py"], check=True,
                          capture_output=True, text=True).stdout
    path = Path(tempfile.mkdtemp()) / "sdm_before.py"
    path.write_text(text)
    spec = importlib.util.spec_from_file_location("taptune.machine.sdm_before", path)
    mod = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = mod  # dataclasses look their module up
    spec.loader.exec_module(mod)
    if not hasattr(mod, "AUTO_BUDGET"):  # before the time budget of method="auto"
        plain = mod.sdm_lobes
        mod.AUTO_BUDGET = None
        mod.sdm_lobes = lambda *a, budget=None, **k: plain(*a, **k)
    return mod


def _run(module, modes, cut, rpm):
    import numpy as np

    from taptune.machine import stability_lobes

    f = np.arange(100.0, 9000.0, 2.0)
    saved = sys.modules["taptune.machine.sdm"]
    sys.modules["taptune.machine.sdm"] = module
    try:
        c0 = time.process_time()
        gy = modes[1].frf(f) if modes[1] is not None else None
        lob = stability_lobes(f, modes[0].frf(f), gy, rpm=rpm, method="sdm", modes=modes, **cut)
        return lob, time.process_time() - c0
    finally:
        sys.modules["taptune.machine.sdm"] = saved


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--before-rev", default="main", help="git revision of the old sdm.py")
    parser.add_argument("--cases", default="", help="comma-separated case names (default: all)")
    parser.add_argument("--low", action="store_true", help="the 'after' run starts at 500 rpm")
    args = parser.parse_args()

    import numpy as np

    import taptune.machine.sdm as after

    before = _load_before(args.before_rev)
    for mod in (before, after):
        mod.PARALLEL_WORK = float("inf")  # CPU of one process, comparable
    cases = _cases()
    names = [c for c in args.cases.split(",") if c] or list(cases)
    rpm = np.arange(5000.0, 25000.0 + 1, 10.0)
    print(f"{'case':9s} {'median %':>8s} {'p95 %':>7s} {'labels %':>8s} {'a_min old':>10s} {'a_min new':>10s} "
          f"{'cpu old':>8s} {'cpu new':>8s}")
    meds = []
    for name in names:
        modes, cut = cases[name]
        old, t_old = _run(before, modes, cut, rpm)
        grid = np.concatenate([np.arange(500.0, 5000.0, 10.0), rpm]) if args.low else rpm
        new, t_new = _run(after, modes, cut, grid)
        a_new = new.a_lim[-rpm.size:]
        # Speeds the old code left to the zero-order lobes are no comparison of the SDM.
        zoa_below = [float(w.split("below ")[1].split(" rpm")[0]) for w in old.warnings if "zero-order" in w]
        sdm_old = rpm > (max(zoa_below) if zoa_below else 0.0)
        both = np.isfinite(old.a_lim) & np.isfinite(a_new) & sdm_old
        rel = np.abs(a_new[both] / old.a_lim[both] - 1)
        flip_new = np.asarray(new.flip[-rpm.size:])
        labels = np.mean(np.asarray(old.flip)[both] != flip_new[both])
        meds.append(np.median(rel))
        low = f" (500-5000 rpm: lowest {1e3 * np.nanmin(new.a_lim[:-rpm.size]):.3f} mm)" if args.low else ""
        old_zoa = f" (old: ZOA below {max(zoa_below):.0f} rpm)" if zoa_below else ""
        print(f"{name:9s} {100 * np.median(rel):8.3f} {100 * np.percentile(rel, 95):7.3f} {100 * labels:8.2f} "
              f"{1e3 * np.min(old.a_lim):10.4f} {1e3 * np.min(new.a_lim):10.4f} {t_old:8.2f} {t_new:8.2f}{low}{old_zoa}"
              + (f"  warnings: {'; '.join(new.warnings)}" if new.warnings else ""))
    print(f"median over cases of the median difference: {100 * np.median(meds):.3f} %")


if __name__ == "__main__":
    main()
