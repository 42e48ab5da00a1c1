"""Does the lobes' band hold on holders unlike the model? (issue 25's band acceptance check)

For holders of the realism corpus's validation split (benchmarks/realism: non-uniform
grip, collet nut or coolant tube, holder diameters and flute ratio off, stick-out read
off a ruler, doublets, phone recordings), identified from one tap (the stored
identifications of ``benchmarks/realism/results_<tier>_validation*.json``; their
near-optimal parameter sets), at the tapped stick-out and at another one:

* **truth**: the true holder FE (benchmarks.realism.truth, each bending plane on its own,
  at the TRUE stick-out) cut at the coupling plane and coupled to the spindle by the same
  receptance coupling as the product (taptune.machine.coupling.couple), then the SDM
  lobes (``stability_lobes(method="auto")``, the same method and depth cap);
* **product**: what ``taptune lobes ASSEMBLY --holder NAME --machine M ...`` computes for
  the DESCRIBED assembly: the tool-point FRF of the best parameter set, the holder's
  prediction band (``Entry.predict`` = ``identify.predict`` with the identification's
  misfit floor and measured modes), and the lobes with their band at confidence 0.9,
  method auto.

Reported: the fraction of speeds where the true limit ≥ ``a_lim_mm_safe`` (pooled and
per holder), the fraction of reported safe pockets truly stable over their whole window
(the true limit ≥ the pocket's depth at every speed of the window), and for the best safe
pocket its depth over the true depth there (the lowest true limit over its window; also
over the true limit at its centre speed).

The product's central lobes are computed once per stick-out on a speed grid extended
to ±``EXTEND`` (whole steps of the same grid), and the band is evaluated from them with
:func:`taptune.machine.band.lobe_band` exactly as :func:`~taptune.machine.band.lobes_with_band`
does (its extension is narrower, the grid points the same; on ival002 ``lobes_with_band``
itself gave the same safe depth at the median speed, at most 3 % apart where the SDM's
speed sampling differs with the grid's range, and the same safe pockets within 0.3 %).
Truth and central lobes are cached (``--cache``), so another band is re-evaluated in
seconds (``--sweep``, ``--cached-only``).

``before`` in the result is the frequency band alone (the band before this benchmark),
``after`` the product's band; ``--sweep`` shows other model-form parts of the
dynamic-stiffness band (:data:`taptune.machine.band.DEPTH_MODEL_FORM` was chosen on the
calibration split: the smallest on a 0.1 grid that holds ≥ 92 % of the speeds and of
the safe pockets there).

Run (20 holders per tier, both tiers: 34 min wall on 2 cores shared with a load of ~8;
then ~1 min from the cache)::

    OPENBLAS_NUM_THREADS=1 nice -n 10 python -m benchmarks.lobes_coverage --n 20 --out benchmarks/lobes_coverage.json
    python -m benchmarks.lobes_coverage --split calibration --n 12 --sweep 0.2 0.4 0.6 0.8
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("OMP_NUM_THREADS", "1")

import numpy as np  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
REALISM = ROOT / "benchmarks" / "realism"
MACHINES = {"example": ROOT / "recordings" / "machine" / "machine.toml",
            "d01": ROOT.parent / "shared" / "cases-dev" / "machine-d01" / "machine.toml"}
MM = 1e-3
CONFIDENCE = 0.9
#: The speed grid of every diagram: 500 rpm to the example machine's top speed, 10 rpm steps (the default).
RPM = (500.0, 24000.0, 10.0)
#: The central lobes are computed on the grid extended to n/s for every |s − 1| ≤ EXTEND.
EXTEND = 0.25
#: Cuts, one per holder in turn: (teeth, ae / D, milling). Al 6082 coefficients.
CUTS = ((4, 0.5, "down"), (2, 0.1, "down"), (3, 1.0, "up"), (4, 0.25, "up"), (3, 0.05, "down"))
MATERIAL = "al6082"


def load_records(tier: str, n: int, split: str = "validation") -> list[dict]:
    """The first ``n`` stored identifications of ``split`` in ``tier`` (every stored file, in index order)."""
    recs = []
    for name in (f"results_{tier}_{split}.json", f"results_{tier}_{split}_24.json", f"results_{tier}_{split}_48.json"):
        path = REALISM / name
        if path.exists():
            recs += json.loads(path.read_text())["cases"]
    recs = [r for r in sorted(recs, key=lambda r: r["index"]) if "failed" not in r]
    return recs[:n]


def true_toolpoint(case, true_stickout_mm: float, spindle, freq_hz):
    """(G_xx, G_yy) of the TRUE holder at its true stick-out on the spindle [m/N]: each
    bending plane's truth FE cut at the coupling plane, coupled as the product couples."""
    from benchmarks.realism.truth import truth_model
    from taptune.machine.blocks import receptance_blocks
    from taptune.machine.coupling import couple
    from taptune.machine.plane import cut_assembly

    asm = cut_assembly(case.true_at(true_stickout_mm))
    planes = [case.holder.plane(0), case.holder.plane(1)] if case.holder.asymmetry else [case.holder] * 2
    out = []
    for plane, s in zip(planes, (spindle.x, spindle.y)):
        fe, params = truth_model(asm, plane)
        b = receptance_blocks(fe, params, freq_hz)
        out.append(couple(b.h11, b.h12, b.h21, b.h22, s.at(freq_hz))[:, 0, 0])
    return out[0], out[1]


def cut_of(index: int, diameter_mm: float) -> dict:
    teeth, ae_rel, milling = CUTS[index % len(CUTS)]
    return {"teeth": teeth, "ae_mm": round(ae_rel * diameter_mm, 4), "milling": milling, "diameter_mm": diameter_mm}


def run_case(record: dict, machine_key: str) -> list[dict]:
    """Truth and central lobes of one holder at its tapped stick-out and its first query;
    [] for a holder that cannot go on the spindle (the tool reaches behind the coupling plane)."""
    from taptune.errors import InputError

    try:
        return _run_case(record, machine_key)
    except InputError as err:
        print(f"{record['name']}: left out: {err}", flush=True)
        return []


def _run_case(record: dict, machine_key: str) -> list[dict]:
    from benchmarks.realism.corpus import case_of
    from benchmarks.realism.run import product_predict
    from taptune.cli.cmd_toolpoint import DEFAULT_F_MAX_HZ, DEFAULT_F_MIN_HZ, DEFAULT_STEP_HZ
    from taptune.io.machine import load_machine
    from taptune.library.exchange import frequency_grid
    from taptune.machine.band import band_from_prediction
    from taptune.machine.coupling import toolpoint_frf
    from taptune.machine.lobes import stability_lobes
    from taptune.machine.materials import cutting_coefficients
    from taptune.model.params import HolderParams

    case = case_of(record)
    machine = load_machine(MACHINES[machine_key])
    lo = max(machine.x.freq_hz[0], machine.y.freq_hz[0], DEFAULT_F_MIN_HZ)
    hi = min(machine.x.freq_hz[-1], machine.y.freq_hz[-1], DEFAULT_F_MAX_HZ)
    freq = frequency_grid(DEFAULT_STEP_HZ * np.ceil(lo / DEFAULT_STEP_HZ), hi, DEFAULT_STEP_HZ)
    sets = [HolderParams(**p) for p in record["identification"]["param_sets"]]
    ident = record["identification"]
    coeff = cutting_coefficients(MATERIAL)
    rpm = frequency_grid(*RPM)
    step = RPM[2]
    ext = np.arange(np.floor(RPM[0] / (1 + EXTEND) / step), np.ceil(RPM[1] / (1 - EXTEND) / step) + 1) * step
    ext = ext[ext > 0]
    inner = slice(int(np.searchsorted(ext, RPM[0])), int(np.searchsorted(ext, RPM[0])) + rpm.size)
    assert np.allclose(ext[inner], rpm)
    spindle = {"x": machine.x, "y": machine.y}
    out = []
    sites = [("tapped", case.described.stickout / MM, case.true_assembly.stickout / MM)]
    q = case.queries[0]
    sites.append(("other", q.stickout_mm, q.true_stickout_mm))
    for where, so_mm, true_mm in sites:
        described = case.described_at(so_mm)
        tool = described.tool
        d_mm = (tool.flute_diameter or tool.segments[-1].od) / MM
        cut = cut_of(record["index"], d_mm)
        cap = tool.flute_length if tool.flute_length is not None else np.inf
        kw = dict(teeth=cut["teeth"], ktc=coeff.ktc, krc=coeff.krc, diameter=d_mm * MM, ae=cut["ae_mm"] * MM,
                  milling=cut["milling"], method="auto", depth_cap=cap)
        t0 = time.process_time()
        gx, gy = true_toolpoint(case, true_mm, machine, freq)
        truth = stability_lobes(freq, gx, gy, rpm=rpm, **kw)
        t1 = time.process_time()
        frf = toolpoint_frf(described, sets[0], spindle, freq)
        central = stability_lobes(freq, frf.xx, frf.yy, rpm=ext, **kw)
        t2 = time.process_time()
        pred = product_predict(sets, described, case, ident)
        rel, coverage, sources, _ = band_from_prediction(pred)
        out.append({
            "name": case.name, "index": record["index"], "tier": case.tier, "where": where, "machine": machine_key,
            "kinds": list(case.kinds), "stickout_mm": so_mm, "true_stickout_mm": true_mm, "cut": cut,
            "depth_cap_mm": cap / MM if np.isfinite(cap) else None,
            "band": {"rel": rel, "coverage": coverage, "sources": sources,
                     "damping_ratio": pred.damping_ratio[0], "damping_spread": pred.damping_ratio_spread[0],
                     "bending_hz": list(pred.bending_hz), "half_width_hz": list(pred.bending_hz_spread),
                     "truth_hz": list(q.truth.bending_hz) if where == "other" else list(case.truth.bending_hz)},
            "modes_true": [[m.hz, m.damping_ratio, m.magnitude] for m in _top(freq, gx)],
            "modes_model": [[m.hz, m.damping_ratio, m.magnitude] for m in _top(freq, frf.xx)],
            "truth_method": truth.method, "central_method": central.method,
            "rpm_ext": ext.tolist(), "inner": [inner.start, inner.stop],
            "a_true": _finite(truth.a_lim), "a_central_ext": _finite(central.a_lim),
            "cpu_s": {"truth": round(t1 - t0, 2), "product": round(t2 - t1, 2)},
        })
    return out


def _top(freq, g):
    from taptune.machine.peaks import dominant_modes

    return sorted(dominant_modes(freq, g, "x"), key=lambda m: -m.magnitude)[:3]


def _finite(a) -> list:
    return [None if not np.isfinite(v) else float(v) for v in np.asarray(a, dtype=float)]


def _arr(values) -> np.ndarray:
    return np.array([np.inf if v is None else v for v in values], dtype=float)


def evaluate_site(site: dict, model_form=None) -> dict:
    """The band of one site (the product path) against its truth.

    ``model_form``: the dynamic-stiffness band's model-form part (default the product's
    :data:`~taptune.machine.band.DEPTH_MODEL_FORM`); None … -1 leaves out the dynamic
    stiffness (the frequency band alone, as before this benchmark)."""
    from taptune.machine.band import DEPTH_MODEL_FORM, band_samples, depth_band, lobe_band

    ext = np.asarray(site["rpm_ext"])
    inner = slice(*site["inner"])
    cap = site["depth_cap_mm"] * MM if site["depth_cap_mm"] is not None else np.inf
    b = site["band"]
    mf = DEPTH_MODEL_FORM if model_form is None else model_form
    depth = 0.0 if mf < 0 else depth_band(b["damping_ratio"], b["damping_spread"], mf)
    scales, magnitudes = band_samples(b["rel"], b["coverage"], depth)
    band = lobe_band(ext, _arr(site["a_central_ext"]), inner, scales, CONFIDENCE, cap, b["sources"], magnitudes)
    rpm = ext[inner]
    true = np.minimum(_arr(site["a_true"]), cap)
    safe = np.minimum(band.a_safe, cap)
    known = np.isfinite(safe)
    # Both limits come from the same bisection (relative bracket 1 %, interpolated inside):
    # a safe depth within 0.5 % of the true limit counts as held.
    held = true >= safe * (1 - 5e-3)
    pockets = []
    for p in band.safe_pockets:
        w = (rpm >= p.rpm_low - 1e-6) & (rpm <= p.rpm_high + 1e-6)
        true_min = float(np.min(true[w]))
        i = int(np.argmin(np.abs(rpm - p.rpm)))
        pockets.append({"rpm_low": p.rpm_low, "rpm_high": p.rpm_high, "rpm": p.rpm, "a_mm": p.a / MM,
                        "true_min_mm": true_min / MM, "true_centre_mm": float(true[i]) / MM,
                        "stable": bool(true_min >= p.a * (1 - 5e-3))})
    return {"speeds": int(known.sum()), "held": int((held & known).sum()),
            "fraction_held": float((held & known).sum() / max(known.sum(), 1)),
            "safe_over_central_median": float(np.median((safe / np.minimum(_arr(site["a_central_ext"])[inner], cap))[known])),
            "pockets": pockets}


def summarise(sites: list[dict], model_form=None) -> dict:
    """Pooled, per-holder and per-pocket figures of :func:`evaluate_site` over ``sites``."""
    per = [evaluate_site(s, model_form) for s in sites]
    speeds = sum(p["speeds"] for p in per)
    held = sum(p["held"] for p in per)
    pockets = [q for p in per for q in p["pockets"]]
    best = [p["pockets"][0] for p in per if p["pockets"]]
    ratio_window = np.array([q["a_mm"] / q["true_min_mm"] for q in best])
    ratio_centre = np.array([q["a_mm"] / q["true_centre_mm"] for q in best])
    holders = {}
    for s, p in zip(sites, per):
        h = holders.setdefault(s["name"], [0, 0])
        h[0] += p["held"]
        h[1] += p["speeds"]
    per_holder = {k: v[0] / max(v[1], 1) for k, v in holders.items()}
    # The best pocket's depth where the truth is shallower than it counts as 0 % useful,
    # not as more than 100 %: min(ratio, 1) is the share of the true depth one can use.
    return {
        "sites": len(sites), "holders": len(holders),
        "speeds_held": round(held / max(speeds, 1), 4),
        "per_holder_held": {"median": round(float(np.median(list(per_holder.values()))), 4),
                            "min": round(float(min(per_holder.values())), 4),
                            "holders_ge_0.9": round(float(np.mean([v >= 0.9 for v in per_holder.values()])), 4)},
        "sites_held_ge_0.9": round(float(np.mean([p["fraction_held"] >= 0.9 for p in per])), 4),
        "safe_pockets": len(pockets),
        "safe_pockets_stable": round(float(np.mean([q["stable"] for q in pockets])), 4) if pockets else None,
        "best_pockets": len(best),
        "best_pockets_stable": round(float(np.mean([q["stable"] for q in best])), 4) if best else None,
        "best_depth_over_true_window": {"median": round(float(np.median(ratio_window)), 4),
                                        "fraction_ge_0.5": round(float(np.mean(ratio_window >= 0.5)), 4)},
        "best_depth_over_true_centre": {"median": round(float(np.median(ratio_centre)), 4),
                                        "fraction_ge_0.5": round(float(np.mean(ratio_centre >= 0.5)), 4)},
        "safe_over_central_median": round(float(np.median([p["safe_over_central_median"] for p in per])), 4),
        "per_site": [{"name": s["name"], "where": s["where"], "held": round(p["fraction_held"], 4),
                      "band_pct": round(100 * s["band"]["rel"], 3),
                      "best_pocket": {k: round(v, 3) if isinstance(v, float) else v
                                      for k, v in p["pockets"][0].items()} if p["pockets"] else None}
                     for s, p in zip(sites, per)],
    }


def cached_sites(records, cache: Path, jobs: int, compute: bool = True) -> list[dict]:
    """Every record's two sites, from the cache or computed (and cached; ``compute`` False: cached ones only)."""
    cache.mkdir(parents=True, exist_ok=True)
    if not compute:
        records = [r for r in records if (cache / f"{r['name']}.json").exists()]
    todo = []
    for k, r in enumerate(records):
        path = cache / f"{r['name']}.json"
        if not path.exists():
            todo.append((r, "example" if k % 2 == 0 or not MACHINES["d01"].exists() else "d01", path))
    if todo:
        if jobs > 1:
            from concurrent.futures import ProcessPoolExecutor

            with ProcessPoolExecutor(jobs) as pool:
                futures = [(pool.submit(run_case, r, m), p) for r, m, p in todo]
                for f, p in futures:
                    _store(f.result(), p)
        else:
            for r, m, p in todo:
                _store(run_case(r, m), p)
    sites = []
    for r in records:
        path = cache / f"{r['name']}.json"
        mine = json.loads(path.read_text())
        if any("damping_ratio" not in s["band"] for s in mine):  # cached before the damping was kept
            mine = _with_damping(r, mine)
            path.write_text(json.dumps(mine))
        sites += mine
    return sites


def _with_damping(record: dict, sites: list[dict]) -> list[dict]:
    from benchmarks.realism.corpus import case_of
    from benchmarks.realism.run import product_predict
    from taptune.model.params import HolderParams

    case = case_of(record)
    sets = [HolderParams(**p) for p in record["identification"]["param_sets"]]
    for s in sites:
        pred = product_predict(sets, case.described_at(s["stickout_mm"]), case, record["identification"])
        s["band"].update(damping_ratio=pred.damping_ratio[0], damping_spread=pred.damping_ratio_spread[0])
    return sites


def _store(sites, path: Path) -> None:
    path.write_text(json.dumps(sites))
    if not sites:
        return
    s = sites[0]
    print(f"{s['name']:28s} {s['machine']:8s} cpu truth {sum(x['cpu_s']['truth'] for x in sites):5.1f} s, "
          f"product {sum(x['cpu_s']['product'] for x in sites):5.1f} s; band ±{100 * s['band']['rel']:.2f} %",
          flush=True)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=20, help="holders per tier")
    ap.add_argument("--tier", nargs="+", default=["issue", "harsh"], help="corpus tiers")
    ap.add_argument("--split", default="validation", choices=("validation", "calibration"),
                    help="corpus split (calibration: for choosing the band's constants; never tune on validation)")
    ap.add_argument("--jobs", type=int, default=1)
    ap.add_argument("--cache", default=os.path.expanduser("~/.cache/taptune-lobes-coverage"))
    ap.add_argument("--out", default=None, help="result JSON")
    ap.add_argument("--cached-only", action="store_true", help="evaluate the holders already in the cache")
    ap.add_argument("--sweep", type=float, nargs="+", metavar="C",
                    help="print the figures for these model-form parts of the dynamic-stiffness band (-1: none)")
    args = ap.parse_args(argv)
    from taptune.machine.band import DEPTH_MODEL_FORM

    t0 = time.time()
    records = [r for t in args.tier for r in load_records(t, args.n, args.split)]
    sites = cached_sites(records, Path(args.cache), args.jobs, not args.cached_only)
    sweep = {}
    for c in args.sweep or ():
        sweep[f"{c:g}"] = summarise(sites, c)
        sweep[f"{c:g}"].pop("per_site")
        print(f"model form {c:g}: {_line(sweep[f'{c:g}'])}")
    before = summarise(sites, -1.0)
    after = summarise(sites)
    print(f"frequency band alone (before): {_line(before)}")
    print(f"with the dynamic stiffness (model form {DEPTH_MODEL_FORM:g}): {_line(after)}")
    print(f"wall {time.time() - t0:.0f} s, load {os.getloadavg()[0]:.1f}")
    if args.out:
        before.pop("per_site")
        meta = {"split": args.split, "tiers": args.tier, "n_per_tier": args.n, "confidence": CONFIDENCE,
                "rpm": RPM, "cuts": CUTS, "material": MATERIAL, "depth_model_form": DEPTH_MODEL_FORM}
        by_tier = {}
        for t in args.tier:
            mine = [x for x in sites if x["tier"] == t]
            if mine:
                by_tier[t] = {"before": summarise(mine, -1.0), "after": summarise(mine)}
                for v in by_tier[t].values():
                    v.pop("per_site")
        out = {"meta": meta, "before": before, "after": after, "by_tier": by_tier, "model_form_sweep": sweep}
        Path(args.out).write_text(json.dumps(out, indent=1) + "\n")
    return 0


def _line(s: dict) -> str:
    w, c = s["best_depth_over_true_window"], s["best_depth_over_true_centre"]
    return (f"{s['holders']} holders, {s['sites']} sites: speeds held {s['speeds_held']:.1%} (per holder median "
            f"{s['per_holder_held']['median']:.1%}, min {s['per_holder_held']['min']:.1%}, "
            f"{s['per_holder_held']['holders_ge_0.9']:.0%} of holders >= 90 %); safe pockets truly stable "
            f"{s['safe_pockets_stable']:.1%} of {s['safe_pockets']} (best {s['best_pockets_stable']:.1%}); "
            f"best pocket depth / true over its window median {w['median']:.2f} (>= 0.5: {w['fraction_ge_0.5']:.0%}), "
            f"/ true at its centre {c['median']:.2f} (>= 0.5: {c['fraction_ge_0.5']:.0%}); "
            f"safe / central median {s['safe_over_central_median']:.2f}")


if __name__ == "__main__":
    sys.exit(main())
