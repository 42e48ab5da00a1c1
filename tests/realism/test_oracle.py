"""The realism oracle: exact fits of the true frequencies and the statistics it reports."""

import numpy as np
import pytest

from benchmarks.realism.corpus import make_case
from benchmarks.realism.oracle import VARIANTS, fit_frequencies, summarise


def test_in_family_truth_is_fitted_to_its_frequencies():
    # The in-family control's truth IS the product model with the described geometry:
    # some parameter set reproduces its three bending frequencies (RMS log-misfit < 0.001 %).
    case = make_case("infamily", 0)
    fits = fit_frequencies([case.described], [case.truth.bending_hz], starts=2, seed=0)
    assert fits[0]["misfit"] < 1e-5
    assert all(0.0 <= u <= 1.0 for u in fits[0]["u"])


def _record(errors):
    preds = []
    for k, e in enumerate(errors):
        p = {"mode": 1 + k % 3, "ruler_pct": 0.1, "measured": k % 3 != 2,
             "pipeline": {"error_pct": 2 * e, "half_width_pct": 1.0, "covered": abs(2 * e) <= 1.0}}
        for v in VARIANTS:
            p[v] = {"error_pct": e, "valley_pct": [e - 1, e + 1], "chosen_pct": e / 2}
        preds.append(p)
    fit = {k: 0.0 for k in ("misfit_pct", "pick_misfit_pct", "exact_misfit_pct", "floor_misfit_pct",
                            "floor_exact_misfit_pct")}
    return {"predictions": preds, "fit": fit}


def test_summary_gives_median_p90_and_max_of_the_absolute_error():
    errors = [-0.1, 0.2, -0.3, 0.4, -0.5, 0.6, -0.7, 0.8, -0.9, 1.0]
    s = summarise([_record(errors)])
    st = s["all"]["ruler"]
    assert st["n"] == 10
    assert st["median_pct"] == pytest.approx(0.55)
    assert st["p90_pct"] == pytest.approx(np.percentile(np.abs(errors), 90))
    assert st["max_pct"] == pytest.approx(1.0)
    assert st["share_le_0.4"] == pytest.approx(0.4)
    assert s["all"]["ruler_chosen"]["max_pct"] == pytest.approx(0.5)
    assert s["all"]["ruler_valley_worst"]["max_pct"] == pytest.approx(2.0)
    assert s["all"]["pipeline"]["coverage"] == pytest.approx(0.5)  # |2e| <= 1
    # Modes 1 and 2 are the measured ones here.
    assert s["measured_modes"]["ruler"]["n"] == 7
