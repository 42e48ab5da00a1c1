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

Stick-outs read with a gauge (``run --stickout-error 0.05 --out $R/gauge_…``; the
validation records are stored as ``gauge_*_validation*.json``)::

    python benchmarks/calibrate_bands.py --gauge --records <gauge calibration JSONs> \
        --validate $R/gauge_*_validation*.json

measured 2026-11-25 (identifications with the extreme pushes' former 0.05 first step;
the stored validation records are of the 0.01 step: issue tier 96.9 % at ± 2.21 %, harsh
91.3 % at 2.90 % with the shipped c; the gauge calibration records are not stored, run
them as above to reproduce): c calibrated on 144 such holders are pinned 0.435 %, free 1.276 %,
unknown 2.965 % (shipped 0.566 / 1.074 / 2.884 %): no narrower bands (validation issue
tier ± 2.63 % against 2.25 % with the shipped c, both ≈ 97 % covered), so the shipped c
serve a gauge too.

What the fit shows (issue 22): ``--evidence`` asks whether the misfit of the fit (against
the measured modes, relative to the peaks' 0.05 % precision) and the number of measured
modes predict the transfer error, and calibrates Mondrian cells evidence group × fit class
(``explained``: all three modes measured and met within 2 × 0.05 %), each tier alone: the
ruler tiers, the gauge-read holders (``gauge_*_validation.json``, then not validation; the
``_24`` halves stay held out) as tiers of their own, and in-family holders with the
stick-out stated to 0.05 mm (``run --split infamily --stickout-error 0.05``: indices 12–29
calibrate, 0–11 and 30–47 validate)::

    python benchmarks/calibrate_bands.py --by-tier --evidence --cache /tmp/rows.json \
        --records $R/results_issue_calibration*.json $R/results_harsh_calibration*.json \
                  $R/results_infamily_gauge_calibration.json \
                  $R/gauge_issue_validation.json $R/gauge_harsh_validation.json \
        --validate $R/results_issue_validation*.json $R/results_harsh_validation*.json \
                   $R/results_infamily_gauge_validation*.json $R/gauge_*_validation_24.json

Measured 2026-11-27 (stored records; 1140 calibration predictions outside the family, 108
in it): the fit's misfit (unfloored) barely ranks the errors — Spearman with |error| +0.16
(pinned), +0.03 (free), +0.18 (unknown), with the c each prediction needs −0.01, −0.00,
+0.21; the 90 % c of the pinned predictions by misfit tercile 0.36 / 0.24 / 0.47 %. In-family
fits of three modes meet them to a median 0.009 %, outside ones to 0.014–0.016 %: one tap's
three frequencies are met by five parameters whatever the holder. The number of measured
modes does predict the error (outside: median 0.37 / 1.16 / 2.03 % with 3 / 2 / 1 modes),
but the set part already follows it (set + geometry median 0.77 / 1.92 / 8.56 %). The cells
group × fit class need, each tier alone: pinned/explained 0.35 % (harsh), 0.25 (issue),
0.84 (harsh gauge), 0.06 (issue gauge), 0 (in-family); the largest kept, every validation
set gets wider bands (issue 96.9 % at ±3.32 %, shipped 94.8 % at ±2.62 %; in-family 100 %
at ±2.86 %, shipped ±1.91 %). Calibrated on the ruler tiers alone they give pinned/explained
0.35 % but cover the pinned modes of 24 gauge-read harsh holders only 83 %. Whatever the
model-form term, set + geometry alone are ±0.76 % (median) on the in-family validation
holders (0.52 % with three modes heard), ±1.85 / 2.16 % on the ruler tiers and ±1.23 /
1.84 % on the gauge ones. bands.py is unchanged.

Two taps (``--joint --evidence`` on the two-tap records that keep the joint fit): the
taps *agree* (``bands.taps_agree``) when 5+ of their 6 frequencies were heard and the
joint fit meets all within 0.1 %. With a ruler none of 48 holders outside the family
agreed (``two_taps_<tier>_<split>_12.json``; with 5–6 heard their joint misfit is
0.13–3.6 %), 13 of 24 in the family did (``two_taps_infamily_*.json``, errors ≤ 0.11 %).
With the stick-outs read to ±0.05 mm (``two_taps --stickout-error 0.05``, calibration
split, first 16 holders per tier, 15 identified each; validation split, first 12; stored as
``two_taps_gauge_<tier>_<split>.json``, whose ``predictions`` carry the joint c: the
``rows`` serve here; ≈ 3 CPU-min per 16 holders)::

    python -m benchmarks.realism.two_taps --tier issue --split calibration --n 16 --stickout-error 0.05 \
        --out $R/two_taps_gauge_issue_calibration.json   # likewise harsh; --split validation --n 12
    python benchmarks/calibrate_bands.py --joint --evidence --records $R/two_taps_gauge_*_calibration.json \
        $R/two_taps_infamily_calibration.json \
        --validate $R/two_taps_gauge_*_validation.json $R/two_taps_infamily_validation.json

6 of 30 agreed (issue 5, harsh 1), errors ≤ 0.30 %; of the 36 predictions of agreeing
holders (with the in-family 6) 35 lay inside set + geometry alone, one needed c 0.127 %:
``MODEL_FORM_AGREED`` pinned (free and unknown: too few, they keep the joint c).
Held out (validation split, first 12 per tier, gauged; ``two_taps_infamily_validation``):
none of 24 holders outside the family agreed (their bands, the joint c: issue 97.2 % at
±1.64 %, harsh 100 % at ±1.96 %); 7 of 12 in the family did, their 21 predictions all
covered at ±0.35 % (all 12: 97.2 % at ±0.61 %, joint c ±0.98 %).

Where the band comes from (``--decompose``, 2026-11-27; in-family holders with the
stick-out stated to 0.05 mm, ``results_infamily_gauge_*.json``, 288 predictions):
|error| median 0.08 % (pinned 0.044 %, p90 0.12 %); the set part alone covers 92 % at
a median ±0.23 %, with the stick-out parts 95.1 % at ±0.28 %; the geometry part is
±0.52 % (median), of which flute ratio 0.47 %, stick-out 0.08 % + 0.08 % (identified),
diameters 0.06 %; set + geometry ±0.87 % (three modes heard ±0.52 %), with the shipped c
±2.02 % (99.3 % covered). Outside the family with a ruler (calibration records) the
stick-out parts lead (pinned: 0.48 + 0.47 %, flute 0.31 / 0.40 % issue / harsh); with a
gauge (``gauge_harsh_validation.json``) the flute ratio (pinned 0.51 %). ``--refit 8``
(the first 8 in-family calibration holders): a flute ratio 0.05 off absorbed by the
smallest linearised refit at the tapped stick-out moves the queries' measured modes by
0.86 % (median), the band counts 0.75 %, the raw sensitivity is 1.09 %; diameters 1 %:
0.081 / 0.078 / 0.252 % — neither part is overstated. A c of its own for gauge-read
stick-outs (``--by-tier --records gauge_{issue,harsh}_validation.json``, validated on
the ``_24`` halves): pinned 0.66 %, free 0.40 %, unknown 0.63 % give issue 92.4 % at
±1.64 %, harsh 82.6 % (free 74 %) at ±2.16 % against the shipped 96.9 % at ±2.21 % and
91.3 % at ±2.90 %: under-covers, not shipped. ``--offsets`` (predictions at other
stick-out changes from the stored identifications), with the shipped c: the gauge
records above with ``--offsets 0 2 5`` 94–100 % covered at Δ 0, 2 and 5 mm (median
±0.61 / 0.9 / 1.5–1.8 %); the ruler calibration records with ``--offsets -5 5 -2 2``
88.6 % (harsh) and 91.8 % (issue) at Δ 2 mm, 88.8 / 94.5 % at 5 mm, 91.4 / 96.5 % at
10 mm: the growth 1 + Δ/10 mm holds down to small changes (the model-form c each
prediction needs does not fall towards Δ 0 with a ruler, whose reading error the
stated 0.3 mm understates).

``--by-tier`` calibrates each tier alone and keeps the larger c (the shipped choice: each
tier covered, not only the pool). ``--write`` puts MODEL_FORM, DELTA_REF_MM and CALIBRATION into bands.py; the comment above
MODEL_FORM and the numbers in docs/physics.md §5 are then updated by hand from the printout
(the ``(validation)`` lines). Re-measure the harsh tier too: the best fits may stay the
same while the near-optimal sets (the band's set part and the groups) change with the code.

Without ``--write`` it only prints (the coefficients to paste into bands.py and the
validation). ``--variants`` also prints the other band forms tried (per group and mode,
fitted Δref, a scaled set part; Mondrian cells by holder kind, by the interface band, by
mode 1; normalised scores ``c_g × (x / median x)^p × f × (1 + Δ/Δref)`` for each feature of
:data:`FEATURES`, p fitted on the records), each calibrated on the records and measured
on the validation records, then a 6-fold cross-validation by holder on the records and a
leave-one-tier-out check of the feature chosen on the records alone.

Measured 2026-11-25 (records of commit 829f3d9, ``--by-tier``; the interface band was
then 9.4–10.5 kHz, now the product's 9.35–10.55 kHz): the shipped form covers
the validation's issue tier 93.8 % at a median ± 2.60 %, the harsh tier 91.3 % (pinned
84 %) at 3.23 %. The best normalised score chosen on the records, x = f / mode number,
p = 0.75: issue 93.8 % (pinned 93, free 94, unknown 95 %) at 2.42 %, harsh 92.0 % (pinned
87 %) at 3.05 %, in-family 100 % at 1.94 % (2.06 %); cross-validated on the records only
0.14 (issue) and 0.07 (harsh) percentage points narrower. L/D^-0.75 is alike (2.40 / 3.11 %),
every other feature and the Mondrian cells gain less or lose coverage (holder kind: 3.99 /
3.74 %, its cells too small). Two features, (f/n)^0.75 × (Δ / tapped stick-out)^-0.25 (the
best pair on the records): issue 94.4 % at 2.43 %, harsh 91.0 % (pinned 85 %) at 2.93 %,
in-family 1.92 %; cross-validated 0.20 / 0.18 points narrower at the same coverage. Not
shipped: none gains the 0.2 points asked for on both tiers' validation. The set and
geometry parts alone have a median of 1.81 % / 2.14 %, so no model-form term, however
well it adapts, brings the median to 1.5 % at the default tolerances.
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
from benchmarks.realism.geometry import FAMILIES  # noqa: E402
from taptune.signal.labels import interface_bands  # noqa: E402

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
        ident = rec["identification"]
        terms = np.asarray(ident.get("objective_terms") or [[math.nan, math.nan]], dtype=float)
        for m, (f, t) in enumerate(zip(p.bending_hz, q.truth.bending_hz)):
            out.append({"case": rec["name"], "tier": tier_of(rec), "split": rec["split"],
                        "mode": m + 1, "f": f, "err": abs(f - t), "set": b.set_hz[m], "geom": b.geometry_hz[m],
                        "delta": b.delta_stickout_mm, "group": b.model_form_groups[m], "measured": measured[m],
                        # features known at prediction time, for the normalised-score variants
                        "family": rec.get("family"), "floor": ident["relative_floor"],
                        "obj_freq": float(terms[:, 0].sum()), "obj_shape": float(terms[:, 1].sum()),
                        "n_measured": int(sum(measured)), "misfit": raw_misfit(ident),
                        "stickout": asm.stickout * 1e3, "stickout_tapped": case.described.stickout * 1e3,
                        "diameter": rec["tool"]["diameter_mm"], "f_all": list(p.bending_hz),
                        "parts": {k: v[m] for k, v in b.geometry_parts_hz.items()}})
        return p

    reevaluate([r for r in records if "failed" not in r], band)
    return out


def tier_of(rec: dict) -> str:
    """The corpus tier of a record; the in-family control is a tier of its own, and so are
    stick-outs read with a gauge (``<tier> gauge``: the geometry part is small there, so
    the model-form term must carry more of the error)."""
    from benchmarks.realism.corpus import RULER_MM

    if rec["split"] == "infamily":
        return "infamily"
    tier = rec.get("tier", "harsh")
    return tier if rec.get("stickout_error_mm", RULER_MM) == RULER_MM else f"{tier} gauge"


def raw_misfit(ident: dict) -> float:
    """Largest relative miss of the fitted model on the measured frequencies (no floor) [–]."""
    pairs = [(m, f) for m, f in zip(ident["bending_measured_hz"], ident["bending_model_hz"]) if m is not None]
    return max([0.0] + [abs(f / m - 1) for m, f in pairs])


def cached_rows(paths, cache: str | None) -> list[dict]:
    """:func:`rows` of each results JSON, through the ``cache`` file when given (an entry
    made before the rows had their features is made again)."""
    store = json.loads(Path(cache).read_text()) if cache and Path(cache).exists() else {}
    out = []
    for p in paths:
        st = Path(p).stat()
        key = f"{Path(p).resolve()}|{st.st_size}|{st.st_mtime_ns}"
        if key not in store or any("parts" not in r for r in store[key]):
            store[key] = rows(load([p]))
        out += store[key]
    if cache:
        Path(cache).write_text(json.dumps(store))
    return out


def scale(r, delta_ref: float) -> float:
    """The stick-out growth factor 1 + Δ/Δref (Δref = inf: none)."""
    return 1.0 + (0.0 if math.isinf(delta_ref) else r["delta"] / delta_ref)


def need(r, delta_ref: float = bands.DELTA_REF_MM, set_scale: float = 1.0, sigma=None) -> float:
    """The smallest model-form c that covers this prediction's error (divided by the
    prediction's scale ``sigma(r)`` when given: a normalised conformal score)."""
    extra = max(r["err"] ** 2 - (set_scale * r["set"]) ** 2 - r["geom"] ** 2, 0.0)
    return math.sqrt(extra) / (r["f"] * scale(r, delta_ref) * (1.0 if sigma is None else sigma(r)))


def key_of(r, per_mode: bool, cell=None) -> str:
    """The Mondrian cell of a row: its group, ``group/mode``, or ``group/cell(r)``."""
    if cell is not None:
        return f"{r['group']}/{cell(r)}"
    return f"{r['group']}/{r['mode']}" if per_mode else r["group"]


def calibrate(rows_, delta_ref=bands.DELTA_REF_MM, per_mode=False, set_scale=1.0, by_tier=False, sigma=None,
              cell=None) -> dict:
    """Mondrian split-conformal c per group (or per group and mode: keys ``group/mode``;
    or per group and ``cell(row)``: keys ``group/cell``).

    ``by_tier``: calibrated on each corpus tier alone and the largest c of the tiers
    kept, so that each tier's holders are covered (pooled, the easier tier's many small
    errors let the harder tier's go uncovered). ``sigma``: a per-prediction scale known
    at prediction time (row → number > 0); the model-form term is then
    ``c × sigma × f × (1 + Δ/Δref)`` and c the quantile of the normalised scores.
    """
    if by_tier:
        per = [calibrate([r for r in rows_ if r["tier"] == t], delta_ref, per_mode, set_scale, sigma=sigma, cell=cell)
               for t in sorted({r["tier"] for r in rows_})]
        return {k: max(c.get(k, 0.0) for c in per) for k in sorted(set().union(*per))}
    scores: dict[str, list] = {}
    for r in rows_:
        scores.setdefault(key_of(r, per_mode, cell), []).append(need(r, delta_ref, set_scale, sigma))
    return {k: bands.conformal_quantile(v) for k, v in sorted(scores.items())}


def coefficient(c: dict, r, per_mode: bool, cell=None) -> float:
    """c of the row's cell; a cell the calibration never saw gets its group's (else any) largest."""
    k = key_of(r, per_mode, cell)
    if k in c:
        return c[k]
    same = [v for key, v in c.items() if key.split("/")[0] == r["group"]]
    return max(same or c.values())


def half_width(r, c: dict, delta_ref=bands.DELTA_REF_MM, per_mode=False, set_scale=1.0, sigma=None,
               cell=None) -> float:
    model = coefficient(c, r, per_mode, cell) * r["f"] * scale(r, delta_ref) * (1.0 if sigma is None else sigma(r))
    return float(bands.compose(set_scale * r["set"], r["geom"], model))


def stats(rows_, c, delta_ref=bands.DELTA_REF_MM, per_mode=False, set_scale=1.0, sigma=None, cell=None) -> dict:
    """Coverage, half-width (median, mean) and |error| over rows, overall and per group."""
    if not rows_:
        return {"n": 0}
    h = np.array([half_width(r, c, delta_ref, per_mode, set_scale, sigma, cell) / r["f"] for r in rows_])
    e = np.array([r["err"] / r["f"] for r in rows_])
    inside = e <= h + 1e-12
    groups = {g: f"{np.mean(inside[[r['group'] == g for r in rows_]]):.0%} of "
                 f"{sum(r['group'] == g for r in rows_)} "
                 f"(±{100 * np.median(h[[r['group'] == g for r in rows_]]):.2f} %)"
              for g in bands.GROUPS if any(r["group"] == g for r in rows_)}
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


#: The interface modes' band [Hz] (HSK-A63) the identification and the check exclude.
INTERFACE_HZ = interface_bands("HSK-A63")[0][0]


def holder_kind(r) -> str:
    """The holder kind a user knows from the assembly file: collet (ER), shrinkfit or hydraulic."""
    family = r.get("family") or "unknown"
    known = next((f for f in FAMILIES if f.key == family), None)
    return "collet" if known is not None and known.collet else family


def interface_distance(r) -> float:
    """Relative distance of the predicted frequency from :data:`INTERFACE_HZ` (0 inside) [–]."""
    lo, hi = INTERFACE_HZ
    return 0.0 if lo <= r["f"] <= hi else min(abs(r["f"] - lo), abs(r["f"] - hi)) / r["f"]


def crossing_distance(r) -> float:
    """Relative distance of the predicted frequency from the nearest other predicted mode [–]."""
    return min(abs(f - r["f"]) for m, f in enumerate(r["f_all"]) if m != r["mode"] - 1) / r["f"]


#: Per-prediction features known at prediction time, tried (``--variants``) as the scale
#: of a normalised (heteroscedastic) conformal score: model form
#: ``c_g × (x / median x)^p × f × (1 + Δ/Δref)``, p fitted on the calibration records.
FEATURES = {
    "f/n (frequency / mode number)": lambda r: r["f"] / r["mode"],
    "L/D at the query": lambda r: r["stickout"] / r["diameter"],
    "fit misfit (relative_floor)": lambda r: r["floor"],
    "near-optimal sets' spread": lambda r: r["set"] / r["f"],
    "objective frequency term": lambda r: r["obj_freq"],
    "objective shape term": lambda r: r["obj_shape"],
    "measured modes": lambda r: r["n_measured"],
    "mode number": lambda r: r["mode"],
    "Δ / tapped stick-out": lambda r: r["delta"] / r["stickout_tapped"],
    "distance to the interface band": interface_distance,
    "distance to the nearest other mode": crossing_distance,
}
#: Exponents p tried for each feature.
EXPONENTS = (-1.0, -0.75, -0.5, -0.25, 0.25, 0.5, 0.75, 1.0)


def power_scale(cal, feature: str, p: float):
    """``sigma(r) = (x / median x)^p`` with the median of the calibration rows (x floored at
    5 % of it, so that a zero feature cannot make the band vanish or blow up)."""
    x = FEATURES[feature]
    values = np.array([x(r) for r in cal], dtype=float)
    med = float(np.median(values[values > 0])) if np.any(values > 0) else 1.0
    return lambda r: (max(x(r), 0.05 * med) / med) ** p


def fit_exponent(cal, feature: str, by_tier: bool) -> tuple[float, float]:
    """The exponent of :data:`EXPONENTS` whose conformal c give the smallest median half-width
    on ``cal`` (each group covered ≥ 90 % there by construction). Returns (p, that median [%])."""
    best = None
    for p in EXPONENTS:
        sigma = power_scale(cal, feature, p)
        h = stats(cal, calibrate(cal, by_tier=by_tier, sigma=sigma), sigma=sigma)["half_median_pct"]
        if best is None or h < best[1] - 1e-9:
            best = (p, h)
    return best


def fit_pair(cal, first: str, second: str, by_tier: bool):
    """Exponents (p, q) of :data:`EXPONENTS` for ``sigma = first^p × second^q`` (each over its
    median) with the smallest median half-width on ``cal``. Returns (p, q, sigma)."""
    best = None
    for p, q in ((p, q) for p in EXPONENTS for q in EXPONENTS):
        a, b = power_scale(cal, first, p), power_scale(cal, second, q)
        sigma = (lambda a, b: lambda r: a(r) * b(r))(a, b)
        h = stats(cal, calibrate(cal, by_tier=by_tier, sigma=sigma), sigma=sigma)["half_median_pct"]
        if best is None or h < best[0] - 1e-9:
            best = (h, p, q, sigma)
    return best[1:]


def select_feature(cal, by_tier: bool):
    """The feature and exponent (or None: no scale) with the smallest median half-width on ``cal``."""
    best = (None, 0.0, stats(cal, calibrate(cal, by_tier=by_tier))["half_median_pct"])
    for feature in FEATURES:
        p, h = fit_exponent(cal, feature, by_tier)
        if h < best[2] - 1e-9:
            best = (feature, p, h)
    return best


def held_out_line(title, pairs) -> str:
    """Coverage (overall, per group) and median half-width of (row, half-width [–]) pairs."""
    h = np.array([w for _, w in pairs])
    inside = np.array([r["err"] / r["f"] <= w + 1e-12 for r, w in pairs])
    groups = ", ".join(f"{g} {np.mean(inside[[r['group'] == g for r, _ in pairs]]):.0%}" for g in bands.GROUPS
                       if any(r["group"] == g for r, _ in pairs))
    return (f"{title:34s} n {len(pairs):3d}  covered {np.mean(inside):6.1%}  ± median {100 * np.median(h):.2f} %  "
            f"by group: {groups}")


def cross_validate(cal, by_tier: bool, folds: int = 6, seed: int = 0) -> None:
    """K-fold check by holder on the calibration records: for each fold, the shipped form,
    the normalised score whose feature and exponent are chosen on the other folds
    (:func:`select_feature`, the whole choice redone per fold) and the two-feature score
    (:func:`fit_pair`, exponents fitted on the other folds) are calibrated on the other folds
    and measured on it."""
    cases = sorted({r["case"] for r in cal})
    order = np.random.default_rng(seed).permutation(len(cases))
    fold = {cases[i]: k % folds for k, i in enumerate(order)}
    out = {"shipped form": [], "selected feature": [], "f/n × Δ/L": []}
    chosen = []
    for k in range(folds):
        train = [r for r in cal if fold[r["case"]] != k]
        test = [r for r in cal if fold[r["case"]] == k]
        feature, p, _ = select_feature(train, by_tier)
        chosen.append("none" if feature is None else f"{feature} ^{p:g}")
        sigma = None if feature is None else power_scale(train, feature, p)
        pair = fit_pair(train, "f/n (frequency / mode number)", "Δ / tapped stick-out", by_tier)[2]
        for name, s in (("shipped form", None), ("selected feature", sigma), ("f/n × Δ/L", pair)):
            c = calibrate(train, by_tier=by_tier, sigma=s)
            out[name] += [(r, half_width(r, c, sigma=s) / r["f"]) for r in test]
    print(f"\n{folds}-fold cross-validation by holder on the calibration records (feature chosen per fold: "
          + "; ".join(chosen) + "):")
    for name, pairs in out.items():
        for tier in sorted({r["tier"] for r, _ in pairs}):
            print("  " + held_out_line(f"{name}, {tier}", [(r, w) for r, w in pairs if r["tier"] == tier]))


def leave_one_tier_out(cal, val) -> None:
    """Choose and calibrate on one tier's calibration records alone, measure the other tier's
    validation records: the shipped form vs the selected normalised score."""
    tiers = sorted({r["tier"] for r in cal})
    if len(tiers) < 2:
        return
    print("\nleave one tier out (chosen and calibrated on one tier, measured on the other's validation):")
    for a in tiers:
        train = [r for r in cal if r["tier"] == a]
        feature, p, _ = select_feature(train, False)
        for b in (t for t in tiers if t != a):
            test = [r for r in val if r["tier"] == b and r["split"] == "validation"]
            if not test:
                continue
            for name, s in (("shipped form", None),
                            (f"{feature} ^{p:g}" if feature else "no feature chosen",
                             None if feature is None else power_scale(train, feature, p))):
                c = calibrate(train, sigma=s)
                print("  " + line(f"{a} → {b}: {name}", stats(test, c, sigma=s)))


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
    # Mondrian cells known at prediction time beyond the evidence group.
    forms += [("per group and holder kind (collet/shrinkfit/hydraulic)", dict(cell=holder_kind)),
              ("per group, inside the interface band or not", dict(cell=lambda r: interface_distance(r) == 0)),
              ("per group, mode 1 or higher", dict(cell=lambda r: r["mode"] == 1))]
    # Normalised (heteroscedastic) scores: one feature, its exponent fitted on the records.
    for feature in FEATURES:
        p, _ = fit_exponent(cal, feature, by_tier)
        forms.append((f"per group × ({feature} / median)^{p:g}", dict(sigma=power_scale(cal, feature, p))))
    # Two features: the best single one with the stick-out change relative to the stick-out.
    pair = ("f/n (frequency / mode number)", "Δ / tapped stick-out")
    p, q, sigma = fit_pair(cal, *pair, by_tier)
    forms.append((f"per group × (f/n / median)^{p:g} × (Δ/L / median)^{q:g}", dict(sigma=sigma)))
    for name, kw in forms:
        c = calibrate(cal, **{"by_tier": by_tier, **kw})
        kw.pop("by_tier", None)
        print(f"  {name}: c = {', '.join(f'{k} {100 * v:.3f} %' for k, v in c.items())}")
        print("    " + line("calibration (in-sample)", stats(cal, c, **kw)))
        for title, rs in by_set(val).items():
            print("    " + line(f"{title}", stats(rs, c, **kw)))
    cross_validate(cal, by_tier)
    leave_one_tier_out(cal, val)


#: The peaks' relative precision (MEASUREMENT_FLOOR of taptune.identify.check, the fit
#: misfit's floor): a fit meeting every measured peak within EXPLAINED × this explains them.
PRECISION = 5e-4
EXPLAINED = 2.0


def fit_class(r) -> str:
    """What the fit shows about the model, known at prediction time: ``explained`` when
    the tap measured all three modes and the fit meets each within EXPLAINED × the peaks'
    precision, else ``partial``."""
    return "explained" if r["n_measured"] == 3 and r["misfit"] <= EXPLAINED * PRECISION else "partial"


def _rank_correlation(x, y) -> float:
    """Spearman's rank correlation (ties, e.g. the many predictions that need no c, share
    their mean rank)."""
    from scipy.stats import spearmanr

    return float(spearmanr(x, y).statistic)


def evidence(cal, val, by_tier: bool = True) -> None:
    """Does what the fit shows predict the transfer error? (issue 22.) On the calibration
    rows of holders outside the model family: per evidence group, the rank correlation of
    the fit's misfit (unfloored) with |error| and with the model-form c each prediction
    needs, and the 90 % conformal c per misfit tercile; per number of measured modes, the
    errors and the set + geometry parts, outside and inside the family; then Mondrian
    cells group × :func:`fit_class` calibrated (each tier alone, the largest kept, the
    in-family tier among them when given) and measured on the validation rows, beside the
    shipped c and the set + geometry parts alone (the narrowest any model-form term allows)."""
    outside = [r for r in cal if r["tier"] != "infamily"]
    print(f"\nwhat the fit shows vs the error ({len(outside)} calibration predictions outside the family):")
    for g in bands.GROUPS:
        rs = [r for r in outside if r["group"] == g]
        if len(rs) < 6:
            continue
        m = np.array([r["misfit"] for r in rs])
        e = np.array([r["err"] / r["f"] for r in rs])
        c = np.array([need(r) for r in rs])
        cuts = np.percentile(m, [100 / 3, 200 / 3])
        print(f"  {g}: n {len(rs)}, Spearman(misfit, |err|) {_rank_correlation(m, e):+.2f}, "
              f"(misfit, needed c) {_rank_correlation(m, c):+.2f}")
        for name, sel in (("low", m <= cuts[0]), ("mid", (m > cuts[0]) & (m <= cuts[1])), ("high", m > cuts[1])):
            print(f"    {name:4s} misfit {100 * m[sel].min():.3f}–{100 * m[sel].max():.3f} %: n {sel.sum():3d}, |err| median "
                  f"{100 * np.median(e[sel]):.2f} %, p90 {100 * np.percentile(e[sel], 90):.2f} %, "
                  f"90 % c {100 * bands.conformal_quantile(c[sel]):.2f} %")
    for title, rs in (("outside the family", outside), ("in the family", [r for r in cal + val if r["tier"] == "infamily"])):
        for n in (1, 2, 3):
            sel = [r for r in rs if r["n_measured"] == n]
            if not sel:
                continue
            e = np.array([r["err"] / r["f"] for r in sel])
            sg = np.array([math.hypot(r["set"], r["geom"]) / r["f"] for r in sel])
            print(f"  {title}, {n} mode(s) measured: n {len(sel):3d}, |err| median {100 * np.median(e):.3f} %, "
                  f"p90 {100 * np.percentile(e, 90):.2f} %; set + geometry median {100 * np.median(sg):.2f} %")
    cells = calibrate(cal, by_tier=by_tier, cell=fit_class)
    print("\nMondrian cells evidence group × fit class (" + ("each tier alone, the largest kept" if by_tier else "pooled")
          + "): " + ", ".join(f"{k} {100 * v:.3f} % (n {sum(key_of(r, False, fit_class) == k for r in cal)})"
                              for k, v in cells.items()))
    for tier in sorted({r["tier"] for r in cal}):
        rs = [r for r in cal if r["tier"] == tier]
        print(f"  {tier}: " + ", ".join(f"{k} {100 * v:.3f} % (n {sum(key_of(r, False, fit_class) == k for r in rs)})"
                                        for k, v in calibrate(rs, cell=fit_class).items()))
    for title, rs in by_set(val).items():
        print("  " + line(f"{title}: set + geometry only", stats(rs, ZERO)))
        print("  " + line(f"{title}: shipped c", stats(rs, bands.MODEL_FORM)))
        print("  " + line(f"{title}: c per group × fit class", stats(rs, cells, cell=fit_class)))


def decompose(rows_) -> None:
    """Where the half-width comes from (issue 22): per tier and evidence group, the errors
    beside the set part, the geometry part and each of its tolerances (medians, relative);
    then, for holders the model describes, what covers their errors: the set part with the
    stick-out parts alone (their geometry is exact: the diameter and flute-ratio parts and
    the model-form term cover errors they do not have)."""
    print("\nthe band's parts against the errors (medians; |err| also p90):")
    names = ("stickout", "stickout_identified", "diameter", "flute_ratio")
    for tier in sorted({r["tier"] for r in rows_}):
        for g in bands.GROUPS:
            rs = [r for r in rows_ if r["tier"] == tier and r["group"] == g]
            if not rs:
                continue
            rel = lambda key: np.array([r[key] / r["f"] for r in rs])  # noqa: E731
            e, s, geo = rel("err"), rel("set"), rel("geom")
            part = {k: np.median([r["parts"].get(k, 0.0) / r["f"] for r in rs]) for k in names}
            print(f"  {tier:12s} {g:8s} n {len(rs):4d}: |err| {100 * np.median(e):.3f} % (p90 "
                  f"{100 * np.percentile(e, 90):.2f}); set {100 * np.median(s):.2f}, geometry "
                  f"{100 * np.median(geo):.2f} (" + ", ".join(f"{k} {100 * v:.2f}" for k, v in part.items())
                  + f"); set + geometry {100 * np.median(np.hypot(s, geo)):.2f} %, covers "
                  f"{np.mean(e <= np.hypot(s, geo)):.0%}")
    inside = [r for r in rows_ if r["tier"] == "infamily"]
    if inside:
        e = np.array([r["err"] / r["f"] for r in inside])
        for title, keep in (("set + stick-out parts", ("stickout", "stickout_identified")),
                            ("set + stick-out + diameter parts", ("stickout", "stickout_identified", "diameter"))):
            h = np.array([math.sqrt(r["set"] ** 2 + sum(r["parts"].get(k, 0.0) ** 2 for k in keep)) / r["f"]
                          for r in inside])
            three = np.array([r["n_measured"] == 3 for r in inside])
            print(f"  in the family, {title} alone: covers {np.mean(e <= h):.1%} at median ±{100 * np.median(h):.2f} % "
                  f"(three modes heard: {np.mean((e <= h)[three]):.1%} at ±{100 * np.median(h[three]):.2f} %)")


def refit_check(records: list[dict], n: int = 6) -> None:
    """Is the geometry part of a wrong diameter or flute ratio overstated? (issue 22.)

    The band counts such an error only through the change of each mode's relative
    sensitivity from the tapped to the predicted stick-out (the fit absorbs the rest). The
    check: the error is absorbed instead by the smallest shift (in the optimiser's unit
    coordinates) of the five parameters that set the frequencies (k_tt, k_rr, alpha and
    the two factors) that meets the measured modes at the tapped stick-out (linearised,
    central differences), and that shift predicts the queries. Prints, per tolerance, the
    medians of the raw sensitivity at the query, the band's per-mode difference and this
    refit's transfer error, relative, for the first ``n`` records' measured modes.
    """
    from benchmarks.realism.corpus import case_of
    from taptune.model import ModelOptions
    from taptune.model.fe import mesh_frequency_hz
    from taptune.model.params import P_LOWER, P_UPPER, HolderParams, from_p, to_p

    frequency_params = (0, 1, 4, 5, 6)
    step = 0.01  # unit coordinates

    def solve(asm, p, f_max):
        return bands._solved_hz(asm, from_p(p), ModelOptions(), 3, f_max)

    def jacobian(asm, p, f_max):
        f0 = solve(asm, p, f_max)
        cols = []
        for k in frequency_params:
            dp = np.zeros(p.size)
            dp[k] = step * (P_UPPER[k] - P_LOWER[k])
            cols.append((solve(asm, p + dp, f_max) - solve(asm, p - dp, f_max)) / (2 * step * f0))
        return f0, np.array(cols).T

    def sensitivity(asm, move, tol, p, f_max, f0):
        return (solve(move(asm, tol), p, f_max) - solve(move(asm, -tol), p, f_max)) / (2 * f0)

    moves = (("flute_ratio", bands._with_flute_ratio, 0.05), ("diameter", bands._with_diameters, 0.01))
    out = {name: [] for name, _, _ in moves}
    for rec in [r for r in records if "failed" not in r][:n]:
        case = case_of(rec)
        p0 = to_p(HolderParams(**rec["identification"]["param_sets"][0]))
        measured = np.array([m is not None for m in rec["identification"]["bending_measured_hz"]])
        tapped = case.described
        f_max = mesh_frequency_hz(tapped, ModelOptions())
        f0, jac = jacobian(tapped, p0, f_max)
        for name, move, tol in moves:
            s_tap = sensitivity(tapped, move, tol, p0, f_max, f0)
            shift = np.linalg.lstsq(jac[measured], s_tap[measured], rcond=None)[0]  # smallest shift that absorbs it
            for q in case.queries:
                asm = tapped.with_stickout(q.stickout_mm * 1e-3)
                fq_max = mesh_frequency_hz(asm, ModelOptions())
                fq, jq = jacobian(asm, p0, fq_max)
                s_q = sensitivity(asm, move, tol, p0, fq_max, fq)
                for m in np.flatnonzero(measured):
                    out[name].append((abs(s_q[m]), abs(s_q[m] - s_tap[m]), abs(jq[m] @ shift - s_q[m])))
    print(f"\na wrong geometry absorbed by a refit ({n} holders, measured modes; medians of |Δf/f|):")
    for name, tol_rows in out.items():
        a = 100 * np.median(np.array(tol_rows), axis=0)
        print(f"  {name}: raw sensitivity at the query {a[0]:.3f} %, the band's per-mode difference {a[1]:.3f} %, "
              f"linearised refit {a[2]:.3f} %")


def offset_rows(records: list[dict], offsets_mm) -> list[dict]:
    """Like :func:`rows`, at other stick-out changes than the stored queries: every stored
    identification predicts its described stick-out + each offset [mm], and the truth
    there is solved with a fresh stick-out reading (uniform within the case's own reading
    error, as the corpus draws its queries; seeded by the case). Nothing is re-identified."""
    from benchmarks.realism.corpus import case_of, make_query
    from taptune.errors import InputError
    from taptune.model.params import HolderParams

    out = []
    for rec in records:
        if "failed" in rec:
            continue
        case = case_of(rec)
        ident = rec["identification"]
        sets = [HolderParams(**p) for p in ident["param_sets"]]
        measured = [m is not None for m in ident["bending_measured_hz"]]
        rng = np.random.default_rng(case.seed + 77)
        so, err = case.described.stickout / 1e-3, case.stickout_error_mm
        for off in offsets_mm:
            try:
                q = make_query(case.true_assembly, case.holder, so + off, so + off + float(rng.uniform(-err, err)))
                p = predict(sets, case.described.with_stickout((so + off) * 1e-3),
                            relative_floor=ident["relative_floor"], identified=[case.described], model_form=ZERO,
                            measured_modes=measured)
            except InputError:
                continue  # the tool cannot stand out that far (or that little) in this holder
            b = p.band
            for m, (f, t) in enumerate(zip(p.bending_hz, q.truth.bending_hz)):
                out.append({"case": rec["name"], "tier": tier_of(rec), "split": rec["split"], "mode": m + 1, "f": f,
                            "err": abs(f - t), "set": b.set_hz[m], "geom": b.geometry_hz[m],
                            "delta": b.delta_stickout_mm, "group": b.model_form_groups[m], "measured": measured[m],
                            "n_measured": int(sum(measured))})
    return out


def by_delta(rows_, paths, offsets_mm) -> None:
    """Coverage and median half-width of the shipped c per tier and stick-out change: the
    stored queries' ``rows_`` beside predictions at ``offsets_mm`` from the identifications
    of ``paths`` (:func:`offset_rows`)."""
    extra = offset_rows(load(paths), offsets_mm)
    print(f"\nthe shipped c by stick-out change (stored queries + offsets {offsets_mm} mm):")
    allrows = rows_ + extra
    for tier in sorted({r["tier"] for r in allrows}):
        for d in sorted({round(r["delta"]) for r in allrows if r["tier"] == tier}):
            rs = [r for r in allrows if r["tier"] == tier and round(r["delta"]) == d]
            if len(rs) >= 30:
                print("  " + line(f"{tier} Δ {d} mm", stats(rs, bands.MODEL_FORM)))


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


def agreement_rows(paths) -> list[dict]:
    """The ``rows`` of two-tap results whose records keep the joint fit (``identification``),
    each marked ``agreed`` (:func:`taptune.identify.bands.taps_agree`: at least
    ``AGREED_HEARD`` frequencies heard over both taps, all met within ``AGREED_MISFIT``);
    in-family rows get their own tier."""
    out = []
    for rec in load(paths):
        ident = rec.get("identification")
        if "failed" in rec or ident is None:
            continue
        heard = sum(f is not None for tap in ident["bending_measured_hz"] for f in tap)
        agreed = bands.taps_agree(ident["bending_measured_hz"], ident["relative_floor"])
        for r in rec["rows"]:
            out.append({**r, "tier": "infamily" if r["split"] == "infamily" else r["tier"],
                        "agreed": agreed, "heard": heard})
    return out


def joint_agreement(cal_paths, val_paths) -> None:
    """Does the two taps' agreement predict the error? Per tier, how many holders agree and
    their errors; Mondrian cells group × agreement calibrated each tier alone (the largest
    kept) and measured on the validation rows beside MODEL_FORM_JOINT."""
    cal, val = agreement_rows(cal_paths), agreement_rows(val_paths)
    print(f"\ntwo taps' agreement ({bands.AGREED_HEARD}+ of 6 frequencies heard, all met within "
          f"{100 * bands.AGREED_MISFIT:g} %):")
    for title, rs in (("calibration", cal), ("validation", val)):
        for tier in sorted({r["tier"] for r in rs}):
            sel = [r for r in rs if r["tier"] == tier]
            ag = [r for r in sel if r["agreed"]]
            e = [100 * r["err"] / r["f"] for r in ag]
            print(f"  {title} {tier}: {len(ag) // 3} of {len(sel) // 3} holders agree"
                  + (f", |err| median {np.median(e):.3f} %, max {np.max(e):.2f} %" if e else ""))
    cell = lambda r: "agreed" if r["agreed"] else "not"  # noqa: E731
    c = calibrate(cal, by_tier=True, cell=cell)
    print("  c per group × agreement: " + ", ".join(f"{k} {100 * v:.3f} %" for k, v in c.items()))
    shipped = {f"{g}/agreed": bands.MODEL_FORM_AGREED[g] for g in bands.GROUPS}
    shipped.update({f"{g}/not": bands.MODEL_FORM_JOINT[g] for g in bands.GROUPS})
    for tier in sorted({r["tier"] for r in val}):
        rs = [r for r in val if r["tier"] == tier]
        print("  " + line(f"{tier} (validation), joint c", stats(rs, bands.MODEL_FORM_JOINT)))
        print("  " + line(f"{tier} (validation), agreement cells", stats(rs, c, cell=cell)))
        print("  " + line(f"{tier} (validation), shipped (MODEL_FORM_AGREED)", stats(rs, shipped, cell=cell)))
        ag = [r for r in rs if r["agreed"]]
        if ag:
            print("    " + line("    of which agreed, shipped", stats(ag, shipped, cell=cell)))


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


def gauge(cal_paths, val_paths, cache) -> None:
    """Would holders whose stick-outs were read with a gauge, and stated so
    (``benchmarks.realism.run --stickout-error 0.05``), need other model-form c? The
    Mondrian c calibrated on such records alone (Δref as shipped, each tier alone and the
    larger kept), and the validation records measured with the shipped c and with these."""
    cal = cached_rows(cal_paths, cache)
    val = cached_rows(val_paths, cache) if val_paths else []
    c = calibrate(cal, delta_ref=bands.DELTA_REF_MM, by_tier=True)
    print(f"stick-outs read with a gauge, {len(cal)} predictions: c "
          + ", ".join(f"{g} {100 * c.get(g, 0.0):.3f} % (n {sum(r['group'] == g for r in cal)})" for g in bands.GROUPS)
          + "; shipped " + ", ".join(f"{g} {100 * v:.3f} %" for g, v in bands.MODEL_FORM.items()))
    for title, rs in by_set(cal + val).items():
        print("  " + line(f"{title}, set + geometry only", stats(rs, ZERO)))
        print("  " + line(f"{title}, shipped c", stats(rs, bands.MODEL_FORM)))
        print("  " + line(f"{title}, gauge-calibrated c", stats(rs, c)))


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
    ap.add_argument("--evidence", action="store_true", help="also print whether what the fit shows (misfit, "
                                                             "measured modes) predicts the error, and cells by it")
    ap.add_argument("--joint", action="store_true", help="calibrate MODEL_FORM_JOINT on two-tap results "
                                                          "(benchmarks/realism/two_taps.py) instead")
    ap.add_argument("--gauge", action="store_true", help="records whose stick-outs were read with a gauge (run "
                                                          "--stickout-error 0.05): compare c calibrated on them with the shipped c")
    ap.add_argument("--decompose", action="store_true", help="also print the band's parts (set, each geometry "
                                                              "tolerance) against the errors, per tier and group")
    ap.add_argument("--offsets", type=float, nargs="+", metavar="MM",
                    help="also predict these stick-out changes from the stored identifications of --records and "
                         "--validate, and print the shipped c's coverage per stick-out change")
    ap.add_argument("--refit", type=int, metavar="N", help="also check the diameter and flute-ratio parts against a "
                                                           "linearised refit on the first N records")
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
        if args.evidence:
            joint_agreement(args.records, args.validate)
        return 0
    if args.gauge:
        gauge(args.records, args.validate, args.cache)
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
    if args.evidence:
        evidence(cal, val, args.by_tier)
    if args.decompose:
        decompose(cal + val)
    if args.refit:
        refit_check(load(args.records), args.refit)
    if args.offsets:
        by_delta(cal + val, args.records + args.validate, args.offsets)
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
