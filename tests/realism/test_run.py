"""The realism harness: offline re-evaluation of bands and the summary it prints."""

import json
from types import SimpleNamespace

import numpy as np
import pytest

from benchmarks.realism.corpus import make_case
from benchmarks.realism.run import reevaluate, summarise
from tests.conftest import REPO

BASELINE = REPO / "benchmarks" / "realism" / "baseline_validation.json"


@pytest.fixture(scope="module")
def records():
    return json.loads(BASELINE.read_text())["cases"][:2]


def test_baseline_records_hold_what_band_methods_need(records):
    for rec in records:
        assert len(rec["identification"]["param_sets"]) >= 1
        assert {"truth_hz", "predicted_hz", "spread_hz", "error_pct", "covered", "measured"} <= set(rec["predictions"][0])
        assert len(rec["labels"]) == 3 and "margin_db" in rec["labels"][0]


def test_reevaluate_scores_a_band_method_against_the_truth(records):
    # A "band method" that returns the truth with a ±1 Hz band: no error, everything covered.
    def oracle(sets, asm, rec):
        case = make_case(rec["split"], rec["index"])
        q = next(q for q in case.queries if abs(q.stickout_mm * 1e-3 - asm.stickout) < 1e-9)
        return SimpleNamespace(bending_hz=q.truth.bending_hz, bending_hz_spread=(1.0, 1.0, 1.0))

    new = reevaluate(records, oracle)
    s = summarise(new)["transfer"]
    assert s["error_max_pct"] == pytest.approx(0.0, abs=1e-6)
    assert s["coverage"] == 1.0
    # The stored records are not touched.
    assert any(p["error_pct"] != 0 for r in records for p in r["predictions"])


def test_summary_counts_labels_of_audible_modes_only(records):
    s = summarise(records)["labels"]
    audible = sum(lab["audible"] for r in records for lab in r["labels"])
    assert s["audible_modes"] == audible
    assert s["right"] + s["audible_wrong_peak"] + s["audible_missed"] == audible


def test_write_results_trims_to_the_size_limit(records, tmp_path, capsys):
    from benchmarks.realism.run import print_table, write_results

    data = {"meta": {}, "summary": {}, "cases": json.loads(json.dumps(records))}
    full = write_results(str(tmp_path / "full.json"), json.loads(json.dumps(data)))
    small = write_results(str(tmp_path / "small.json"), data, limit=full - 1)
    assert small < full
    back = json.loads((tmp_path / "small.json").read_text())["cases"]
    assert "truth_holder" not in back[0] and "recording" not in back[0]
    a, b = records[0]["identification"]["param_sets"][0], back[0]["identification"]["param_sets"][0]
    assert all(b[k] == pytest.approx(a[k], rel=1e-8) for k in a)
    print_table(records)
    assert records[0]["name"] in capsys.readouterr().out


def test_calibration_is_the_conformal_quantile_per_group():
    from benchmarks.calibrate_bands import calibrate, stats

    rng = np.random.default_rng(5)
    rows = []
    for group, scale in (("pinned", 0.002), ("free", 0.01)):
        for err in rng.exponential(scale, 99):
            rows.append({"group": group, "mode": 1, "f": 1000.0, "err": 1000.0 * err, "set": 0.0, "geom": 0.0,
                         "delta": 0.0, "measured": True})
    c = calibrate(rows)
    for group in ("pinned", "free"):
        need = sorted(r["err"] / 1000.0 for r in rows if r["group"] == group)
        assert c[group] == pytest.approx(need[89])  # ⌈0.9 × 100⌉ = 90th smallest of 99
    s = stats(rows, c)
    assert 0.9 <= s["coverage"] <= 0.92 and set(s["groups"]) == {"pinned", "free"}
