"""Numbers as a machinist reads them: no negative zero, no ± wider than its value, an empty form that says what it needs."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from taptune.gui.numbers import NOT_DETERMINED, date_text, determined, number


@pytest.mark.parametrize("value, spec, text", [
    (-0.0004, "+.2f", "0.00"), (-0.0, "+.2f", "0.00"), (0.0001, "+.2f", "0.00"), (-0.013, "+.2f", "-0.01"),
    (0.02, "+.2f", "+0.02"), (-0.0002, ".3f", "0.000"), (-1e-20, "{:.3g}", "-1e-20"), (1.81e9, "{:.3g}", "1.81e+09"),
])
def test_a_number_that_prints_as_zero_has_no_sign(value, spec, text):
    assert number(value, spec) == text


def test_a_spread_wider_than_its_value_is_not_a_determination():
    assert determined(1.81e9, 6.9e8) and determined(-10.0, 9.0)
    assert not determined(0.00013, 0.0069) and not determined(10.6, 25.0) and not determined(float("nan"), 1.0)


def _identification(params, spread, measured, model):
    f = np.linspace(4600.0, 4800.0, 50)
    shape = np.exp(-((f - 4700.0) / 30.0) ** 2)
    return SimpleNamespace(bending_measured_hz=[measured], bending_model_hz=[model], damping_model=[(0.004,) * 3],
                           window_hz=[f], measured_shape=[shape], model_shape=[shape], params=SimpleNamespace(**params),
                           param_spread=spread, objective=0.1, evaluations=100, seconds=1.0, param_sets=(None,) * 5,
                           warnings=())


def test_fit_view_says_in_words_what_the_tap_did_not_determine(qtbot):
    from taptune.gui.fit_view import PARAM_ROWS, FitView

    params = dict(k_tt=1.81e9, k_rr=8.02e3, eta_tt=0.00013, eta_rr=0.0097, alpha=10.6, density_factor=0.994,
                  modulus_factor=1.03)
    spread = dict(k_tt=6.9e8, k_rr=1.9e3, eta_tt=0.0069, eta_rr=0.0052, alpha=25.0, density_factor=0.03,
                  modulus_factor=0.023)
    view = FitView()
    qtbot.addWidget(view)
    # f2 model 14934.7 against 14934.8 measured: -0.0007 %, printed without a sign.
    view.show_identification(_identification(params, spread, (4686.2, 14934.8, 19894.3), (4687.3, 14934.7, 19894.5)))
    assert [view.freq_table.item(r, 3).text() for r in range(3)] == ["+0.02 %", "0.00 %", "0.00 %"]
    rows = {key: r for r, (key, *_rest) in enumerate(PARAM_ROWS)}
    loss = rows["eta_tt"]
    assert view.param_table.item(loss, 1).text() == NOT_DETERMINED
    assert view.param_table.columnSpan(loss, 1) == 2
    assert "0.00013" in view.param_table.item(loss, 1).toolTip() and "0.0069" in view.param_table.item(loss, 1).toolTip()
    assert view.param_table.item(rows["alpha"], 1).text() == NOT_DETERMINED
    assert "Not determined by this tap (their fits spread more than their value): translational loss, " \
           "intensity slope." in view.summary.text()
    stiffness = rows["k_tt"]
    assert (view.param_table.item(stiffness, 1).text(), view.param_table.item(stiffness, 2).text()) == ("1.81e+09",
                                                                                                       "6.9e+08")
    # A later fit that determines everything shows plain numbers again (no span left over).
    view.show_identification(_identification(params, {k: 0.0 for k in spread}, (4686.2, 14934.8, 19894.3),
                                             (4687.3, 14934.7, 19894.5)))
    assert view.param_table.columnSpan(loss, 1) == 1 and view.param_table.item(loss, 1).text() == "0.00013"


def test_an_empty_assembly_form_starts_empty_and_says_what_is_missing(qtbot):
    from taptune.gui.assembly_panel import NOT_SET, AssemblyPanel

    panel = AssemblyPanel()
    qtbot.addWidget(panel)
    assert panel.assembly is None
    # Not "1.0 mm" and "0.1 mm": nothing is set until the user sets it.
    assert panel.stickout.text() == NOT_SET and panel.clamp.text() == NOT_SET
    assert panel.message.text().startswith("Still missing: a holder, a tool, the stick-out.")


def test_one_date_form_for_every_view():
    assert date_text("2026-11-27T08:21:49Z") == "2026-11-27 08:21"
