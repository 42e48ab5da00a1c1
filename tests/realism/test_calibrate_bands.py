"""calibrate_bands.py's normalised-score and Mondrian-cell variants (benchmarks, seeded rows)."""

import numpy as np
import pytest

from benchmarks.calibrate_bands import calibrate, power_scale, stats


def _rows(seed=3, n=400):
    """Rows whose model-form error grows with the frequency per mode number (x), as a
    normalised score should learn: |error| ∝ x, no set or geometry part, Δ = 0."""
    rng = np.random.default_rng(seed)
    out = []
    for _ in range(n):
        mode = int(rng.integers(1, 4))
        x = float(np.exp(rng.uniform(np.log(3e2), np.log(3e4))))  # log-uniform: the scale spans 100 ×
        f = x * mode
        out.append({"group": "pinned", "tier": "issue", "mode": mode, "f": f, "set": 0.0, "geom": 0.0, "delta": 0.0,
                    "measured": True, "err": f * 1e-6 * x * float(rng.exponential(1.0))})
    return out


def test_a_constant_scale_divides_the_coefficient_and_leaves_the_band():
    rows = _rows()
    plain = calibrate(rows)
    halved = calibrate(rows, sigma=lambda r: 2.0)
    assert halved["pinned"] == pytest.approx(plain["pinned"] / 2)
    assert stats(rows, halved, sigma=lambda r: 2.0)["half_median_pct"] == pytest.approx(
        stats(rows, plain)["half_median_pct"])


def test_a_scale_that_follows_the_error_narrows_the_band_at_the_same_coverage():
    cal, val = _rows(3), _rows(4)
    plain = stats(val, calibrate(cal))
    sigma = power_scale(cal, "f/n (frequency / mode number)", 1.0)
    scaled = stats(val, calibrate(cal, sigma=sigma), sigma=sigma)
    assert scaled["coverage"] >= 0.87 and plain["coverage"] >= 0.87
    assert scaled["half_median_pct"] < 0.8 * plain["half_median_pct"]


def test_mondrian_cells_get_their_own_coefficient():
    rows = _rows()
    c = calibrate(rows, cell=lambda r: r["mode"] == 1)
    assert set(c) == {"pinned/True", "pinned/False"}
    s = stats(rows, c, cell=lambda r: r["mode"] == 1)
    assert s["coverage"] >= 0.9


def test_fit_class_and_tiers_known_at_prediction_time():
    from benchmarks.calibrate_bands import fit_class, tier_of

    assert fit_class({"n_measured": 3, "misfit": 8e-4}) == "explained"
    assert fit_class({"n_measured": 3, "misfit": 2e-3}) == "partial"  # the model misses a peak
    assert fit_class({"n_measured": 2, "misfit": 0.0}) == "partial"  # five parameters meet two modes anyway
    assert tier_of({"split": "infamily", "tier": "harsh", "stickout_error_mm": 0.05}) == "infamily"
    assert tier_of({"split": "validation", "tier": "issue", "stickout_error_mm": 0.4}) == "issue"
    assert tier_of({"split": "validation", "tier": "harsh", "stickout_error_mm": 0.05}) == "harsh gauge"


def test_evidence_report_runs_on_rows(capsys):
    from benchmarks.calibrate_bands import evidence

    rng = np.random.default_rng(5)
    rows = []
    for split in ("calibration", "validation"):
        for r in _rows(6 if split == "calibration" else 7, 120):
            r.update(split=split, n_measured=int(rng.integers(1, 4)), misfit=float(rng.uniform(0, 2e-3)),
                     group=str(rng.choice(["pinned", "free", "unknown"])))
            rows.append(r)
    evidence([r for r in rows if r["split"] == "calibration"], [r for r in rows if r["split"] == "validation"])
    out = capsys.readouterr().out
    assert "Spearman(misfit, |err|)" in out and "group × fit class" in out and "issue validation" in out


def test_two_taps_agree_only_with_five_frequencies_met_within_the_precision(tmp_path):
    import json

    from benchmarks.calibrate_bands import agreement_rows

    def rec(name, measured, floor, split="validation"):
        rows = [{"case": name, "tier": "harsh", "split": split, "mode": n, "f": 1e4, "err": 1.0, "set": 0.0,
                 "geom": 0.0, "delta": 10.0, "group": "pinned", "measured": True} for n in (1, 2, 3)]
        return {"name": name, "rows": rows,
                "identification": {"bending_measured_hz": measured, "bending_model_hz": measured,
                                   "relative_floor": floor}}

    six, four = [[1.0, 2.0, 3.0], [1.1, 2.1, 3.1]], [[1.0, 2.0, None], [1.1, 2.1, None]]
    cases = [rec("a", six, 5e-4), rec("b", six, 3e-3), rec("c", four, 5e-4), rec("d", six, 5e-4, "infamily"),
             {"name": "e", "failed": "no tap"}]
    path = tmp_path / "two.json"
    path.write_text(json.dumps({"cases": cases}))
    rows = agreement_rows([path])
    agreed = {r["case"]: r["agreed"] for r in rows}
    assert agreed == {"a": True, "b": False, "c": False, "d": True}
    assert {r["tier"] for r in rows if r["case"] == "d"} == {"infamily"}
