"""The Machine view's canvas: redrawing only the data (or one y axis) gives the picture a full draw gives."""

from __future__ import annotations

import numpy as np
import pytest


def test_round_and_steady_tops():
    from taptune.gui.blit import round_top, steady_top

    assert [round_top(v) for v in (0.9, 1.0, 1.01, 2.6, 13.0, 0.0042)] == pytest.approx([1.0, 1.0, 1.2, 3.0, 15.0,
                                                                                          0.005])
    assert steady_top(2.6, None) == 3.0  # a new picture: the tightest round top
    assert steady_top(2.0, 3.0) == 3.0  # fits: the axis stays
    assert steady_top(1.4, 3.0) == 1.5  # less than half of it: shrinks to the tightest round top
    assert steady_top(3.2, 3.0) == 4.0  # grows with room: 3.2 × 1.25 = 4.0
    assert steady_top(float("nan"), 3.0) == 3.0


def _canvas(qtbot):
    from taptune.gui.blit import BlitCanvas, add_grid

    canvas = BlitCanvas()
    qtbot.addWidget(canvas)
    canvas.resize(700, 300)
    canvas.show()
    qtbot.waitExposed(canvas)
    fig = canvas.figure
    fig.subplots_adjust(left=0.08, right=0.99, bottom=0.15, top=0.88, wspace=0.25)
    with canvas.styled():
        ax_f, ax_l = fig.subplots(1, 2)
        for ax in (ax_f, ax_l):
            add_grid(ax)
        line, = ax_f.plot([], [], lw=1.0, label="x")
        ax_f.legend(loc="upper right", framealpha=1.0)
        fill = ax_l.fill_between([], [], [], color="#d5ecd4", lw=0, zorder=0)
        edge, = ax_l.plot([], [], lw=1.0, label="limit")
        ax_l.legend(loc="upper left", framealpha=1.0)
        ax_l.set_xlabel("spindle speed [rpm]")
        ax_l.set_ylabel("depth [mm]")
    return canvas, ax_f, ax_l, line, fill, edge


def _show(canvas, ax_f, ax_l, line, fill, edge, k: float):
    f = np.linspace(0.05, 15, 800)
    g = 1 / np.abs(1 - (f / (3 + 0.1 * k)) ** 2 + 0.04j)
    line.set_data(f, g)
    rpm = np.linspace(2000, 24000, 500)
    a = 2 + k + 3 * np.abs(np.sin(rpm / 1500))
    fill.set_data(rpm, 0, a)
    edge.set_data(rpm, a)
    ax_f.set_xlim(0, 15)
    ax_l.set_xlim(2000, 24000)
    ax_f.set_title(f"FRF {k}", loc="left")


def _pixels(canvas) -> np.ndarray:
    return np.asarray(canvas.buffer_rgba()).astype(int)


def _full(canvas) -> np.ndarray:
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    FigureCanvasAgg.draw(canvas)
    return _pixels(canvas)


def test_data_and_y_axis_updates_draw_what_a_full_draw_draws(qtbot):
    canvas, ax_f, ax_l, line, fill, edge = _canvas(qtbot)
    parts = (canvas, ax_f, ax_l, line, fill, edge)
    _show(*parts, k=0.0)
    ax_f.set_ylim(0, 30)
    ax_l.set_ylim(0, 8)
    canvas.render_now()
    assert canvas.renders == {"full": 1, "y axis": 0, "data": 0}
    # The title (data: it changes with each move) stays in its place above the axes.
    title = ax_f._left_title.get_window_extent(canvas.get_renderer())
    assert ax_f.bbox.y1 < title.y0 < title.y1 < canvas.figure.bbox.y1

    _show(*parts, k=0.5)  # new data, same axes
    canvas.render_now()
    assert canvas.renders["data"] == 1
    fast = _pixels(canvas)
    assert np.abs(fast - _full(canvas)).max(axis=2).astype(bool).mean() < 1e-3  # the same picture

    _show(*parts, k=1.0)
    ax_l.set_ylim(0, 12)  # new ticks on the lobes' y axis only
    canvas.render_now()
    assert canvas.renders == {"full": 1, "y axis": 1, "data": 1}
    fast = _pixels(canvas)
    assert np.abs(fast - _full(canvas)).max(axis=2).astype(bool).mean() < 1e-3
    # The grid follows the new ticks: a horizontal line at each of 0, 2, …, 12 mm.
    grid = [c for c in ax_l.collections if c.get_gid() == "grid"][0]
    assert sum(1 for s in grid.get_segments() if s[0][1] == s[1][1]) == 7

    size = canvas.get_width_height()
    canvas.resize(size[0] - 100, size[1] - 40)  # another size: everything again
    qtbot.waitUntil(lambda: canvas.get_width_height() != size)
    canvas.render_now()
    assert canvas.get_width_height() != size
    assert canvas.renders["full"] == 2


def test_the_slider_redraws_only_the_data_while_the_axes_hold(qtbot, settings):
    """Stick-outs 1 mm apart on the example machine: most moves keep both axes' ticks."""
    from pathlib import Path

    from PySide6.QtCore import QSettings

    from taptune.gui.machine_view import MachineView, compute_machine
    from taptune.gui.predictor import PredictorSource
    from taptune.io.assembly import load_assembly
    from taptune.model.params import HolderParams

    from tests.gui.conftest import HOLDER_A

    root = Path(__file__).resolve().parents[2]
    view = MachineView(QSettings(str(Path(settings.fileName()).with_name("blit.ini")), QSettings.IniFormat))
    qtbot.addWidget(view)
    view.resize(950, 560)
    view.show()
    assert view.load_machine(str(root / "recordings" / "machine" / "machine.toml"), remember=False)
    source = PredictorSource("holder A", (HolderParams(**HOLDER_A),), load_assembly(root / "recordings" / "er32_d16.toml"))
    view.set_source(source)
    view.shutdown()
    cut = view.cut()
    for stickout_mm in (52.0, 53.0, 54.0, 55.0):
        view.draw(*compute_machine(source, view.machine, stickout_mm, cut))
        view.canvas.render_now()
    assert view.canvas.renders["full"] == 1 and view.canvas.renders["data"] >= 2
    assert "55.0 mm" in view.canvas.figure.axes[0].get_title(loc="left")
