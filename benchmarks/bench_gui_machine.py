"""Machine view: time of one stick-out slider move — tool-point FRF + lobes + redraw.

The Machine view (offscreen Qt) with the example machine (recordings/machine), holder A
of the reference assembly (assets/er32_hsk63_d16.toml) and its tool, the default cut (4 teeth, Ø16, ae 4 mm down,
al7075, 2,000–24,000 rpm). The view first shows its first picture as in the app (the
preview computed in its worker); then each move to a stick-out from 45 to 65 mm is timed
in its parts on the GUI thread, as the worker and the view run them one after the other:
``compute_machine`` (toolpoint_frf and stability_lobes), then ``draw`` and the event
loop's one render of the canvas: what a screen update costs. The first move after the
first picture is also shown on its own (warm-up), and how the renders went: data only
over the kept axes, one y axis drawn again, or everything (BlitCanvas).

    OPENBLAS_NUM_THREADS=1 QT_QPA_PLATFORM=offscreen python benchmarks/bench_gui_machine.py [--moves 21] [--live 0.3]

CPU seconds (``time.process_time``) do not move much with other load on the machine;
wall seconds do (the load average is printed).
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("QT_QPA_PLATFORM", "offscreen")
REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--moves", type=int, default=21, help="slider moves, spread over 45–65 mm")
    parser.add_argument("--live", type=float, default=0.0, metavar="SECONDS",
                        help="instead: move the slider every SECONDS through the view's own workers (the "
                             "semi-discretization and band run in the background as in the app) and time "
                             "each move until its preview is drawn")
    args = parser.parse_args()

    import numpy as np
    from PySide6.QtCore import QSettings
    from PySide6.QtWidgets import QApplication

    from taptune.gui.machine_view import MachineView, compute_machine
    from taptune.gui.predictor import PredictorSource
    from taptune.io.assembly import load_assembly
    from taptune.model.params import HolderParams

    app = QApplication.instance() or QApplication([])
    settings = QSettings(str(Path(os.environ.get("TMPDIR", "/tmp")) / "bench_gui_machine.ini"), QSettings.IniFormat)
    view = MachineView(settings)
    view.resize(950, 560)
    view.show()
    view.load_machine(str(REPO / "recordings" / "machine" / "machine.toml"), remember=False)
    assembly = load_assembly(REPO / "recordings" / "er32_d16.toml")
    holder_a = HolderParams(1.90e9, 9.37e3, 1.98e-3, 8.20e-3, -10.0, 7478 / 7800, 1.0)
    source = PredictorSource("holder A (the published ER32 holder)", (holder_a,), assembly)
    t0 = time.perf_counter()
    if hasattr(view, "warming"):  # the imports the view starts when made (the app makes it at start)
        view.warming.join(60)
    warm = time.perf_counter() - t0
    t0 = time.perf_counter()
    with _waiting(app, view.updated):
        view.set_source(source)  # the first picture, computed in the worker as in the app
    app.processEvents()
    first_picture = time.perf_counter() - t0
    if args.live:
        return _live(app, view, args)
    view.shutdown()  # the timed moves run here, one after the other, not in the workers
    cut = view.cut()

    rows = []
    load = os.getloadavg()[0]
    renders = dict(getattr(view.canvas, "renders", {}))  # (a plain canvas, before BlitCanvas, has none)
    for stickout_mm in np.linspace(45.0, 65.0, args.moves):
        c0, w0 = time.process_time(), time.perf_counter()
        result = compute_machine(source, view.machine, float(stickout_mm), cut)
        c1, w1 = time.process_time(), time.perf_counter()
        view.draw(*result)  # new data, then draw_idle: the render runs in the event loop, once
        app.processEvents()
        c2, w2 = time.process_time(), time.perf_counter()
        rows.append((c1 - c0, c2 - c1, c2 - c0, w2 - w0))
    rows = np.array(rows)
    kinds = ", ".join(f"{view.canvas.renders[k] - renders[k]} {k}" for k in renders) or "every one in full"
    print(f"{args.moves} slider moves, 45–65 mm; FRF {len(result[1].freq_hz)} frequencies, "
          f"lobes {len(result[2].rpm)} speeds; load average {load:.1f} on {os.cpu_count()} cores")
    print(f"warm-up at view creation {warm:.2f} s, then the first picture (worker) {first_picture:.2f} s wall; "
          f"renders: {kinds}")
    print(f"{'per move':>22} {'median':>8} {'max':>8} {'first':>8}")
    for name, col in (("FRF + lobes CPU s", 0), ("redraw CPU s", 1), ("total CPU s", 2), ("total wall s", 3)):
        print(f"{name:>22} {np.median(rows[:, col]):8.3f} {rows[:, col].max():8.3f} {rows[0, col]:8.3f}")
    view.close()


def _live(app, view, args) -> None:
    """Slider moves every ``args.live`` s through the workers: wall time from each move to its drawn preview."""
    import numpy as np

    end = time.perf_counter() + 120
    while view.refining and time.perf_counter() < end:  # the first picture's refinement
        app.processEvents()
        time.sleep(0.005)
    end = time.perf_counter() + 1.0  # then a look at it before the drag
    while time.perf_counter() < end:
        app.processEvents()
        time.sleep(0.005)
    load = os.getloadavg()[0]
    waits, missed, refines = [], 0, []
    view.refined.connect(lambda _r: refines.append(1))
    for stickout_mm in np.linspace(45.0, 65.0, args.moves):
        t0 = time.perf_counter()
        with _waiting(app, view.updated, timeout=10) as w:
            view.set_stickout_mm(float(stickout_mm))
        app.processEvents()  # the render
        if w.seen and abs(w.seen[-1][0] - stickout_mm) < 1e-9:
            waits.append(time.perf_counter() - t0)
        else:
            missed += 1
        while time.perf_counter() < t0 + args.live:
            app.processEvents()
            time.sleep(0.002)
    view.shutdown()
    waits = np.array(waits)
    print(f"{args.moves} slider moves every {args.live:g} s through the view's workers; load average {load:.1f} "
          f"on {os.cpu_count()} cores; {len(refines)} refinements drawn meanwhile; {missed} moves not timed")
    print(f"move → preview drawn, wall s: median {np.median(waits):.3f}, max {waits.max():.3f}")
    if os.environ.get("BENCH_ROWS"):
        print(np.round(waits, 3))
    view.close()


class _waiting:
    """``with _waiting(app, signal):`` runs the block, then the event loop until ``signal`` (at most ``timeout`` s)."""

    def __init__(self, app, signal, timeout: float = 60.0):
        self.app, self.signal, self.seen, self.timeout = app, signal, [], timeout

    def __enter__(self):
        self.signal.connect(self.seen.append)
        return self

    def __exit__(self, *exc):
        end = time.perf_counter() + self.timeout
        while not self.seen and time.perf_counter() < end:
            self.app.processEvents()
            time.sleep(0.002)
        self.signal.disconnect(self.seen.append)
        return False


if __name__ == "__main__":
    main()
