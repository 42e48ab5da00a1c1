"""The app's *Listen to cut* in the Machine view: the verdict, the next speed from the lobes, ✓/✗ on the lobes, the history."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("pytestqt")

from benchmarks.cut.sounds import lines_cut  # noqa: E402
from taptune.io.audio import write_audio  # noqa: E402
from tests.gui.conftest import *  # noqa: E402,F401,F403  (window, library_path, settings …)
from tests.gui.test_machine_view import MACHINE, _show_on_machine, holder_a  # noqa: E402,F401


@pytest.mark.slow
def test_listen_to_a_chatter_in_the_machine_view(qtbot, window, holder_a, reference_assembly, library_path, tmp_path):  # noqa: F811
    from taptune.library import HolderLibrary

    _show_on_machine(qtbot, window, reference_assembly)
    view = window.machine
    panel = view.cut_panel
    rec, _ = lines_cut(10000, view.teeth.value(), seed=3, chatter_hz=4390.0, chatter_db=12.0)
    wav = tmp_path / "cut.wav"
    write_audio(wav, rec.samples, rec.sample_rate)
    panel.rpm.setValue(10000)
    panel.depth.setValue(3.0)
    assert panel.listen_file(str(wav))
    assert panel.analysis.verdict == "chatter" and abs(panel.analysis.chatter_hz / 4390 - 1) < 0.01
    assert panel.advice.basis == "lobes" and panel.advice.suggested_rpm
    assert "CHATTER" in panel.result.text() and "Try" in panel.result.text()
    # Kept in the library holder's history and drawn on the lobes.
    (obs,) = HolderLibrary(library_path).get(holder_a.name).observations
    assert obs.verdict == "chatter" and obs.depth_mm == 3.0
    ax_l = view.canvas.figure.axes[1]
    assert any(line.get_marker() == "$\u2717$" for line in ax_l.lines)
    shot = os.environ.get("TAPTUNE_CUT_SCREENSHOT")
    if shot:
        window.grab().save(shot)


def test_record_cut_from_a_fake_input(qtbot, tmp_path):
    from taptune.gui.cut_panel import CutPanel
    from taptune.io.recording import FakeInputStream

    class View:  # the few things the panel asks of the Machine view
        source = None
        result = None

        @staticmethod
        def cut():
            from taptune.gui.machine_view import Cut

            return Cut(3, 16.0, 8.0, "down", 800.0, 200.0, 2000.0, 24000.0)

    rec, _ = lines_cut(8000, 3, seed=4, chatter_hz=1234.0, chatter_db=15.0)
    panel = CutPanel(View(), stream_factory=FakeInputStream(rec.samples.astype(np.float32), end="idle").factory)
    qtbot.addWidget(panel)
    panel.rpm.setValue(8000)
    import taptune.gui.cut_panel as module

    module.RECORD_S, old = 1.0, module.RECORD_S
    try:
        panel.record()
        qtbot.waitUntil(lambda: panel.analysis is not None, timeout=5000)
    finally:
        module.RECORD_S = old
    assert panel.analysis.verdict == "chatter" and panel.advice.basis == "rule"
    assert len(panel.session) == 1  # no library holder: kept for this session only
