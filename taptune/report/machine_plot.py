"""Pictures of the machine stage: tool-point FRFs, stability lobes, spindle receptances.

``draw_*`` draw into matplotlib Axes the caller made (the PNGs here, the batch report
page :mod:`taptune.report.machine_page`, the GUI) and return nothing; ``plot_*`` are
thin wrappers that make a figure and write a PNG through
:func:`taptune.report.figures.save_png`. Arrays in SI (m/N, Hz, rpm; depths in mm).
Text sizes are relative ("small"…) so a caller scales them all with ``font.size``.
matplotlib is imported inside the functions (Agg backend), so importing this module
costs nothing on the CLI's fast paths.
"""

from __future__ import annotations

import numpy as np

from taptune.report.fit_plot import _pyplot, _save

UM_PER_N = 1e6  # m/N → µm/N for the axes (a machinist reads µm/N)
MARKED_POCKETS = 8
LABELLED_POCKETS = 3
#: x and y of a single tool-point FRF; several FRFs take one colour each from the cycle.
XY_COLOURS = ("#2c3e50", "#e67e22")


def _wrap(title: str, width: int = 100) -> str:
    """Each line of ``title`` wrapped to fit an 8-inch figure at 9 pt."""
    import textwrap

    return "\n".join(textwrap.fill(line, width) for line in title.splitlines())


def draw_toolpoint(axes, curves, modes_hz=()) -> None:
    """Draw tool-point FRFs: |G| (log) into ``axes[0]``; Re G and Im G into ``axes[1]``, ``axes[2]`` if given.

    x solid, y dashed. One curve: x and y in two colours, legend G_xx, G_yy; several
    (stick-outs): one colour per curve, legend "label, x".

    Parameters
    ----------
    axes : Axes or sequence of Axes (1 or 3)
    curves : list of (label, freq_hz, g_xx, g_yy)
        ``g_xx``, ``g_yy`` complex [m/N] on ``freq_hz`` [Hz].
    modes_hz : sequence of float
        Frequencies [Hz] marked with a labelled vertical line on |G| (the dominant modes).
    """
    import matplotlib

    axes = list(np.atleast_1d(axes))
    cycle = matplotlib.rcParams["axes.prop_cycle"].by_key()["color"]
    for n, (label, f, gx, gy) in enumerate(curves):
        colours = XY_COLOURS if len(curves) == 1 else (cycle[n % len(cycle)],) * 2
        for g, style, d, c in ((gx, "-", "x", colours[0]), (gy, "--", "y", colours[1])):
            g = np.asarray(g) * UM_PER_N
            name = f"{label}, {d}" if len(curves) > 1 else f"G_{d}{d}"
            axes[0].semilogy(f, np.abs(g), style, color=c, lw=1.1, label=name)
            if len(axes) == 3:
                axes[1].plot(f, g.real, style, color=c, lw=1.0)
                axes[2].plot(f, g.imag, style, color=c, lw=1.0)
    for hz in modes_hz:
        axes[0].axvline(hz, color="#c0392b", lw=0.6, alpha=0.6)
        axes[0].annotate(f"{hz:.0f} Hz", (hz, 1.0), xycoords=("data", "axes fraction"), rotation=90, xytext=(2, -4),
                         textcoords="offset points", fontsize="x-small", color="#c0392b", va="top")
    for ax, name in zip(axes, ("tool point |G| [µm/N]", "Re G [µm/N]", "Im G [µm/N]")):
        ax.set_ylabel(name)
        ax.grid(True, which="both", alpha=0.3)
    axes[-1].set_xlabel("frequency [Hz]")
    axes[0].legend(fontsize="small", ncol=2 if len(curves) > 1 else 1, loc="lower left")


def draw_lobes(ax, rpm, a_lim_mm, a_crit_mm, pockets, safe_mm=None, band_mm=None, depth_cap_mm=None,
               safe_pockets=()) -> None:
    """Draw a stability-lobe diagram: the stable area, the limit, the critical depth and the best pockets.

    Parameters
    ----------
    ax : Axes
    rpm, a_lim_mm : array_like, shape (n,)
        The stability boundary: limiting axial depth [mm] per spindle speed [rpm], NaN
        where no lobe reaches.
    a_crit_mm : float or None
        The lowest limit over all speeds [mm] (stable at any speed below it).
    pockets : sequence of dict
        ``{"rpm", "a_lim_mm"}`` of the lobe peaks, best first; the best eight are marked
        and the best three labelled (at low speed the lobes crowd into many tiny peaks).
        With safe pockets only the best three peaks are marked, unlabelled.
    safe_mm : array_like, optional
        The depth stable with the band's confidence per speed [mm] (dashed).
    band_mm : (low, high) array_like, optional
        The lobes' uncertainty band [mm] (shaded).
    depth_cap_mm : float, optional
        The tool's flute length [mm]: a line, and the stable area stops there.
    safe_pockets : sequence of dict
        ``{"rpm_low", "rpm_high", "rpm", "a_mm"}`` best first: drawn as bars over their window.
    """
    rpm = np.asarray(rpm, dtype=float)
    a = np.asarray(a_lim_mm, dtype=float)
    finite = np.isfinite(a)
    if band_mm is not None:
        lo, hi = (np.asarray(b, dtype=float) for b in band_mm)
        if depth_cap_mm is not None:
            lo, hi = np.minimum(lo, depth_cap_mm), np.minimum(hi, depth_cap_mm)
        ax.fill_between(rpm, lo, hi, color="#f39c12", alpha=0.25, lw=0, label="uncertainty band")
    ax.fill_between(rpm, 0, np.where(finite, a, np.nan), color="#27ae60", alpha=0.15, lw=0, label="stable")
    ax.plot(rpm, a, color="#1e8449", lw=1.3, label="stability limit")
    if safe_mm is not None:
        ax.plot(rpm, np.asarray(safe_mm, dtype=float), color="#2c3e50", lw=1.0, ls="--", label="safe depth")
    if depth_cap_mm is not None:
        ax.axhline(depth_cap_mm, color="#7f8c8d", lw=1.2, ls=":", label=f"flute length {depth_cap_mm:g} mm")
    if a_crit_mm is not None:
        ax.axhline(a_crit_mm, color="#c0392b", ls="--", lw=1.0, label=f"critical depth {a_crit_mm:.3g} mm")
    for k, p in enumerate(safe_pockets[:LABELLED_POCKETS + 2]):
        ax.plot([p["rpm_low"], p["rpm_high"]], [p["a_mm"]] * 2, color="#8e44ad", lw=3.0, solid_capstyle="butt",
                label="safe pocket" if k == 0 else None)
        if k < LABELLED_POCKETS:
            ax.annotate(f"{p['rpm_low']:.0f}–{p['rpm_high']:.0f} rpm\n{p['a_mm']:.2g} mm", (p["rpm"], p["a_mm"]),
                        textcoords="offset points", xytext=(0, -22), ha="center", fontsize="x-small", color="#8e44ad")
    if len(safe_pockets):
        pockets = ()  # the safe pockets are the advice; the sharp peaks would compete with them
    for k, p in enumerate(pockets[:MARKED_POCKETS]):
        ax.plot(p["rpm"], p["a_lim_mm"], "v", color="#2c3e50", ms=6 if k < LABELLED_POCKETS else 4)
        if k < LABELLED_POCKETS:
            ax.annotate(f"{p['rpm']:.0f} rpm\n{p['a_lim_mm']:.2g} mm", (p["rpm"], p["a_lim_mm"]),
                        textcoords="offset points", xytext=(0, 6), ha="center", fontsize="x-small")
    top = max(float(a[finite].max()) if finite.any() else 0.0, a_crit_mm or 0.0)
    if depth_cap_mm is not None:
        top = min(top, depth_cap_mm) if top > 0 else depth_cap_mm
    ax.set_ylim(0, 1.25 * top if top > 0 else 1.0)
    if rpm.size:
        ax.set_xlim(rpm.min(), rpm.max())
    ax.set_xlabel("spindle speed [rpm]")
    ax.set_ylabel("axial depth of cut a_p [mm]")
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize="small", loc="upper left")


def draw_chatter(ax, rpm, chatter_hz) -> None:
    """Draw the chatter frequency [Hz] on the stability boundary against spindle speed [rpm]."""
    ax.plot(rpm, np.asarray(chatter_hz, dtype=float), ".", ms=1.5, color="#2c3e50")
    ax.set_xlabel("spindle speed [rpm]")
    ax.set_ylabel("chatter [Hz]")
    ax.grid(True, alpha=0.3)


def plot_toolpoint(curves, path, title: str = "") -> None:
    """Write a PNG of tool-point FRFs (:func:`draw_toolpoint`: |G|, Re G and Im G).

    Parameters
    ----------
    curves : list of (label, freq_hz, g_xx, g_yy)
        One entry per stick-out; ``g_xx``, ``g_yy`` complex [m/N] on ``freq_hz`` [Hz].
    path : str or Path
        The PNG to write.
    """
    plt = _pyplot()
    fig, axes = plt.subplots(3, 1, figsize=(8, 8), sharex=True, layout="constrained",
                             gridspec_kw={"height_ratios": [2, 1, 1]})
    draw_toolpoint(axes, curves)
    for ax in axes[:-1]:
        ax.set_xlabel("")  # shared axis: the frequency label only under the last panel
    axes[0].set_title(_wrap(title or "tool-point FRF on the machine"), fontsize=9)
    _save(fig, path)


def plot_lobes(rpm, a_lim_mm, a_crit_mm: float, pockets, path, chatter_hz=None, title: str = "", safe_mm=None,
               band_mm=None, depth_cap_mm=None, safe_pockets=()) -> None:
    """Write a PNG of a stability-lobe diagram (:func:`draw_lobes`), the chatter frequency below if given.

    Parameters are those of :func:`draw_lobes`, plus ``path`` (the PNG) and
    ``chatter_hz`` (array_like, shape (n,), optional): the chatter frequency on the
    boundary [Hz], drawn in a second panel (:func:`draw_chatter`).
    """
    plt = _pyplot()
    rows = 2 if chatter_hz is not None else 1
    fig, axes = plt.subplots(rows, 1, figsize=(8, 6.5 if rows == 2 else 4.5), sharex=True, layout="constrained",
                             gridspec_kw={"height_ratios": [3, 1][:rows]}, squeeze=False)
    draw_lobes(axes[0, 0], rpm, a_lim_mm, a_crit_mm, pockets, safe_mm, band_mm, depth_cap_mm, safe_pockets)
    if chatter_hz is not None:
        axes[0, 0].set_xlabel("")
        draw_chatter(axes[1, 0], rpm, chatter_hz)
    axes[0, 0].set_title(_wrap(title or "stability lobes"), fontsize=9)
    _save(fig, path)


def plot_spindle(freq_hz, h, path, trusted=None, title: str = "") -> None:
    """Write a PNG of a spindle receptance: |h_wf|, |h_wm|, |h_θm| (log), what not to trust shaded.

    Parameters
    ----------
    freq_hz : array_like, shape (n,)
    h : array_like, shape (n, 2, 2), complex
        [[h_wf, h_wm], [h_θf, h_θm]] [m/N, 1/N; 1/N, rad/(N·m)].
    trusted : array_like of bool, shape (n,), optional
        False where the result is not trustworthy (shaded).
    """
    plt = _pyplot()
    h = np.asarray(h)
    bad = np.zeros(len(freq_hz), bool) if trusted is None else ~np.asarray(trusted, dtype=bool)
    fig, axes = plt.subplots(3, 1, figsize=(8, 7.5), sharex=True, layout="constrained")
    terms = ((0, 0, "|h_wf| [m/N]"), (0, 1, "|h_wm| [1/N]"), (1, 1, "|h_θm| [rad/(N·m)]"))
    for ax, (i, j, label) in zip(axes, terms):
        ax.loglog(freq_hz, np.abs(h[:, i, j]), color="#2c3e50", lw=1.2)
        if bad.any():  # one artist however many bands
            ax.fill_between(freq_hz, 0, 1, where=bad, transform=ax.get_xaxis_transform(), color="#e67e22",
                            alpha=0.2, lw=0, step="mid")
        ax.set_ylabel(label)
        ax.grid(True, which="both", alpha=0.3)
    axes[-1].set_xlabel("frequency [Hz]")
    note = " (shaded: not trustworthy)" if bad.any() else ""
    axes[0].set_title((title or "spindle receptance at the coupling plane") + note, fontsize=9)
    _save(fig, path)
