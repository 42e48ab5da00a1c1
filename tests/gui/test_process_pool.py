"""The app's warm process pool: both cores identify, the window stays responsive, same result."""

import time

import numpy as np
import pytest
from PySide6.QtCore import QTimer

from taptune.gui import messages

pytestmark = pytest.mark.slow


@pytest.fixture(scope="module")
def app_pool():
    from taptune.gui.app import start_process_pool, stop_process_pool

    pool = start_process_pool()
    yield pool
    stop_process_pool()


def test_pool_identification_ticks_and_matches_one_process(qtbot, library_path, generated_recording, app_pool,
                                                           fast_identify_options):
    from dataclasses import replace

    from taptune.gui.main_window import MainWindow, run_identification

    options = replace(fast_identify_options, islands=2, jobs=app_pool.processes)
    win = MainWindow(library_path, identify_options=options, devices=lambda: [])
    qtbot.addWidget(win)
    win.show()
    wav, _, _ = generated_recording
    with qtbot.waitSignal(win.analysis_ready, timeout=60000):
        win.load_recording(str(wav))
    ticks = []
    timer = QTimer()
    timer.timeout.connect(lambda: ticks.append(time.perf_counter()))
    timer.start(10)
    t0 = time.perf_counter()
    with qtbot.waitSignal(win.identification_ended, timeout=120000) as blocker:
        win.start_identification()
    seconds = time.perf_counter() - t0
    timer.stop()
    assert blocker.args == ["finished"], messages.history
    # The event loop ran all along (10 % of the ideal tick count: the machine may be loaded).
    assert len(ticks) >= max(3, 0.1 * seconds / 0.010), f"{len(ticks)} ticks in {seconds:.2f} s"
    assert np.diff([t0] + ticks).max() < max(1.0, 0.5 * seconds)
    alone = run_identification([win.analysis], [win.assembly_panel.assembly], replace(options, jobs=1), None)
    pooled, single = win.identification.to_dict(), alone.to_dict()
    pooled.pop("seconds"), single.pop("seconds")
    assert pooled == single
    win.close()
