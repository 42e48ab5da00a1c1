"""PDF report: per-recording views of a joint fit, prediction rows, tables, pages on disk.

The identification here is built by hand from the model at the nominal holder (two
parameter sets, so the spread is known), and the spectra come from synthetic taps:
the report is tested without running the optimiser.
"""

from __future__ import annotations

import re

import numpy as np
import pytest

from tests.test_batch import assembly_text, write_case

from taptune.errors import InputError
from taptune.identify import Identification, predict
from taptune.model import NOMINAL, analyse
from taptune.report.pdf import (
    PredictionRow,
    parameter_cells,
    predict_rows,
    prediction_cells,
    recording_view,
    report_pages,
    report_stickouts_mm,
    write_identification_report,
)

PERTURBED = NOMINAL.__class__(**{**NOMINAL.to_dict(), "k_tt": NOMINAL.k_tt * 1.1})


def _asm(holder="ER32 report", stickout_mm=53.5):
    import tomllib

    from taptune.io.assembly import parse_assembly

    return parse_assembly(tomllib.loads(assembly_text(holder, stickout_mm)), "report.toml")


def hand_made_identification(assemblies) -> Identification:
    """An Identification at the nominal holder for these assemblies (shapes: a Lorentzian and a shifted copy)."""
    model = [tuple(analyse(a, NOMINAL).bending_hz[:3]) for a in assemblies]
    windows = tuple(np.arange(f[0] - 100, f[0] + 100, 1.0) for f in model)
    shapes = tuple(1 / (1 + ((w - w.mean()) / 10) ** 2) for w in windows)
    return Identification(
        params=NOMINAL, param_sets=(NOMINAL, PERTURBED),
        bending_measured_hz=tuple(tuple(f * 1.001 for f in m) for m in model),
        bending_model_hz=tuple(model), damping_model=tuple((0.01, 0.008, 0.006) for _ in model),
        objective=0.75, objective_terms=tuple((0.1 * (k + 1), 0.2 * (k + 1)) for k in range(len(model))),
        evaluations=1234, seconds=5.0, seed=7, warnings=("one warning",),
        window_hz=windows, measured_shape=shapes, model_shape=tuple(np.roll(s, 3) for s in shapes),
    )


@pytest.fixture(scope="module")
def joint_case(tmp_path_factory):
    """Two synthetic recordings of one holder at 48.5 and 58.5 mm, analysed, with a hand-made joint identification."""
    from taptune.identify.pipeline import analyse_for_assembly
    from taptune.io.audio import read_audio

    folder = tmp_path_factory.mktemp("report")
    assemblies = [_asm(stickout_mm=48.5), _asm(stickout_mm=58.5)]
    recordings = [read_audio(write_case(folder, f"s{k}", "ER32 report", a.stickout * 1e3, seed=k))
                  for k, a in enumerate(assemblies)]
    analyses = [analyse_for_assembly(r, a) for r, a in zip(recordings, assemblies)]
    return hand_made_identification(assemblies), analyses, recordings, assemblies


def test_recording_view_takes_one_recording_of_a_joint_fit(joint_case):
    result = joint_case[0]
    view = recording_view(result, 1)
    assert view.bending_model_hz == (result.bending_model_hz[1],)
    assert view.objective_terms == (result.objective_terms[1],)
    assert view.objective == pytest.approx(0.2 + 0.4)  # this recording's share
    assert view.param_sets == result.param_sets
    assert np.array_equal(view.window_hz[0], result.window_hz[1])
    assert view.to_dict()["bending_model_hz"] == [round(f, 2) for f in result.bending_model_hz[1]]


def test_predictions_cover_the_recorded_stickout_and_plus_minus_10_and_20_mm():
    assert report_stickouts_mm(53.5) == [33.5, 43.5, 53.5, 63.5, 73.5]
    rows = predict_rows((NOMINAL, PERTURBED), _asm(stickout_mm=53.5))
    assert [r.stickout_mm for r in rows] == [33.5, 43.5, 53.5, 63.5, 73.5]
    # Longer stick-out, lower first bending frequency (cantilevered tool gets softer).
    f1 = [r.bending_hz[0] for r in rows]
    assert all(a > b for a, b in zip(f1, f1[1:]))
    # The middle row is the recorded assembly itself.
    assert rows[2].bending_hz == pytest.approx(predict((NOMINAL, PERTURBED), _asm()).bending_hz, rel=1e-9)
    assert all(s > 0 for r in rows for s in r.bending_hz_spread)  # two distinct parameter sets


def test_an_impossible_stickout_is_a_note_not_an_error():
    rows = predict_rows((NOMINAL,), _asm(stickout_mm=80.0))  # tool is 93.5 mm long
    assert [r.note for r in rows] == ["", "", "", "", "geometry not possible"]
    cells = prediction_cells(rows, 80.0)
    assert cells[2][0] == "80.0 *" and cells[4][1] == "geometry not possible"


def test_table_cells_show_value_and_spread():
    view = hand_made_identification([_asm()])
    cells = {row[0]: row for row in parameter_cells(view)}
    assert cells["k_tt"][1] == f"{NOMINAL.k_tt:.4g}"
    assert cells["k_tt"][2] == f"± {NOMINAL.k_tt * 0.05:.2g}"  # half the 10 % range
    assert cells["η_tt"][2] == "± 0"
    row = prediction_cells([PredictionRow(53.5, (1000.4, 3000.0, 5000.0), (1.2, 3.6, 10.0), 0.0123)], 53.5)[0]
    assert row == ["53.5 *", "1000 ± 1", "3000 ± 4", "5000 ± 10", "1.230"]


def test_identification_report_has_one_page_per_recording(joint_case, tmp_path):
    result, analyses, recordings, assemblies = joint_case
    pdf = tmp_path / "sub" / "report.pdf"
    write_identification_report(pdf, result, analyses, recordings, assemblies)
    data = pdf.read_bytes()
    assert data.startswith(b"%PDF")
    assert len(re.findall(rb"/Type\s*/Page\b(?!s)", data)) == 2
    assert not list(tmp_path.glob("sub/.*.tmp"))


def test_report_pages_carry_the_provenance(joint_case):
    from taptune.library.schema import sha256_file

    result, analyses, recordings, assemblies = joint_case
    pages = report_pages(result, analyses, recordings, assemblies)
    assert [p.file for p in pages] == [r.path for r in recordings]
    assert pages[0].sha256 == sha256_file(recordings[0].path)
    assert pages[1].joint_files == tuple(r.path for r in recordings)
    assert pages[1].result.seed == 7 and pages[0].stickout_mm == pytest.approx(48.5)


def test_an_unwritable_report_is_bad_input(joint_case, tmp_path):
    blocker = tmp_path / "file"
    blocker.write_text("")
    with pytest.raises(InputError, match="cannot write the report"):
        write_identification_report(blocker / "r.pdf", *joint_case)


def test_an_alpha_that_rounds_to_zero_prints_without_a_sign():
    # A slope of -0.001 % is no slope: the page prints "0.00", never "-0.00".
    from dataclasses import replace

    view = hand_made_identification([_asm()])
    for alpha, shown in ((-0.001, "0.00"), (0.0, "0.00"), (-0.006, "-0.01"), (2.5, "+2.50")):
        cells = {row[0]: row for row in parameter_cells(replace(view, params=replace(NOMINAL, alpha=alpha)))}
        assert cells["α"][1] == shown

