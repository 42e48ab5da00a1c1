"""The machine drawings: draw_* into given Axes, the PNG wrappers, the report page row that uses them."""

from __future__ import annotations

import numpy as np
import pytest

from taptune.report.machine_page import PAGE_TEXT, MachineView, draw_machine
from taptune.report.machine_plot import (UM_PER_N, draw_lobes, draw_toolpoint, plot_lobes, plot_toolpoint)

plt = pytest.importorskip("matplotlib.pyplot")


def frf(f, fn=1000.0, k=1e7, zeta=0.02):
    """Viscous single mode [m/N]."""
    r = f / fn
    return 1 / (k * (1 - r**2 + 2j * zeta * r))


@pytest.fixture
def figure():
    fig = plt.figure()
    yield fig
    plt.close(fig)


def lobe_case():
    rpm = np.linspace(3000.0, 12000.0, 300)
    a = 0.5 + 0.4 * np.cos(rpm / 700.0) ** 2
    a[-20:] = np.nan  # no lobe reaches
    i = np.flatnonzero((a[1:-1] > a[:-2]) & (a[1:-1] >= a[2:])) + 1
    pockets = [{"rpm": float(rpm[j]), "a_lim_mm": float(a[j])} for j in i[np.argsort(-a[i])]]
    return rpm, a, pockets


def test_draw_toolpoint_one_curve_or_three_panels(figure):
    f = np.linspace(200.0, 3000.0, 400)
    gx, gy = frf(f), frf(f, 1100.0)
    ax = figure.add_subplot(1, 1, 1)
    draw_toolpoint(ax, [("", f, gx, gy)], modes_hz=[1000.0, 1100.0])
    lines = [ln for ln in ax.get_lines() if ln.get_label() in ("G_xx", "G_yy")]
    assert np.allclose(lines[0].get_ydata(), np.abs(gx) * UM_PER_N) and lines[1].get_linestyle() == "--"
    assert ax.get_yscale() == "log" and [t.get_text() for t in ax.texts] == ["1000 Hz", "1100 Hz"]

    fig, axes = plt.subplots(3, 1)
    try:
        draw_toolpoint(axes, [("40 mm", f, gx, gy), ("50 mm", f, 2 * gx, 2 * gy)])
        assert [t.get_text() for t in axes[0].get_legend().get_texts()] == ["40 mm, x", "40 mm, y", "50 mm, x", "50 mm, y"]
        assert np.allclose(axes[1].get_lines()[2].get_ydata(), 2 * gx.real * UM_PER_N)
        assert np.allclose(axes[2].get_lines()[0].get_ydata(), gx.imag * UM_PER_N)
        # one colour per stick-out, x solid and y dashed
        colours = [ln.get_color() for ln in axes[0].get_lines()]
        assert colours[0] == colours[1] != colours[2] == colours[3]
    finally:
        plt.close(fig)


def test_draw_lobes_marks_eight_pockets_and_labels_three(figure):
    rpm, a, pockets = lobe_case()
    ax = figure.add_subplot(1, 1, 1)
    draw_lobes(ax, rpm, a, 0.5, pockets)
    markers = [ln for ln in ax.get_lines() if ln.get_marker() == "v"]
    assert len(markers) == min(8, len(pockets)) and len(ax.texts) == 3
    assert ax.texts[0].get_text() == f"{pockets[0]['rpm']:.0f} rpm\n{pockets[0]['a_lim_mm']:.2g} mm"
    assert ax.get_ylim() == pytest.approx((0.0, 1.25 * np.nanmax(a)))
    assert ax.get_xlim() == pytest.approx((rpm[0], rpm[-1]))
    assert "critical depth 0.5 mm" in [t.get_text() for t in ax.get_legend().get_texts()]


def test_png_wrappers_write_pictures(tmp_path):
    f = np.linspace(200.0, 3000.0, 400)
    plot_toolpoint([("40 mm", f, frf(f), frf(f, 1100.0))], tmp_path / "tp.png", "holder on machine")
    rpm, a, pockets = lobe_case()
    plot_lobes(rpm, a, 0.5, pockets, tmp_path / "lobes.png", chatter_hz=np.full(len(rpm), 1050.0))
    for name in ("tp.png", "lobes.png"):
        assert (tmp_path / name).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_page_row_uses_the_drawings_at_page_text_size(figure):
    f = np.linspace(200.0, 3000.0, 400)
    rpm, a, pockets = lobe_case()
    view = MachineView(title="On the test machine", freq_hz=f, xx=frf(f), yy=frf(f, 1100.0),
                       modes=((1000.0, "x"), (1010.0, "y"), (1100.0, "y")), rpm=rpm, a_lim_mm=a, a_crit_mm=0.5,
                       pockets=tuple(pockets), cut="4 teeth, ae 5 mm, down")
    draw_machine(figure, view)
    frf_ax, lobe_ax = figure.axes
    assert [t.get_text() for t in frf_ax.texts] == ["1000 Hz", "1100 Hz"]  # the x/y pair marked once
    assert lobe_ax.get_title(loc="left") == view.cut and len(lobe_ax.texts) == 3
    assert lobe_ax.xaxis.label.get_fontsize() == PAGE_TEXT["font.size"]

    failed = plt.figure()
    try:
        draw_machine(failed, MachineView(title="On the test machine", error="the tool is behind the coupling plane"))
        assert "behind the coupling plane" in failed.axes[0].texts[0].get_text()
    finally:
        plt.close(failed)
