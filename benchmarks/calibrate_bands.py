"""Calibrate the model-form term of the prediction bands on the realism corpus, and validate it.

The band of a predicted bending frequency (taptune/identify/bands.py) is
``sqrt(set² + geometry² + model_form²)`` with ``model_form = c_g × f × (1 + Δ/Δref)``;
Δ is the stick-out change from the identification and g the prediction's evidence group
(``pinned``: the near-optimal parameter sets agree on it within 0.2 %; ``free``: they do
not; ``unknown``: the mode was not measured in the tap, or a single set). This script takes
stored identifications of the realism corpus (``python -m benchmarks.realism.run ... --out``
JSONs: holders outside the model family, described as a careful user would), predicts
every query stick-out again from the stored near-optimal sets with the set and geometry
parts alone (nothing is re-identified), and computes for each prediction the smallest c
that covers its error. c_g is the Mondrian (group-conditional) split-conformal quantile of
these at level ⌈0.9 (n_g + 1)⌉ / n_g: each group is covered ≥ 90 % on exchangeable holders.
``--validate`` measures coverage and half-width on other records (never used to calibrate)
with the coefficients just calibrated and with those in bands.py.

The whole loop, on the code of the working tree. Measured 2026-11-25 on the idle 2-core
machine: each ``run`` of 24 cases ≈ 1 min wall (≈ 1.4 CPU-min), the calibration ≈ 3.5 min
without ``--cache`` (it re-predicts every query of every file with finite-difference
geometry sensitivities), seconds with it. Calibration: 72 holders per tier (three files
of 24 each, under the 200 kB limit); validation: 48 per tier::

    export PYTHONPATH=$PWD OPENBLAS_NUM_THREADS=1
    R=benchmarks/realism
    for tier in issue harsh; do
      for start in 0 24 48; do
        s=$([ $start = 0 ] && echo "" || echo "_$start")
        python -m benchmarks.realism.run --tier $tier --split calibration --start $start --n 24 --jobs 2 \
            --out $R/results_${tier}_calibration$s.json
      done
      for start in 0 24; do
        s=$([ $start = 0 ] && echo "" || echo "_$start")
        python -m benchmarks.realism.run --tier $tier --split validation --start $start --n 24 --jobs 2 \
            --out $R/results_${tier}_validation$s.json
      done
    done
    python -m benchmarks.realism.run --split infamily --n 12 --jobs 2 --out $R/results_infamily.json
    python benchmarks/calibrate_bands.py --records $R/results_*_calibration*.json \
        --validate $R/results_issue_validation*.json $R/results_harsh_validation*.json $R/results_infamily.json \
        --cache /tmp/taptune-band-rows.json --by-tier --write [--variants]
    python benchmarks/calibrate_bands.py --rewrite-results $R/results_*.json
    # joint (two-tap) identifications: MODEL_FORM_JOINT
    for tier in issue harsh; do for split in calibration:72 validation:48; do
      python -m benchmarks.realism.two_taps --tier $tier --split ${split%:*} --n ${split#*:} --jobs 2 \
          --single "$R/results_${tier}_${split%:*}*.json" --out $R/two_taps_${tier}_${split%:*}.json
    done; done
    python benchmarks/calibrate_bands.py --joint --records $R/two_taps_*_calibration.json \
        --validate $R/two_taps_*_validation.json --write
    python -m pytest tests/identify/test_bands.py tests/realism

``--by-tier`` calibrates each tier alone and keeps the larger c (the shipped choice: each
tier covered, not only the pool). ``--write`` puts MODEL_FORM, DELTA_REF_MM and CALIBRATION into bands.py; the comment above
MODEL_FORM and the numbers in docs/physics.md §5 are then updated by hand from the printout
(the ``(validation)`` lines). Re-measure the harsh tier too: the best fits may stay the
same while the near-optimal sets (the band's set part and the groups) change with the code.

Without ``--write`` it only prints (the coefficients to paste into bands.py and the
validation). ``--variants`` also prints the other band forms tried (per group and mode,
fitted Δref, a scaled set part), each calibrated on the records and measured on the
validation records.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import re
import sys
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

import numpy as np  # noqa: E402

from taptune.identify import bands, predict  # noqa: E402

ZERO = {g: 0.0 for g in bands.GROUPS}


def load(paths) -> list[dict]:
    """The case records of benchmarks.realism.run results JSONs."""
    out = []
    for p in paths:
        out += json.loads(Path(p).read_text())["cases"]
    return out


def rows(records: list[dict]) -> list[dict]:
    """Per prediction (query × mode): frequency, |error|, the band's set and geometry parts
    [Hz], the stick-out change [mm], the evidence group, and the case's tier and split."""
    from benchmarks.realism.corpus import case_of
    from benchmarks.realism.run import reevaluate

    out = []

    def band(sets, asm, rec):
        case = case_of(rec)
        measured = [m is not None for m in rec["identification"]["bending_measured_hz"]]
        p = predict(sets, asm, relative_floor=rec["identification"]["relative_floor"],
                    identified=[case.described], model_form=ZERO, measured_modes=measured)
        q = next(q for q in case.queries if abs(q.stickout_mm - asm.stickout * 1e3) < 1e-6)
        b = p.band
        for m, (f, t) in enumerate(zip(p.bending_hz, q.truth.bending_hz)):
            out.append({"case": rec["name"], "tier": rec.get("tier", "harsh"), "split": rec["split"],
                        "mode": m + 1, "f": f, "err": abs(f - t), "set": b.set_hz[m], "geom": b.geometry_hz[m],
                        "delta": b.delta_stickout_mm, "group": b.model_form_groups[m], "measured": measured[m]})
        return p

    reevaluate([r for r in records if "failed" not in r], band)
    return out


def cached_rows(paths, cache: str | None) -> list[dict]:
    """:func:`rows` of each results JSON, through the ``cache`` file when given."""
    store = json.loads(Path(cache).read_text()) if cache and Path(cache).exists() else {}
    out = []
    for p in paths:
        st = Path(p).stat()
        key = f"{Path(p).resolve()}|{st.st_size}|{st.st_mtime_ns}"
        if key not in store:
            store[key] = rows(load([p]))
        out += store[key]
    if cache:
        Path(cache).write_text(json.dumps(store))
    return out


def scale(r, delta_ref: float) -> float:
    """The stick-out growth factor 1 + Δ/Δref (Δref = inf: none)."""
    return 1.0 + (0.0 if math.isinf(delta_ref) else r["delta"] / delta_ref)


def need(r, delta_ref: float = bands.DELTA_REF_MM, set_scale: float = 1.0) -> float:
    """The smallest model-form c that covers this prediction's error."""
    extra = max(r["err"] ** 2 - (set_scale * r["set"]) ** 2 - r["geom"] ** 2, 0.0)
    return math.sqrt(extra) / (r["f"] * scale(r, delta_ref))


def key_of(r, per_mode: bool) -> str:
    return f"{r['group']}/{r['mode']}" if per_mode else r["group"]


def calibrate(rows_, delta_ref=bands.DELTA_REF_MM, per_mode=False, set_scale=1.0, by_tier=False) -> dict:
    """Mondrian split-conformal c per group (or per group and mode: keys ``group/mode``).

    ``by_tier``: calibrated on each corpus tier alone and the largest c of the tiers
    kept, so that each tier's holders are covered (pooled, the easier tier's many small
    errors let the harder tier's go uncovered).
    """
    if by_tier:
        per = [calibrate([r for r in rows_ if r["tier"] == t], delta_ref, per_mode, set_scale)
               for t in sorted({r["tier"] for r in rows_})]
        return {k: max(c.get(k, 0.0) for c in per) for k in sorted(set().union(*per))}
    scores: dict[str, list] = {}
    for r in rows_:
        scores.setdefault(key_of(r, per_mode), []).append(need(r, delta_ref, set_scale))
    return {k: bands.conformal_quantile(v) for k, v in sorted(scores.items())}


def coefficient(c: dict, r, per_mode: bool) -> float:
    """c of the row's cell; a cell the calibration never saw gets its group's (else any) largest."""
    k = key_of(r, per_mode)
    if k in c:
        return c[k]
    same = [v for key, v in c.items() if key.split("/")[0] == r["group"]]
    return max(same or c.values())


def half_width(r, c: dict, delta_ref=bands.DELTA_REF_MM, per_mode=False, set_scale=1.0) -> float:
    model = coefficient(c, r, per_mode) * r["f"] * scale(r, delta_ref)
    return float(bands.compose(set_scale * r["set"], r["geom"], model))


def stats(rows_, c, delta_ref=bands.DELTA_REF_MM, per_mode=False, set_scale=1.0) -> dict:
    """Coverage, half-width (median, mean) and |error| over rows, overall and per group."""
    if not rows_:
        return {"n": 0}
    h = np.array([half_width(r, c, delta_ref, per_mode, set_scale) / r["f"] for r in rows_])
    e = np.array([r["err"] / r["f"] for r in rows_])
    inside = e <= h + 1e-12
    groups = {g: f"{np.mean(inside[[r['group'] == g for r in rows_]]):.0%} of "
                 f"{sum(r['group'] == g for r in rows_)}" for g in bands.GROUPS if any(r["group"] == g for r in rows_)}
    return {"n": len(rows_), "coverage": float(np.mean(inside)), "half_median_pct": 100 * float(np.median(h)),
            "half_mean_pct": 100 * float(np.mean(h)),
            "half_measured_median_pct": 100 * float(np.median(h[[r["measured"] for r in rows_]]))
            if any(r["measured"] for r in rows_) else float("nan"), "err_median_pct": 100 * float(np.median(e)),
            "err_max_pct": 100 * float(np.max(e)),
            "measured_err_median_pct": 100 * float(np.median(e[[r["measured"] for r in rows_]]))
            if any(r["measured"] for r in rows_) else float("nan"), "groups": groups}


def line(title: str, s: dict) -> str:
    if not s["n"]:
        return f"{title}: no predictions"
    return (f"{title:34s} n {s['n']:3d}  covered {s['coverage']:6.1%}  ± median {s['half_median_pct']:.2f} % "
            f"(measured modes {s['half_measured_median_pct']:.2f} %, mean {s['half_mean_pct']:.2f} %)  |err| median {s['err_median_pct']:.2f} % "
            f"(measured modes {s['measured_err_median_pct']:.2f} %), max {s['err_max_pct']:.2f} %  "
            f"by group: {', '.join(f'{g} {v}' for g, v in s['groups'].items())}")


def by_set(rows_) -> dict[str, list]:
    """Rows split by (tier, split) for reporting."""
    out: dict[str, list] = {}
    for r in rows_:
        out.setdefault(f"{r['tier']} {r['split']}", []).append(r)
    return out


#: Δref tried. No growth (Δref = ∞) is left out: at Δ = 0 the model reproduces the
#: tap, so the model-form error must grow from there; the corpus's Δ (5–20 mm) cannot
#: tell the forms apart (median half-widths within 0.1 % of each other, ∞ included).
DELTA_REFS = (5.0, 10.0, 20.0, 40.0)


def fit_delta_ref(cal, by_tier: bool = False) -> tuple[float, dict]:
    """Δref of the growth 1 + Δ/Δref, fitted on the calibration rows: the one of
    :data:`DELTA_REFS` whose conformal c give the smallest median half-width there
    (coverage ≥ 90 % per group holds for every Δref by construction). Returns (Δref, c)."""
    best = None
    for d in DELTA_REFS:
        c = calibrate(cal, delta_ref=d, by_tier=by_tier)
        h = stats(cal, c, delta_ref=d)["half_median_pct"]
        print(f"  Δref {d:g} mm: median half-width {h:.3f} %, c = "
              + ", ".join(f"{k} {100 * v:.3f} %" for k, v in c.items()))
        if best is None or h < best[0] - 1e-9:
            best = (h, d, c)
    return best[1], best[2]


def variants(cal, val, by_tier: bool = False) -> None:
    """Other band forms: calibrated on ``cal`` (each tier alone, the larger c kept, when
    ``by_tier``, as the shipped form), measured on ``val`` (reported, not used unless chosen)."""
    print(f"\nvariants ({'by tier' if by_tier else 'pooled'}, calibrated on the records, measured on the validation records):")
    forms = [(f"per group, Δref {bands.DELTA_REF_MM:g} mm (bands.py form)", dict(delta_ref=bands.DELTA_REF_MM)),
             (f"per group and mode, Δref {bands.DELTA_REF_MM:g} mm", dict(delta_ref=bands.DELTA_REF_MM, per_mode=True)),
             (f"per group, Δref {bands.DELTA_REF_MM:g} mm, {'pooled tiers' if by_tier else 'largest of the tiers'}",
              dict(delta_ref=bands.DELTA_REF_MM, by_tier=not by_tier))]
    for d in sorted({5.0, 10.0, 20.0, 40.0, math.inf} - {bands.DELTA_REF_MM}):  # ∞: no growth with Δ
        forms.append((f"per group, Δref {d:g} mm", dict(delta_ref=d)))
    for s in (0.5, 0.0):
        forms.append((f"per group, set part × {s:g}", dict(delta_ref=bands.DELTA_REF_MM, set_scale=s)))
    for name, kw in forms:
        c = calibrate(cal, **{"by_tier": by_tier, **kw})
        kw.pop("by_tier", None)
        print(f"  {name}: c = {', '.join(f'{k} {100 * v:.3f} %' for k, v in c.items())}")
        print("    " + line("calibration (in-sample)", stats(cal, c, **kw)))
        for title, rs in by_set(val).items():
            print("    " + line(f"{title}", stats(rs, c, **kw)))


def write_constants(c: dict, delta_ref: float, note: str) -> None:
    """Put the calibrated MODEL_FORM (and Δref, the note) into taptune/identify/bands.py."""
    path = REPO / "taptune" / "identify" / "bands.py"
    text = path.read_text()
    body = ", ".join(f'"{g}": {round(c.get(g, max(c.values())), 5)}' for g in bands.GROUPS)
    text, n1 = re.subn(r"^MODEL_FORM = \{.*\}$", f"MODEL_FORM = {{{body}}}", text, flags=re.M)
    ref = 'float("inf")' if math.isinf(delta_ref) else repr(float(delta_ref))
    text, n2 = re.subn(r"^DELTA_REF_MM = .*$", f"DELTA_REF_MM = {ref}", text, flags=re.M)
    text, n3 = re.subn(r'^CALIBRATION = ".*"$', f"CALIBRATION = {json.dumps(note, ensure_ascii=False)}", text, flags=re.M)
    if (n1, n2, n3) != (1, 1, 1):
        raise SystemExit(f"bands.py: could not find the MODEL_FORM / DELTA_REF_MM / CALIBRATION lines ({n1, n2, n3})")
    path.write_text(text)
    print(f"wrote MODEL_FORM = {{{body}}}, DELTA_REF_MM = {ref} into {path}")


def joint(cal_paths, val_paths, write: bool) -> None:
    """Calibrate MODEL_FORM_JOINT on joint (two-tap) identifications: the ``rows`` of
    ``benchmarks/realism/two_taps.py`` results (set and geometry parts of each prediction
    of the stick-out no tap saw), each tier alone, the larger c kept, and never below the
    one-tap c of the group (a holder's library history can mix one-tap and joint
    identifications); measured on the validation rows."""
    cal = [r for p in cal_paths for rec in load([p]) for r in rec.get("rows", [])]
    val = [r for p in val_paths for rec in load([p]) for r in rec.get("rows", [])]
    raw = calibrate(cal, delta_ref=bands.DELTA_REF_MM, by_tier=True)
    c = {g: max(raw.get(g, 0.0), bands.MODEL_FORM[g]) for g in bands.GROUPS}
    print(f"joint identifications, {len(cal)} predictions: calibrated c "
          + ", ".join(f"{g} {100 * raw.get(g, 0.0):.3f} % (n {sum(r['group'] == g for r in cal)})" for g in bands.GROUPS)
          + "; kept (at least one tap's): " + ", ".join(f"{g} {100 * v:.3f} %" for g, v in c.items()))
    for title, rs in by_set(val).items():
        print("  " + line(f"{title} (validation), one-tap c", stats(rs, bands.MODEL_FORM)))
        print("  " + line(f"{title} (validation), joint c", stats(rs, c)))
    if write:
        path = REPO / "taptune" / "identify" / "bands.py"
        body = ", ".join(f'"{g}": {round(v, 5)}' for g, v in c.items())
        text, n = re.subn(r"^MODEL_FORM_JOINT = .*$", f"MODEL_FORM_JOINT = {{{body}}}", path.read_text(), flags=re.M)
        if n != 1:
            raise SystemExit("bands.py: could not find the MODEL_FORM_JOINT line")
        path.write_text(text)
        print(f"wrote MODEL_FORM_JOINT = {{{body}}} into {path}")


def rewrite_results(paths) -> None:
    """Redo the stored predictions of results JSONs with the bands now in bands.py (run after
    ``--write``, in a new process), as :func:`benchmarks.realism.run.run_case` predicts:
    their ``covered`` and half-widths, and their summaries, then say what the shipped bands do."""
    from benchmarks.realism.corpus import case_of
    from benchmarks.realism.run import product_predict, reevaluate, summarise, write_results

    for p in paths:
        data = json.loads(Path(p).read_text())

        def band(sets, asm, rec):
            return product_predict(sets, asm, case_of(rec), rec["identification"])

        data["cases"] = reevaluate(data["cases"], band)
        data["summary"] = summarise(data["cases"])
        data["meta"]["bands"] = f"MODEL_FORM {bands.MODEL_FORM}, DELTA_REF_MM {bands.DELTA_REF_MM:g}"
        write_results(p, data)
        t = data["summary"]["transfer"]
        print(f"{p}: coverage {t['coverage']:.1%}, median ± {t['half_width_median_pct']:.2f} %")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--records", nargs="+", default=[], help="results JSONs to calibrate on")
    ap.add_argument("--validate", nargs="*", default=[], help="results JSONs to measure on (never calibrated on)")
    ap.add_argument("--write", action="store_true", help="write the calibrated constants into bands.py")
    ap.add_argument("--variants", action="store_true", help="also print the other band forms tried")
    ap.add_argument("--by-tier", action="store_true", help="calibrate each tier alone and keep the largest c "
                                                            "per group (every tier covered, not only the pool)")
    ap.add_argument("--cache", help="a JSON file keeping the per-prediction rows of each results file "
                                     "(by path, size and time): a second run skips the re-prediction")
    ap.add_argument("--joint", action="store_true", help="calibrate MODEL_FORM_JOINT on two-tap results "
                                                          "(benchmarks/realism/two_taps.py) instead")
    ap.add_argument("--rewrite-results", nargs="+", metavar="JSON",
                    help="only redo the predictions of these results JSONs with the bands now in bands.py")
    args = ap.parse_args(argv)
    if args.rewrite_results:
        rewrite_results(args.rewrite_results)
        return 0
    if not args.records:
        ap.error("--records is required (or --rewrite-results)")
    if args.joint:
        joint(args.records, args.validate, args.write)
        return 0
    cal = cached_rows(args.records, args.cache)
    val = cached_rows(args.validate, args.cache) if args.validate else []
    print("set + geometry only:")
    for title, rs in by_set(cal + val).items():
        print("  " + line(title, stats(rs, ZERO)))
    print("\nthe stick-out-change growth 1 + Δ/Δref, fitted on the calibration records:")
    delta_ref, c = fit_delta_ref(cal, args.by_tier)
    print(f"\nMondrian split-conformal c per group (90 %), Δref {delta_ref:g} mm, on "
          f"{len(cal)} predictions: " + ", ".join(f"{k} {v:.5f} (n {sum(r['group'] == k for r in cal)})"
                                                   for k, v in c.items()))
    print("  " + line("calibration (in-sample)", stats(cal, c, delta_ref)))
    for title, rs in by_set(val).items():
        print("  " + line(f"{title} (validation)", stats(rs, c, delta_ref)))
    print(f"\nwith bands.MODEL_FORM {bands.MODEL_FORM}, Δref {bands.DELTA_REF_MM:g} mm:")
    for title, rs in by_set(cal + val).items():
        print("  " + line(title, stats(rs, bands.MODEL_FORM)))
    if args.variants:
        variants(cal, val, args.by_tier)
    if args.write:
        tiers = " + ".join(sorted({r["tier"] for r in cal}))
        n_cases = len({r["case"] for r in cal})
        note = (f"realism corpus, {tiers} tiers: {n_cases} holders, {len(cal)} predictions; "
                f"Mondrian split-conformal 90 % per evidence group"
                + (", the largest of the tiers" if args.by_tier else ""))
        write_constants(c, delta_ref, note)
    return 0


if __name__ == "__main__":
    sys.exit(main())
