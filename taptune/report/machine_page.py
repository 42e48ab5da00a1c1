"""The machine row of a report page: the tool-point FRF and the stability lobes side by side.

A batch with ``--machine`` attaches a :class:`MachineView` to each
:class:`~taptune.report.pdf.ReportPage` (built in the worker, picklable: arrays and
numbers only); :func:`draw_machine` draws it into a (sub)figure of the page with the
drawing functions of :mod:`taptune.report.machine_plot` (those of ``taptune toolpoint
--plot`` and ``taptune lobes --plot``), page-sized.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from taptune.report.machine_plot import draw_lobes, draw_toolpoint

#: Text of the page-sized drawings: labels 9 pt, legends 7.5 pt, annotations 6.25 pt.
PAGE_TEXT = {"font.size": 9.0}
MARKED_MODES = 4  # the strongest tool-point peaks, each marked once


@dataclass(frozen=True)
class MachineView:
    """What the machine row shows; ``error`` alone when the machine part failed.

    ``xx``, ``yy`` complex [m/N] on ``freq_hz`` [Hz]; ``modes`` (hz, direction) of the
    dominant peaks; ``a_lim_mm`` the stability limit [mm] on ``rpm`` (NaN where no lobe
    reaches); ``pockets`` ``{"rpm", "a_lim_mm"}`` best first; ``cut`` one line.
    """

    title: str
    error: str = ""
    freq_hz: np.ndarray = field(default_factory=lambda: np.zeros(0), repr=False)
    xx: np.ndarray = field(default_factory=lambda: np.zeros(0, complex), repr=False)
    yy: np.ndarray = field(default_factory=lambda: np.zeros(0, complex), repr=False)
    modes: tuple = ()
    rpm: np.ndarray = field(default_factory=lambda: np.zeros(0), repr=False)
    a_lim_mm: np.ndarray = field(default_factory=lambda: np.zeros(0), repr=False)
    a_crit_mm: float | None = None
    pockets: tuple = ()
    cut: str = ""


def draw_machine(fig, view: MachineView) -> None:
    """Fill ``fig`` (a subfigure of the page) with |G| of the tool point (left) and the lobes (right).

    The drawings are those of :mod:`taptune.report.machine_plot`, at page size: the text
    scaled down through ``font.size``.
    """
    import matplotlib

    fig.suptitle(view.title, fontsize=9, x=0.01, ha="left")
    if view.error:
        ax = fig.add_subplot(1, 1, 1)
        ax.axis("off")
        ax.text(0.0, 0.8, f"machine part not computed:\n{view.error}", va="top", ha="left", fontsize=9,
                color="#c0392b", wrap=True, transform=ax.transAxes)
        return
    with matplotlib.rc_context(PAGE_TEXT):
        frf_ax, lobe_ax = fig.subplots(1, 2, width_ratios=[1, 1.25])
        draw_toolpoint(frf_ax, [("", view.freq_hz, view.xx, view.yy)], marked_modes(view.modes))
        draw_lobes(lobe_ax, view.rpm, view.a_lim_mm, view.a_crit_mm, view.pockets)
        lobe_ax.set_title(view.cut, fontsize=7.5, loc="left")
        for ax in (frf_ax, lobe_ax):
            ax.tick_params(labelsize=7)


def marked_modes(modes, n: int = MARKED_MODES, apart: float = 0.03) -> list[float]:
    """The first ``n`` mode frequencies [Hz] of ``modes`` ((hz, direction), strongest first),
    an x/y pair within ``apart`` (relative) counted once, so labels do not overprint."""
    marked: list[float] = []
    for hz, _ in modes:
        if len(marked) < n and all(abs(hz - m) > apart * m for m in marked):
            marked.append(hz)
    return marked
