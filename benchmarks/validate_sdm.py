"""taptune's semi-discretization against an independent, converged reference (and the time-domain simulation).

1. Convergence of the reference (``benchmarks/sdm_reference.py``: piecewise Chebyshev
   collocation written from the papers, sharing no code with taptune.machine): its limit
   at a few speeds of each case as the elements per mode period and their degree grow,
   until the change is far below 0.5 %.
2. The published values of the 1-DOF benchmark (2 teeth, K_t 6e8, K_n 2e8 N/m², 922 Hz,
   ζ 0.011, k 1.34e6 N/m, down-milling; Insperger & Stépán 2004, Int. J. Numer. Meth. Eng.
   61): lowest limit 1.09 mm (flip, near 18,200 rpm) at a/D 0.05 and 0.75 mm at a/D 0.1.
3. For the 1-DOF benchmark, a symmetric 2-mode end mill (2.8 and 3.4 kHz, 2 and 4
   teeth) and one with different modes in x and y (2 teeth), a/D 1, 0.1, 0.05, down and up,
   and the 3+3-mode tool of bench_lobes.py: ``sdm_lobes`` (with the zero-order guide, as
   ``taptune lobes`` runs it) against the reference at every 250 rpm from 5,000 to
   25,000 rpm: median and largest |a_sdm / a_ref − 1|, and how many speeds call the
   chatter flip or Hopf alike. Speeds the SDM leaves to the zero-order lobes are counted
   apart (and their difference shown, since that is what the user gets there).
4. With ``--simulation``: the time-domain check (taptune's own simulator, which shares
   the force law with the SDM, so only a consistency check).

    nice -n 10 python benchmarks/validate_sdm.py [--step 250] [--simulation]
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from benchmarks import sdm_reference as ref  # noqa: E402

#: The 1-DOF benchmark (Insperger & Stépán 2004): x flexible, y rigid.
BENCH_MODES = (ref.Mode("x", 922.0, 0.011, 1.34e6),)
BENCH_CUT = dict(kt=6e8, kn=2e8, diameter=20e-3)
#: A symmetric 2-mode end mill, modes near 3 kHz; Al 7050 coefficients (Altintas 2012, ch. 3).
MILL_MODES = tuple(ref.Mode(d, f, z, k) for d in "xy" for f, z, k in ((2800.0, 0.02, 2.5e7), (3400.0, 0.03, 4.0e7)))
MILL_CUT = dict(kt=7.96e8, kn=1.68e8, diameter=12e-3)
#: With x = y, up- and down-milling of the same a/D are one cut seen in a turned frame (same
#: limits): a tool with different x and y modes tells them apart.
ASYM_MODES = MILL_MODES[:2] + (ref.Mode("y", 2650.0, 0.025, 2.2e7), ref.Mode("y", 3550.0, 0.03, 5.0e7))
#: The 3+3-mode tool point of bench_lobes.py / compare_sdm.py (4 teeth, a/D 0.05, down-milling): its
#: |μ| lingers near 1 over wide depth ranges, where a weakly unstable band is easy to step over.
TOOL3_MODES = tuple(ref.Mode(d, f, z, k) for d, ms in (("x", ((2900.0, 0.012, 2.0e7), (4300.0, 0.02, 6.0e7),
                                                             (6100.0, 0.03, 9.0e7))),
                                                      ("y", ((2880.0, 0.012, 1.8e7), (4350.0, 0.02, 6.5e7),
                                                             (6000.0, 0.03, 9.0e7))))
                    for f, z, k in ms)
TOOL3_CUT = dict(kt=902e6, kn=243e6, diameter=20e-3)
RATIOS = (1.0, 0.1, 0.05)
#: Resolutions of the convergence table: (elements per period of the fastest mode, degree).
LADDER = ((1, 6), (1, 8), (2, 8), (2, 10), (3, 12), (4, 14))


def cases():
    """(name, modes, Cut) of every compared case."""
    out = []
    for name, modes, tool, teeth_list in (("1-DOF benchmark", BENCH_MODES, BENCH_CUT, (2,)),
                                          ("2-mode end mill", MILL_MODES, MILL_CUT, (2, 4)),
                                          ("2-mode end mill, x ≠ y", ASYM_MODES, MILL_CUT, (2,))):
        for teeth in teeth_list:
            for r in RATIOS:
                for milling in ("down", "up"):
                    cut = ref.Cut(teeth=teeth, ae=r * tool["diameter"], milling=milling, **tool)
                    out.append((f"{name}, {teeth} teeth, a/D {r:g}, {milling}", modes, cut))
    out.append(("3+3-mode tool, 4 teeth, a/D 0.05, down", TOOL3_MODES,
                ref.Cut(teeth=4, ae=0.05 * TOOL3_CUT["diameter"], milling="down", **TOOL3_CUT)))
    return out


def taptune_modes(modes):
    """The same modes as taptune's ModalSet pair (y None when it has none: rigid)."""
    from taptune.machine.simulate import ModalSet

    sets = []
    for d in "xy":
        ms = [m for m in modes if m.direction == d]
        sets.append(ModalSet([m.f_hz for m in ms], [m.zeta for m in ms], [m.k for m in ms]) if ms else None)
    return tuple(sets)


def taptune_sdm(modes, cut, rpm):
    """taptune's SDM limits [m] and flip flags at ``rpm`` (NaN where it leaves a speed to the
    zero-order lobes), the zero-order limits, and the warnings."""
    from taptune.machine.lobes import zoa_lobes
    from taptune.machine.sdm import sdm_lobes

    f = np.arange(100.0, 8000.0, 1.0)
    gx, gy = ref.frf(modes, f)
    if not np.any(gy):
        gy = 1e-9 * gx  # rigid y (the zero-order lobes only guide the search)
    kw = dict(teeth=cut.teeth, ktc=cut.kt, krc=cut.kn, diameter=cut.diameter, ae=cut.ae, milling=cut.milling)
    zoa = zoa_lobes(f, gx, gy, rpm=rpm, **kw)
    order = np.argsort(zoa.rpm)

    def guide(r):
        return np.interp(r, zoa.rpm[order], np.where(np.isfinite(zoa.a_lim), zoa.a_lim, zoa.a_crit)[order])

    mx, my = taptune_modes(modes)
    s = sdm_lobes(mx, my, rpm=rpm, guide=guide, **kw)
    return s.a_lim, s.flip, zoa.a_lim, s.warnings


def convergence(speeds_per_case: int = 3) -> None:
    print("1. Convergence of the reference: limit [mm] as the resolution grows "
          "(elements per period of the fastest mode × degree)")
    print("   " + " ".join(f"{e}×{p:<2d}".rjust(10) for e, p in LADDER) + "   last change")
    worst = 0.0
    for name, modes, cut in cases():
        if cut.milling == "up" and cut.ae >= cut.diameter:
            continue  # slotting: up and down are the same cut
        for rpm in np.linspace(5000.0, 25000.0, speeds_per_case):
            row = []
            start = None
            for e, p in LADDER:
                mono = ref.Monodromy(modes, cut, rpm, per_period=e, degree=p)
                a, _ = ref.limit_at(mono, start or ref._static_scale(modes, cut) * 5, rtol=1e-9)
                start = 0.9 * a
                row.append(a)
            change = abs(row[-1] / row[-2] - 1)
            worst = max(worst, abs(row[3] / row[-1] - 1))
            print(f"   {' '.join(f'{a * 1e3:10.6f}' for a in row)}   {change:.1e}   {name}, {rpm:.0f} rpm")
    print(f"   used: {LADDER[3][0]} elements per mode period, degree {LADDER[3][1]}: largest difference from "
          f"the finest {worst:.1e}", flush=True)


def published() -> None:
    print("\n2. Published values, 1-DOF benchmark, down-milling (Insperger & Stépán 2004)")
    for r, paper in ((0.05, "1.09 mm, flip, near 18,200 rpm"), (0.1, "0.75 mm")):
        cut = ref.Cut(teeth=2, ae=r * BENCH_CUT["diameter"], milling="down", **BENCH_CUT)
        coarse = np.arange(5000.0, 25001.0, 100.0)
        lim = ref.limits(BENCH_MODES, cut, coarse)
        i = int(np.argmin(lim.a_lim))
        fine = np.arange(coarse[max(i - 1, 0)], coarse[min(i + 1, coarse.size - 1)] + 1e-9, 5.0)
        lim_f = ref.limits(BENCH_MODES, cut, fine, floor=0.7 * lim.a_lim[i])
        j = int(np.argmin(lim_f.a_lim))
        a_t, flip_t, _, _ = taptune_sdm(BENCH_MODES, cut, coarse)
        k = int(np.nanargmin(a_t))
        print(f"   a/D {r:g}: reference {lim_f.a_lim[j] * 1e3:.3f} mm, {lim_f.kind[j]}, at {fine[j]:.0f} rpm; "
              f"taptune SDM {a_t[k] * 1e3:.3f} mm, {'flip' if flip_t[k] else 'hopf'}, at {coarse[k]:.0f} rpm; "
              f"paper {paper}", flush=True)


def compare(step: float) -> list:
    print(f"\n3. taptune's sdm_lobes against the reference, 5,000–25,000 rpm every {step:g} rpm")
    speeds = np.arange(5000.0, 25000.0 + 1e-9, step)
    rows = []
    done = {}
    for name, modes, cut in cases():
        t0 = time.process_time()
        key = (modes, cut.teeth, cut.ae, cut.milling if cut.ae < cut.diameter else "slot")  # slotting: up = down
        if key not in done:
            done[key] = ref.limits(modes, cut, speeds)
        lim = done[key]
        t_ref = time.process_time() - t0
        a_t, flip_t, zoa, _ = taptune_sdm(modes, cut, speeds)
        sdm = np.isfinite(a_t)
        both = sdm & np.isfinite(lim.a_lim)
        err = np.abs(a_t[both] / lim.a_lim[both] - 1)
        same = int(np.sum(flip_t[both] == (lim.kind[both] == "flip")))
        handed = ~sdm
        near = err[err <= 0.03]
        line = (f"   {name:45s} median {np.median(err):6.2%}  max {err.max():6.2%} "
                f"({near.max():.2%} without the {err.size - near.size} speed(s) > 3 % apart)  "
                f"flip/Hopf alike {same}/{both.sum()}")
        if handed.any():
            e_z = np.abs(zoa[handed] / lim.a_lim[handed] - 1)
            line += (f"; {handed.sum()} speed(s) below {speeds[handed].max():.0f} rpm left to the zero-order "
                     f"lobes (off by median {np.median(e_z):.1%}, max {e_z.max():.1%})")
        print(line + f"   [reference {t_ref:.1f} s CPU]", flush=True)
        wrong = np.flatnonzero(both & (flip_t != (lim.kind == "flip")))
        for w in wrong[:3]:
            print(f"      label differs at {speeds[w]:.0f} rpm: taptune {'flip' if flip_t[w] else 'hopf'} "
                  f"{a_t[w] * 1e3:.4g} mm, reference {lim.kind[w]} {lim.a_lim[w] * 1e3:.4g} mm")
        rows.append((name, float(np.median(err)), float(err.max()), same, int(both.sum()), int(handed.sum()),
                     int(np.sum(err > 0.03))))
    med = np.array([r[1] for r in rows])
    print(f"   all cases: worst median {med.max():.2%}, labels alike at "
          f"{sum(r[3] for r in rows)}/{sum(r[4] for r in rows)} speeds, more than 3 % apart at "
          f"{sum(r[6] for r in rows)}; {sum(r[5] for r in rows)} speeds left to the zero-order lobes", flush=True)
    return rows


def simulation(n_speeds: int) -> None:
    """taptune's SDM against taptune's time-domain simulation (a consistency check only)."""
    from taptune.machine import stability_lobes
    from taptune.machine.simulate import ModalSet, simulate_milling

    print("\n4. taptune's SDM against taptune's time-domain simulation (same force law: a consistency check)")
    x = ModalSet([2900.0, 4300.0], [0.012, 0.02], [2.0e7, 6.0e7])
    y = ModalSet([2880.0, 4350.0], [0.012, 0.02], [1.8e7, 6.5e7])
    f = np.arange(200.0, 9000.0, 2.0)
    rng = np.random.default_rng(1)
    speeds = np.sort(rng.uniform(5000.0, 25000.0, n_speeds)).round(-1)
    factors = np.array([0.9, 0.95, 0.98, 1.02, 1.05, 1.1])
    for ae_ratio in RATIOS:
        for milling in ("down", "up"):
            cut = dict(teeth=2, ktc=902e6, krc=243e6, diameter=20e-3, ae=ae_ratio * 20e-3, milling=milling)
            lobes = stability_lobes(f, x.frf(f), y.frf(f), rpm=speeds, method="sdm", modes=(x, y), **cut)
            errs, same_kind = [], 0
            for rpm, a_s, kind in zip(speeds, lobes.a_lim, lobes.instability):
                run = simulate_milling(x, y, rpm=rpm, depth=a_s * factors, duration_s=80 * 60 / (2 * rpm), fs=5000,
                                       feed_per_tooth=1e-4, contact_loss=False, **cut)
                g = np.log(run.growth)
                cross = np.flatnonzero((g[:-1] < 0) & (g[1:] >= 0))
                if cross.size == 0:
                    errs.append(np.inf)
                    continue
                i = cross[0]
                a_t = np.interp(0.0, g[i:i + 2], a_s * factors[i:i + 2])
                errs.append(abs(a_t / a_s - 1))
                same_kind += bool(run.flip[i + 1]) == (kind == "flip")
            errs = np.array(errs)
            print(f"   a/D {ae_ratio:g} {milling:4}: {errs.size} speeds, median |a_t/a_s - 1| {np.median(errs):.3%}, "
                  f"max {errs.max():.3%}, same kind {same_kind}/{errs.size}", flush=True)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--step", type=float, default=250.0, help="speed step of the comparison [rpm]")
    parser.add_argument("--simulation", action="store_true", help="also the time-domain check (slow)")
    parser.add_argument("--speeds", type=int, default=6, help="speeds of the time-domain check")
    args = parser.parse_args()
    convergence()
    published()
    compare(args.step)
    if args.simulation:
        simulation(args.speeds)


if __name__ == "__main__":
    main()
