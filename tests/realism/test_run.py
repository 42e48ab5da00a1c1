"""The realism harness: offline re-evaluation of bands and the summary it prints."""

import json
from types import SimpleNamespace

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
