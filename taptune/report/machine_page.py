"""The machine row of a report page: the tool-point FRF and the stability lobes side by side.

A batch with ``--machine`` attaches a :class:`MachineView` to each
:class:`~taptune.report.pdf.ReportPage` (built in the worker, picklable: arrays and
numbers only); :func:`draw_machine` draws it into a (sub)figure of the page. The
full-size pictures of ``taptune toolpoint --plot`` and ``taptune lobes --plot`` are
:mod:`taptune.report.machine_plot`; these are their page-sized, vector versions.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from taptune.report.machine_plot import MARKED_POCKETS, UM_PER_N

LABELLED_POCKETS = 3
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
    """Fill ``fig`` (a subfigure of the page) with |G| of the tool point (left) and the lobes (right)."""
    fig.suptitle(view.title, fontsize=9, x=0.01, ha="left")
    if view.error:
        ax = fig.add_subplot(1, 1, 1)
        ax.axis("off")
        ax.text(0.0, 0.8, f"machine part not computed:\n{view.error}", va="top", ha="left", fontsize=9,
                color="#c0392b", wrap=True, transform=ax.transAxes)
        return
    frf_ax, lobe_ax = fig.subplots(1, 2, width_ratios=[1, 1.25])
    draw_toolpoint_magnitude(frf_ax, view)
    draw_lobe_diagram(lobe_ax, view)


def draw_toolpoint_magnitude(ax, view: MachineView) -> None:
    """|G_xx| solid, |G_yy| dashed [µm/N] against frequency, the dominant modes marked."""
    for g, style, colour, d in ((view.xx, "-", "#2c3e50", "x"), (view.yy, "--", "#e67e22", "y")):
        ax.semilogy(view.freq_hz, np.abs(g) * UM_PER_N, style, lw=1.0, color=colour, label=f"G_{d}{d}")
    for hz in marked_modes(view.modes):
        ax.axvline(hz, color="#c0392b", lw=0.6, alpha=0.6)
        ax.annotate(f"{hz:.0f} Hz", (hz, 1.0), xycoords=("data", "axes fraction"), rotation=90,
                    xytext=(2, -4), textcoords="offset points", fontsize=6.5, color="#c0392b", va="top")
    ax.set_xlabel("frequency [Hz]", fontsize=8)
    ax.set_ylabel("tool point |G| [µm/N]", fontsize=8)
    ax.tick_params(labelsize=7)
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=7, loc="lower left")


def marked_modes(modes, n: int = MARKED_MODES, apart: float = 0.03) -> list[float]:
    """The first ``n`` mode frequencies [Hz] of ``modes`` ((hz, direction), strongest first),
    an x/y pair within ``apart`` (relative) counted once, so labels do not overprint."""
    marked: list[float] = []
    for hz, _ in modes:
        if len(marked) < n and all(abs(hz - m) > apart * m for m in marked):
            marked.append(hz)
    return marked


def draw_lobe_diagram(ax, view: MachineView) -> None:
    """The stability limit over speed, the critical depth and the best pockets."""
    a = np.asarray(view.a_lim_mm, dtype=float)
    ax.fill_between(view.rpm, 0, np.where(np.isfinite(a), a, np.nan), color="#27ae60", alpha=0.15, lw=0)
    ax.plot(view.rpm, a, color="#1e8449", lw=1.1, label="stability limit")
    if view.a_crit_mm is not None:
        ax.axhline(view.a_crit_mm, color="#c0392b", ls="--", lw=0.9, label=f"critical depth {view.a_crit_mm:.3g} mm")
    for k, p in enumerate(view.pockets[:MARKED_POCKETS]):
        ax.plot(p["rpm"], p["a_lim_mm"], "v", color="#2c3e50", ms=5 if k < LABELLED_POCKETS else 3)
        if k < LABELLED_POCKETS:
            ax.annotate(f"{p['rpm']:.0f}\n{p['a_lim_mm']:.2g} mm", (p["rpm"], p["a_lim_mm"]),
                        textcoords="offset points", xytext=(0, 5), ha="center", fontsize=6.5)
    finite = a[np.isfinite(a)]
    top = max(float(finite.max()) if finite.size else 0.0, view.a_crit_mm or 0.0)
    ax.set_ylim(0, 1.25 * top if top > 0 else 1.0)
    if len(view.rpm):
        ax.set_xlim(float(view.rpm[0]), float(view.rpm[-1]))
    ax.set_xlabel("spindle speed [rpm]", fontsize=8)
    ax.set_ylabel("axial depth a_p [mm]", fontsize=8)
    ax.set_title(view.cut, fontsize=7.5, loc="left")
    ax.tick_params(labelsize=7)
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=7, loc="upper left")
