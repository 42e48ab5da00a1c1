"""Two stick-outs: a second recording of the same holder and tool, identified jointly; the advice to tap again.

Offscreen Qt; the recordings are generated from the model (tests/gui/conftest.py).
"""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from taptune.gui import messages


def _load(qtbot, window, wav, second=False):
    with qtbot.waitSignal(window.analysis_ready, timeout=30000):
        (window.load_second_recording if second else window.load_recording)(str(wav))


def test_second_recording_is_identified_jointly_and_saved(qtbot, window, generated_recording, second_recording,
                                                          library_path):
    wav1, _toml1, hz1 = generated_recording
    wav2, _toml2, hz2 = second_recording
    _load(qtbot, window, wav1)
    assert not window.second_pane.isVisible()
    _load(qtbot, window, wav2, second=True)
    # The stick-out of the 2nd recording came from the assembly file beside it; the
    # first assembly is unchanged.
    assert window.assembly_panel.second_stickout.value() == pytest.approx(63.5)
    assert window.assembly_panel.assembly.stickout == pytest.approx(0.0535)
    assert window.second_pane.isVisible() and window.spectrum2.analysis is window.second.analysis
    np.testing.assert_allclose(window.second.analysis.bending_hz, hz2, rtol=1e-3)
    assert window.file_label.text() == f"{wav1.name} + {wav2.name}"
    assert window.identify_button.text() == "Identify both together"

    with qtbot.waitSignal(window.identification_ended, timeout=120000) as blocker:
        window.start_identification()
    assert blocker.args == ["finished"], messages.history
    result = window.identification
    assert len(result.bending_measured_hz) == 2
    np.testing.assert_allclose(result.bending_measured_hz[1], hz2, rtol=1e-3)
    # The fit view shows both recordings: two plots, three table rows each.
    assert len(window.fit.canvas.figure.axes) == 2
    assert window.fit.freq_table.rowCount() == 6
    assert window.fit.freq_table.item(3, 0).text() == "f1 · 2"
    assert window.fit.freq_table.item(3, 1).text() == f"{result.bending_measured_hz[1][0]:,.1f}"
    assert "Joint fit of" in window.fit.summary.text()
    assert not window.banner.isVisible()  # two stick-outs: no second-tap advice
    # Both stick-outs go to the library's provenance.
    name = window.save_to_library()
    stickouts = sorted(r.stickout_mm for r in window.library_view.entries[name].identifications)
    assert stickouts == pytest.approx([53.5, 63.5])

    # Removing the 2nd recording returns to a one-recording identification.
    window.remove_second_recording()
    assert window.second is None and not window.second_pane.isVisible()
    assert window.identify_button.text() == "Identify holder"
    assert window.file_label.text() == wav1.name


def test_second_recording_needs_a_valid_second_stickout(qtbot, window, generated_recording, tmp_path):
    import shutil

    _load(qtbot, window, generated_recording[0])
    lone = tmp_path / "lone.wav"  # no assembly file beside it
    shutil.copy(generated_recording[0], lone)
    window.load_second_recording(str(lone))
    assert messages.history[-1][0] == "Set the 2nd stick-out"
    assert window.second is None
    window.assembly_panel.set_second_stickout_mm(53.5)  # the same as the first
    assert window.assembly_panel.second_assembly()[0] is None
    window.assembly_panel.set_second_stickout_mm(63.5)
    assert window.assembly_panel.second_assembly()[0].stickout == pytest.approx(0.0635)
    _load(qtbot, window, lone, second=True)
    assert window.second.assembly.stickout == pytest.approx(0.0635)
    # A 2nd stick-out beyond the tool's length makes the joint fit wait, with the reason.
    window.assembly_panel.set_second_stickout_mm(400.0)
    assert not window.identify_button.isEnabled()
    assert "400" in window.identify_button.toolTip()


def test_advice_asks_for_a_second_tap_only_when_the_bands_are_wide(reference_assembly):
    import dataclasses

    from taptune.gui.advice import second_tap_advice
    from taptune.io.assembly import Tolerances
    from taptune.model.params import HolderParams

    from tests.gui.conftest import HOLDER_A

    best = HolderParams(**HOLDER_A)
    # Geometry known exactly and one parameter set: nothing shows the tap pinned the modes, so
    # the band 20 mm away is the model-form part of the free group (about 2 % for mode 1),
    # which a tap at that stick-out shrinks: the advice comes.
    exact = dataclasses.replace(reference_assembly, tolerances=Tolerances(0.0, 0.0, 0.0))
    tight = SimpleNamespace(param_sets=(best,), relative_floor=5e-4)
    line, details = second_tap_advice(tight, exact)
    assert "at 73.5 mm" in line and "At 73.5 mm" in details
    # With a second recording at that stick-out (a joint fit) there is nothing to advise.
    from taptune.identify.bands import second_tap_advice as advice_in_words
    from taptune.identify.pipeline import transfer_outlook

    joint = transfer_outlook(tight, [exact, exact.with_stickout(exact.stickout + 0.020)])
    assert joint.band.recordings == 2 and advice_in_words([joint]) is None
    # A near-optimal set with a 3x stiffer rotational contact parts ways at 73.5 mm.
    loose = SimpleNamespace(param_sets=(best, HolderParams(**{**HOLDER_A, "k_rr": 3 * HOLDER_A["k_rr"],
                                                            "k_tt": HOLDER_A["k_tt"] / 3})),
                            relative_floor=5e-4)
    line, details = second_tap_advice(loose, exact)
    assert line.startswith("One tap leaves other stick-outs loose (±") and "tap again at about 73.5 mm" in line
    assert "At 73.5 mm" in details and "2nd stick-out" in details and "what one tap cannot tell apart" in details


def test_banner_offers_the_second_tap(qtbot, window, monkeypatch):
    from PySide6.QtWidgets import QFileDialog

    asked = []
    monkeypatch.setattr(QFileDialog, "getOpenFileName", lambda *a, **k: (asked.append(a[1]), ("", ""))[1])
    window.banner.show_text("tap again")
    assert window.banner.isVisible()
    window.banner.button.click()
    assert asked == ["Open the recording at the 2nd stick-out"]
