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
5. With ``--low`` (instead of 1–4): the low speeds, 500–5,000 rpm, where the cut spans many
   vibration periods (many history nodes) and the lobes are narrower than the ±1.5 % window
   a machinist can hold, so that taptune reports the lowest limit within that window
   (``DENSE_WINDOW`` in taptune/machine/sdm.py). The 3+3-mode tool and the symmetric 2-mode
   end mill (2 and 4 teeth, a/D 0.1 and 0.05, down-milling): the reference's convergence at
   low speed, then ``sdm_lobes`` on taptune's own 10 rpm grid from 500 to 5,000 rpm against
   the reference, point by point where taptune resolves the lobes and, in the dense part,
   taptune's lowest limit within the window against the reference's lowest over the same
   window (sampled ``LOBE_SAMPLES`` times per lobe of the fastest mode, each local minimum
   refined by Brent's method).

The reference's answers are cached (``--cache``, default ~/.cache/taptune/sdm_reference.json,
keyed by the case, the speeds, the reference's resolution and the text of sdm_reference.py),
so a rerun after a change to taptune's SDM takes only taptune's time.

    nice -n 10 python benchmarks/validate_sdm.py [--step 250] [--simulation] [--low] [--cache FILE | --no-cache]
"""

from __future__ import annotations

import argparse
import hashlib
import json
import os
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


#: Default file of the reference's cached answers (outside the repository).
CACHE = Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache") / "taptune" / "sdm_reference.json"


class ReferenceCache:
    """The reference's answers on disk, keyed by everything they depend on (the case, the
    speeds, the resolution and the text of sdm_reference.py), so that a rerun after a change
    to taptune's SDM recomputes only taptune. ``path`` None: nothing kept."""

    def __init__(self, path: Path | None):
        self.path = path
        self.new: dict = {}
        self.data: dict = self._read()
        self.source = hashlib.sha256(Path(ref.__file__).read_bytes()).hexdigest()[:16]
        self.hits = self.misses = 0

    def _read(self) -> dict:
        if self.path is None or not self.path.exists():
            return {}
        try:
            return json.loads(self.path.read_text())
        except (OSError, ValueError):
            print(f"   (cache {self.path} unreadable: its answers are computed again)")
            return {}

    def get(self, compute, *parts):
        """``compute()`` (a JSON-able answer) unless the cache holds it for ``parts``."""
        key = hashlib.sha256(repr((self.source,) + parts).encode()).hexdigest()[:32]
        if key in self.data:
            self.hits += 1
            return self.data[key]
        self.misses += 1
        value = compute()
        self.data[key] = self.new[key] = value
        if self.path is not None:  # merged into what another run may have written meanwhile
            self.path.parent.mkdir(parents=True, exist_ok=True)
            merged = {**self._read(), **self.new}
            tmp = self.path.with_name(f"{self.path.name}.{os.getpid()}.tmp")
            tmp.write_text(json.dumps(merged))
            os.replace(tmp, self.path)
        return value


def ref_limits(cache: ReferenceCache, modes, cut, speeds, **kw) -> ref.Limits:
    """:func:`sdm_reference.limits`, cached."""
    speeds = np.asarray(speeds, dtype=float)

    def compute():
        lim = ref.limits(modes, cut, speeds, **kw)
        return [lim.a_lim.tolist(), lim.kind.tolist()]

    a, kind = cache.get(compute, "limits", modes, cut, tuple(speeds.tolist()), sorted(kw.items()))
    return ref.Limits(speeds, np.array(a, dtype=float), np.array(kind, dtype=str))


def ladder(cache: ReferenceCache, modes, cut, rpm: float, steps) -> list:
    """The reference's limit [m] at ``rpm`` for each (elements per mode period, degree) of ``steps``."""
    def compute():
        row, start = [], None
        for e, p in steps:
            mono = ref.Monodromy(modes, cut, rpm, per_period=e, degree=p)
            a, _ = ref.limit_at(mono, start or ref._static_scale(modes, cut) * 5, rtol=1e-9)
            start = 0.9 * a
            row.append(a)
        return row

    return cache.get(compute, "ladder", modes, cut, float(rpm), tuple(steps))


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


def convergence(cache: ReferenceCache, speeds_per_case: int = 3) -> None:
    print("1. Convergence of the reference: limit [mm] as the resolution grows "
          "(elements per period of the fastest mode × degree)")
    print("   " + " ".join(f"{e}×{p:<2d}".rjust(10) for e, p in LADDER) + "   last change")
    worst = 0.0
    for name, modes, cut in cases():
        if cut.milling == "up" and cut.ae >= cut.diameter:
            continue  # slotting: up and down are the same cut
        for rpm in np.linspace(5000.0, 25000.0, speeds_per_case):
            row = ladder(cache, modes, cut, rpm, LADDER)
            change = abs(row[-1] / row[-2] - 1)
            worst = max(worst, abs(row[3] / row[-1] - 1))
            print(f"   {' '.join(f'{a * 1e3:10.6f}' for a in row)}   {change:.1e}   {name}, {rpm:.0f} rpm")
    print(f"   used: {LADDER[3][0]} elements per mode period, degree {LADDER[3][1]}: largest difference from "
          f"the finest {worst:.1e}", flush=True)


def published(cache: ReferenceCache) -> None:
    print("\n2. Published values, 1-DOF benchmark, down-milling (Insperger & Stépán 2004)")
    for r, paper in ((0.05, "1.09 mm, flip, near 18,200 rpm"), (0.1, "0.75 mm")):
        cut = ref.Cut(teeth=2, ae=r * BENCH_CUT["diameter"], milling="down", **BENCH_CUT)
        coarse = np.arange(5000.0, 25001.0, 100.0)
        lim = ref_limits(cache, BENCH_MODES, cut, coarse)
        i = int(np.argmin(lim.a_lim))
        fine = np.arange(coarse[max(i - 1, 0)], coarse[min(i + 1, coarse.size - 1)] + 1e-9, 5.0)
        lim_f = ref_limits(cache, BENCH_MODES, cut, fine, floor=0.7 * lim.a_lim[i])
        j = int(np.argmin(lim_f.a_lim))
        a_t, flip_t, _, _ = taptune_sdm(BENCH_MODES, cut, coarse)
        k = int(np.nanargmin(a_t))
        print(f"   a/D {r:g}: reference {lim_f.a_lim[j] * 1e3:.3f} mm, {lim_f.kind[j]}, at {fine[j]:.0f} rpm; "
              f"taptune SDM {a_t[k] * 1e3:.3f} mm, {'flip' if flip_t[k] else 'hopf'}, at {coarse[k]:.0f} rpm; "
              f"paper {paper}", flush=True)


def compare(cache: ReferenceCache, step: float) -> list:
    print(f"\n3. taptune's sdm_lobes against the reference, 5,000–25,000 rpm every {step:g} rpm")
    speeds = np.arange(5000.0, 25000.0 + 1e-9, step)
    rows = []
    done = {}
    for name, modes, cut in cases():
        t0 = time.process_time()
        key = (modes, cut.teeth, cut.ae, cut.milling if cut.ae < cut.diameter else "slot")  # slotting: up = down
        if key not in done:
            done[key] = ref_limits(cache, modes, cut, speeds)
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


#: Low speeds: taptune's grid as ``taptune lobes`` computes it (the CLI's lowest speed and step) …
LOW_GRID = (500.0, 5000.0, 10.0)
#: … the reference's resolution there (``low_convergence`` shows it converged) …
LOW_RES = dict(per_period=2, degree=8)
LOW_LADDER = ((1, 6), (1, 8), (2, 8), (2, 10), (3, 12))
#: … its samples per lobe of the fastest mode inside a window (each local minimum then refined) …
LOBE_SAMPLES = 5
#: … the relative sample spacings whose window minimum is estimated from the reference's samples …
SPACINGS = (0.01, 0.005, 0.0025)
#: … the ratio between the centres of successive windows, and the step of the point-by-point speeds [rpm].
WINDOW_RATIO = 1.12
POINT_STEP = 100.0


def low_cases():
    """(name, modes, Cut) of the low-speed comparison (all down-milling)."""
    out = [("3+3-mode tool, 4 teeth, a/D 0.05", TOOL3_MODES,
            ref.Cut(teeth=4, ae=0.05 * TOOL3_CUT["diameter"], milling="down", **TOOL3_CUT))]
    for teeth in (2, 4):
        for r in (0.1, 0.05):
            out.append((f"2-mode end mill, {teeth} teeth, a/D {r:g}", MILL_MODES,
                        ref.Cut(teeth=teeth, ae=r * MILL_CUT["diameter"], milling="down", **MILL_CUT)))
    return out


def dense_window() -> float:
    """Half-width of taptune's window (relative speed) over which it reports the lowest limit."""
    from taptune.machine import sdm

    return float(sdm.DENSE_WINDOW)


def dense_below(modes, cut, window: float) -> float:
    """The speed [rpm] below which one lobe of the fastest mode (1/(f τ) of the speed wide) is
    narrower than twice the window: there taptune reports the window's lowest limit."""
    f_max = max(m.f_hz for m in modes)
    return 60.0 * 2 * window * f_max / cut.teeth


def window_min(cache: ReferenceCache, modes, cut, lo: float, hi: float) -> dict:
    """The reference's lowest limit between ``lo`` and ``hi`` [rpm]: ``a`` [m], ``kind`` and
    ``rpm`` there, ``sampled`` (the lowest of the samples before refinement [m]) and every
    limit computed (``speeds``, ``limits``, ``kinds``).

    Samples uniform in the tooth period, LOBE_SAMPLES per lobe of the fastest mode (a lobe spans
    1/k of the speed, k = f τ the mode periods per tooth period); each interior local minimum is
    then refined by Brent's method in speed (to 1/50 of a lobe), each of its limits scanned from
    0.85 × that sample's limit."""
    from scipy.optimize import minimize_scalar

    def compute():
        f_max = max(m.f_hz for m in modes)
        tau_lo, tau_hi = 60.0 / (cut.teeth * hi), 60.0 / (cut.teeth * lo)
        k = f_max * tau_hi
        n = int(np.ceil(np.log(hi / lo) * k * LOBE_SAMPLES)) + 1
        speeds = 60.0 / (cut.teeth * np.linspace(tau_hi, tau_lo, n))
        lim = ref.limits(modes, cut, speeds, **LOW_RES)
        a = np.where(np.isfinite(lim.a_lim), lim.a_lim, np.inf)
        seen = dict(speeds=speeds.tolist(), limits=a.tolist(), kinds=lim.kind.tolist())
        for i in range(1, n - 1):
            if not (np.isfinite(a[i]) and a[i] <= a[i - 1] and a[i] <= a[i + 1]):
                continue

            def depth(rpm, floor=0.85 * a[i]):
                got, kind = ref.limit_at(ref.Monodromy(modes, cut, rpm, **LOW_RES), floor)
                seen["speeds"].append(float(rpm))
                seen["limits"].append(float(got))
                seen["kinds"].append(kind)
                return got if np.isfinite(got) else 1e3

            minimize_scalar(depth, bounds=(speeds[i - 1], speeds[i + 1]), method="bounded",
                            options=dict(xatol=speeds[i] / (50 * k)))
        j = int(np.argmin(seen["limits"]))
        return dict(a=seen["limits"][j], kind=seen["kinds"][j], rpm=seen["speeds"][j], sampled=float(a.min()),
                    **seen)

    return cache.get(compute, "window-min", modes, cut, float(lo), float(hi), LOBE_SAMPLES,
                     sorted(LOW_RES.items()))


def sampled_window_min(w: dict, spacing: float, phases: int = 24) -> np.ndarray:
    """What the lowest of samples every ``spacing`` (relative speed) inside the window of
    :func:`window_min` ``w`` would exceed the window's true lowest by, for ``phases`` offsets
    of the samples (the reference's limit between its own samples: linear in log speed)."""
    order = np.argsort(w["speeds"])
    x = np.log(np.array(w["speeds"])[order])
    y = np.array(w["limits"])[order]
    out = []
    for ph in np.arange(phases) / phases * spacing:
        pts = np.arange(x[0] + ph, x[-1] + 1e-12, spacing)
        out.append(np.interp(pts, x, y).min() / w["a"] - 1)
    return np.array(out)


def low_convergence(cache: ReferenceCache) -> None:
    print("5a. Convergence of the reference at low speed: limit [mm] as the resolution grows "
          "(elements per period of the fastest mode × degree)")
    print("   " + " ".join(f"{e}×{p:<2d}".rjust(10) for e, p in LOW_LADDER) + "   last change")
    used = LOW_LADDER.index((LOW_RES["per_period"], LOW_RES["degree"]))
    worst = 0.0
    for name, modes, cut in low_cases():
        for rpm in (600.0, 1200.0, 2500.0):
            row = ladder(cache, modes, cut, rpm, LOW_LADDER)
            worst = max(worst, abs(row[used] / row[-1] - 1))
            print(f"   {' '.join(f'{a * 1e3:10.6f}' for a in row)}   {abs(row[-1] / row[-2] - 1):.1e}   "
                  f"{name}, {rpm:.0f} rpm", flush=True)
    print(f"   used: {LOW_RES['per_period']} elements per mode period, degree {LOW_RES['degree']}: largest "
          f"difference from the finest {worst:.1e}", flush=True)


def _pct(x) -> str:
    return f"{x:.2%}" if np.isfinite(x) else "–"


def low_compare(cache: ReferenceCache) -> list:
    window = dense_window()
    lo, hi, step = LOW_GRID
    grid = np.arange(lo, hi + 1e-9, step)
    print(f"\n5b. taptune's sdm_lobes ({lo:g}–{hi:g} rpm, every {step:g} rpm) against the reference: point by "
          f"point where taptune resolves the lobes (every {POINT_STEP:g} rpm), and where the lobes are narrower "
          f"than ±{window:.1%} its lowest limit within ±{window:.1%} against the reference's lowest in the same "
          f"window (windows {WINDOW_RATIO:g}× apart; '+' taptune deeper than the reference)")
    rows = []
    for name, modes, cut in low_cases():
        c0 = time.process_time()
        below = dense_below(modes, cut, window)
        centres = []
        c = 510.0  # the window lies inside taptune's grid
        while c < below * (1 - 2 * window):
            centres.append(round(c, -1))
            c *= WINDOW_RATIO
        points = np.arange(np.ceil(below * (1 + 2 * window) / POINT_STEP) * POINT_STEP, hi + 1e-9, POINT_STEP)
        centres = np.array(centres)
        test = np.concatenate([centres, points])
        at = ref_limits(cache, modes, cut, test, **LOW_RES)
        wins = [window_min(cache, modes, cut, r * (1 - window), r * (1 + window)) for r in centres]
        t_ref = time.process_time() - c0
        w1 = time.perf_counter()
        a_t, flip_t, zoa, _ = taptune_sdm(modes, cut, grid)
        t_tap = time.perf_counter() - w1
        idx = np.searchsorted(grid, test)
        a_t, flip_t, zoa = a_t[idx], flip_t[idx], zoa[idx]
        is_dense = np.arange(test.size) < centres.size
        want = at.a_lim.copy()
        kind = at.kind.copy()
        for j, w in enumerate(wins):
            want[j], kind[j] = w["a"], w["kind"]
        err = a_t / want - 1
        same = flip_t == (kind == "flip")
        sdm = np.isfinite(a_t)
        print(f"   {name}, down-milling (lobes narrower than the window below {below:.0f} rpm)")
        for part, sel in (("point by point", sdm & ~is_dense), ("lowest in the window", sdm & is_dense)):
            if not sel.any():
                continue
            e = np.abs(err[sel])
            k = np.flatnonzero(sel)[np.argmax(e)]
            deeper = err[sel] > 0.01
            print(f"      {part:21s} {sel.sum():3d} speeds {test[sel].min():5.0f}–{test[sel].max():5.0f} rpm: median "
                  f"{np.median(e):6.2%}, max {e.max():6.2%} (at {test[k]:.0f} rpm: taptune {a_t[k] * 1e3:.4g} mm, "
                  f"reference {want[k] * 1e3:.4g} mm); more than 1 % deeper at {deeper.sum()}; "
                  f"flip/Hopf alike {same[sel].sum()}/{sel.sum()}")
        for j in np.flatnonzero(sdm & ~is_dense & (err > 0.01)):
            print(f"         {test[j]:5.0f} rpm: taptune {a_t[j] * 1e3:.4g} mm, reference {want[j] * 1e3:.4g} mm "
                  f"{kind[j]} ({err[j]:+.2%})")
        handed = ~sdm
        if handed.any():
            e_z = np.abs(zoa[handed] / at.a_lim[handed] - 1)
            print(f"      {handed.sum()} speed(s) up to {test[handed].max():.0f} rpm left to the zero-order lobes "
                  f"(against the reference's limit at the speed: median {_pct(np.median(e_z))}, max {_pct(e_z.max())})")
        for j, (r, w) in enumerate(zip(centres, wins)):
            shown = f"taptune {a_t[j] * 1e3:8.4f} mm {'flip' if flip_t[j] else 'hopf'} {err[j]:+7.2%}" if sdm[j] \
                else f"zero-order {zoa[j] * 1e3:8.4f} mm"
            print(f"         {r:5.0f} rpm ±{window:.1%}: reference lowest {w['a'] * 1e3:8.4f} mm {w['kind']:4s} at "
                  f"{w['rpm']:7.1f} rpm (at the centre {at.a_lim[j] * 1e3:8.4f} mm; refining the sampled minima: "
                  f"{w['a'] / w['sampled'] - 1:+.2%}, {len(w['speeds'])} limits); {shown}")
        excess = [np.concatenate([sampled_window_min(w, sp) for w in wins]) for sp in SPACINGS] if wins else []
        if excess:
            print("      the lowest of samples every " + " / ".join(f"{sp:.2%}" for sp in SPACINGS) + " of speed in "
                  "the windows (the reference's limits, all offsets): deeper than the lowest by median "
                  + " / ".join(f"{np.median(e):.2%}" for e in excess) + ", at most "
                  + " / ".join(f"{e.max():.2%}" for e in excess))
        print(f"      [reference {t_ref:.1f} s CPU (cache: {cache.hits} hits, {cache.misses} computed so far); "
              f"taptune {t_tap:.1f} s wall]", flush=True)
        rows.append((name, err, sdm, is_dense, same))
    pts = np.concatenate([r[1][r[2] & ~r[3]] for r in rows])
    dns = np.concatenate([r[1][r[2] & r[3]] for r in rows])
    print(f"   all low-speed cases: point by point median {_pct(np.median(np.abs(pts)))}, max "
          f"{_pct(np.abs(pts).max())}; lowest in the window median {_pct(np.median(np.abs(dns)))}, max "
          f"{_pct(np.abs(dns).max())}, more than 1 % deeper than the reference in {np.sum(dns > 0.01)} of "
          f"{dns.size} windows (worst {dns.max():+.2%}); flip/Hopf alike "
          f"{sum(int(r[4][r[2]].sum()) for r in rows)}/{sum(int(r[2].sum()) for r in rows)}; "
          f"{sum(int((~r[2]).sum()) for r in rows)} speed(s) left to the zero-order lobes", flush=True)
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
    parser.add_argument("--low", action="store_true", help="only the low speeds, 500–5,000 rpm (5)")
    parser.add_argument("--cache", type=Path, default=CACHE, help=f"the reference's answers (default {CACHE})")
    parser.add_argument("--no-cache", action="store_true", help="compute the reference afresh, keep nothing")
    args = parser.parse_args()
    cache = ReferenceCache(None if args.no_cache else args.cache)
    t0 = time.perf_counter()
    if args.low:
        low_convergence(cache)
        low_compare(cache)
    else:
        convergence(cache)
        published(cache)
        compare(cache, args.step)
        if args.simulation:
            simulation(args.speeds)
    print(f"\n{time.perf_counter() - t0:.0f} s wall; reference answers: {cache.hits} from the cache, "
          f"{cache.misses} computed")


if __name__ == "__main__":
    main()
