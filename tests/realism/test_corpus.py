"""The realism corpus: deterministic, disjoint splits, deviations no larger than issue 9 allows."""

import numpy as np
import pytest

from benchmarks.realism.audio import audible_modes, record
from benchmarks.realism.corpus import (KINDS, case_of, check_pairs, elsewhere, make_case, without, worn)
from taptune.model.params import HolderParams

MM = 1e-3


@pytest.fixture(scope="module")
def cases():
    return [make_case("validation", i) for i in range(4)]


def test_a_case_is_the_same_every_time(cases):
    again = make_case("validation", 1)
    assert again.to_dict() == cases[1].to_dict()


def test_splits_draw_different_holders(cases):
    other = make_case("calibration", 1)
    assert other.holder.params != cases[1].holder.params
    assert other.name != cases[1].name


def test_deviations_stay_within_the_issue_limits(cases):
    for c in cases:
        assert set(c.kinds) <= set(KINDS)
        tool = c.described.tool
        assert tool.flute_ratio == 0.8  # what a user's file says
        assert abs(c.true_assembly.stickout - c.described.stickout) <= 0.4 * MM + 1e-12
        for q in c.queries:
            assert abs(q.true_stickout_mm - q.stickout_mm) <= 0.4 + 1e-9
        assert all(abs(f - 1) <= 0.015 for f in c.true_od_factors)
        assert 0.72 <= c.true_flute_ratio <= 0.86
        assert 0 <= c.holder.asymmetry <= 0.015
        p = c.holder.params
        # Published ranges of docs/physics.md §2 (five real holders).
        assert 1.8e9 <= p.k_tt <= 4.7e9 and 2.95e3 <= p.k_rr <= 4.83e4
        assert -23 <= p.alpha <= 11
        assert 7428 / 7800 <= p.density_factor <= 8045 / 7800
        assert 200 / 210 <= p.modulus_factor <= 213 / 210
        # A real stick-out: the tool is gripped and the flutes are outside.
        assert c.described.inserted_length > 0.3 * c.described.holder.clamp_length
        assert len(c.queries) == 2


def test_in_family_control_has_no_deviation():
    c = make_case("infamily", 0)
    assert c.kinds == ()
    assert c.true_assembly.stickout == pytest.approx(c.described.stickout)
    assert c.holder.profile.kind == "linear" and c.holder.asymmetry == 0 and c.holder.extra_mass.mass == 0
    assert [s.od for s in c.true_assembly.holder.segments] == [s.od for s in c.described.holder.segments]
    assert c.true_assembly.tool.segments == c.described.tool.segments


def test_worn_and_elsewhere_keep_the_holder(cases):
    ref = cases[0]
    w = worn(ref, 0.5)
    assert w.holder.params.k_tt == pytest.approx(0.5 * ref.holder.params.k_tt)
    assert w.described.holder == ref.described.holder
    assert w.truth.bending_hz[0] < ref.truth.bending_hz[0]
    moved = elsewhere(ref, ref.queries[0].stickout_mm)
    assert moved.holder == ref.holder
    assert moved.described.stickout == pytest.approx(ref.queries[0].stickout_mm * MM)
    assert moved.truth.bending_hz[0] == pytest.approx(ref.queries[0].truth.bending_hz[0], rel=0.02)


def test_without_removes_one_deviation(cases):
    c = next(c for c in cases if "diameters" in c.kinds)
    plain = without(c, "diameters")
    assert "diameters" not in plain.kinds
    assert [s.od for s in plain.true_assembly.holder.segments] == [s.od for s in c.described.holder.segments]
    assert plain.holder == c.holder


def test_recording_is_deterministic_and_its_first_mode_audible(cases):
    from taptune.signal.analysis import analyse_recording

    c = cases[3]
    a, b = record(c), record(c)
    np.testing.assert_array_equal(a.samples, b.samples)
    assert a.sample_rate == c.recording.nuisances.sample_rate
    # Quantised to the file's bit depth.
    full = 2 ** (c.recording.bits - 1) - 1
    assert np.allclose(a.samples * full, np.round(a.samples * full))
    analysis = analyse_recording(a)
    heard = audible_modes(c, analysis)
    assert heard[0]


def test_check_pairs_expect_consistent_then_differs():
    pairs = check_pairs(1)
    assert [p[2] for p in pairs] == ["consistent", "differs", "differs"]
    ref = pairs[0][0]
    assert all(p[0] is ref for p in pairs)
    assert isinstance(ref.holder.params, HolderParams)


@pytest.fixture(scope="module")
def issue_cases():
    return [make_case("calibration", i, tier="issue") for i in range(4)]


def test_issue_tier_is_what_issue_9_describes(issue_cases):
    for c in issue_cases:
        assert c.tier == "issue" and c.name.startswith("ical") and c.seed == 1_500_000 + int(c.name[4:7])
        assert {"stickout", "profile", "diameters", "flute"} <= set(c.kinds)
        assert c.holder.profile.kind in ("soft_front", "crowned")
        assert 0.77 <= c.true_flute_ratio <= 0.83
        assert all(abs(f - 1) <= 0.015 for f in c.true_od_factors)
        assert abs(c.true_assembly.stickout - c.described.stickout) <= 0.4 * MM + 1e-12
        d = c.described.tool.flute_diameter
        for so in [c.described.stickout] + [q.stickout_mm * MM for q in c.queries]:
            assert 3 * d - 1e-9 <= so <= 6 * d + 1e-9
            assert so >= c.described.tool.flute_length  # the flutes are clear of the holder
        if "mass" in c.kinds:
            assert c.family.startswith("er32")
    # Disjoint from the harsh tier of the same split and index.
    harsh = make_case("calibration", 1)
    assert harsh.tier == "harsh" and harsh.holder.params != issue_cases[1].holder.params


def test_case_of_rebuilds_the_case_of_a_record(issue_cases):
    rec = {"split": "calibration", "index": 2, "tier": "issue", "ablate": None}
    assert case_of(rec).to_dict() == issue_cases[2].to_dict()
    old = {"split": "validation", "index": 0}  # records from before the tiers are harsh
    assert case_of(old).name.startswith("val000")
    with pytest.raises(ValueError, match="unknown tier"):
        make_case("calibration", 0, tier="mild")


def test_harsh_tier_is_still_the_corpus_of_the_stored_baselines():
    # The stored identifications (benchmarks/realism/baseline_*.json) predate the tiers:
    # their cases must come out of make_case unchanged.
    import json

    from tests.conftest import REPO

    stored = json.loads((REPO / "benchmarks" / "realism" / "baseline_calibration.json").read_text())["cases"][:2]
    for rec in stored:
        case = case_of(rec)
        assert case.tier == "harsh" and case.name == rec["name"] and list(case.kinds) == rec["kinds"]
        # (the stored JSON rounds the frequencies to 0.01 Hz)
        assert case.truth.bending_hz == pytest.approx(rec["truth"]["bending_hz"], abs=0.006)
        for q, stored_q in zip(case.queries, rec["queries"], strict=True):
            assert q.stickout_mm == stored_q["stickout_mm"]
            assert q.true_stickout_mm == pytest.approx(stored_q["true_stickout_mm"], abs=1e-4)
            assert q.truth.bending_hz == pytest.approx(stored_q["bending_hz"], abs=0.006)


def test_a_gauge_draws_the_same_case_with_smaller_reading_errors(issue_cases):
    ruler = issue_cases[1]
    gauge = make_case("calibration", 1, tier="issue", stickout_error_mm=0.05)
    # The same random numbers: every reading error scaled by 0.05 / 0.4, nothing else moved.
    assert gauge.name == ruler.name and gauge.kinds == ruler.kinds and gauge.holder == ruler.holder
    described = ruler.described.stickout / MM
    assert gauge.true_assembly.stickout / MM - described == pytest.approx(
        (ruler.true_assembly.stickout / MM - described) * 0.05 / 0.4, abs=1e-9)
    for q_r, q_g in zip(ruler.queries, gauge.queries, strict=True):
        assert q_g.true_stickout_mm - q_g.stickout_mm == pytest.approx((q_r.true_stickout_mm - q_r.stickout_mm) / 8)
    # The user measured with a gauge and said so; the ruler's file keeps the default.
    assert gauge.described.tolerances.stickout == pytest.approx(0.05 * MM)
    assert ruler.described.tolerances.stickout == pytest.approx(0.3 * MM)
    record_ = {"split": "calibration", "index": 1, "tier": "issue", "stickout_error_mm": 0.05}
    assert case_of(record_).to_dict() == gauge.to_dict()
