"""Pictures of the machine stage: tool-point FRFs, stability lobes, spindle receptances.

Arrays in (SI: m/N, Hz, rpm; depths in mm), a PNG out through
:func:`taptune.report.figures.save_png`. matplotlib is imported inside the functions
(Agg backend), so importing this module costs nothing on the CLI's fast paths.
"""

from __future__ import annotations

import numpy as np

from taptune.report.fit_plot import _pyplot, _save

UM_PER_N = 1e6  # m/N → µm/N for the axes (a machinist reads µm/N)
MARKED_POCKETS = 8


def _wrap(title: str, width: int = 100) -> str:
    """Each line of ``title`` wrapped to fit an 8-inch figure at 9 pt."""
    import textwrap

    return "\n".join(textwrap.fill(line, width) for line in title.splitlines())


def plot_toolpoint(curves, path, title: str = "") -> None:
    """Write a PNG of tool-point FRFs: |G| (log), real and imaginary part, x solid and y dashed.

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
    colours = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    for k, (label, f, gx, gy) in enumerate(curves):
        c = colours[k % len(colours)]
        for g, style, d in ((gx, "-", "x"), (gy, "--", "y")):
            g = np.asarray(g) * UM_PER_N
            axes[0].semilogy(f, np.abs(g), style, color=c, lw=1.2, label=f"{label}, {d}")
            axes[1].plot(f, g.real, style, color=c, lw=1.0)
            axes[2].plot(f, g.imag, style, color=c, lw=1.0)
    axes[0].set_ylabel("|G| [µm/N]")
    axes[1].set_ylabel("Re G [µm/N]")
    axes[2].set_ylabel("Im G [µm/N]")
    axes[2].set_xlabel("frequency [Hz]")
    for ax in axes:
        ax.grid(True, which="both", alpha=0.3)
    axes[0].legend(fontsize=8, ncol=2)
    axes[0].set_title(_wrap(title or "tool-point FRF on the machine"), fontsize=9)
    _save(fig, path)


def plot_lobes(rpm, a_lim_mm, a_crit_mm: float, pockets, path, chatter_hz=None, title: str = "") -> None:
    """Write a PNG of a stability-lobe diagram.

    Parameters
    ----------
    rpm, a_lim_mm : array_like, shape (n,)
        The stability boundary: limiting axial depth [mm] per spindle speed [rpm].
    a_crit_mm : float
        The lowest limit over all speeds [mm] (stable at any speed below it).
    pockets : list of dict
        ``{"rpm", "a_lim_mm"}`` of the lobe peaks, best first; the best eight are marked and
        the best three labelled.
    chatter_hz : array_like, shape (n,), optional
        Chatter frequency on the boundary [Hz]; drawn in a second panel when given.
    """
    plt = _pyplot()
    rpm = np.asarray(rpm, dtype=float)
    a = np.asarray(a_lim_mm, dtype=float)
    rows = 2 if chatter_hz is not None else 1
    fig, axes = plt.subplots(rows, 1, figsize=(8, 6.5 if rows == 2 else 4.5), sharex=True, layout="constrained",
                             gridspec_kw={"height_ratios": [3, 1][:rows]}, squeeze=False)
    ax = axes[0, 0]
    ax.fill_between(rpm, 0, a, color="#27ae60", alpha=0.15, lw=0, label="stable")
    ax.plot(rpm, a, color="#1e8449", lw=1.4, label="stability limit")
    ax.axhline(a_crit_mm, color="#c0392b", ls="--", lw=1.0, label=f"critical depth {a_crit_mm:.3g} mm")
    # The best few pockets only: at low speed the lobes crowd into many tiny peaks.
    for k, p in enumerate(pockets[:MARKED_POCKETS]):
        ax.plot(p["rpm"], p["a_lim_mm"], "v", color="#2c3e50", ms=6 if k < 3 else 4)
        if k < 3:
            ax.annotate(f"{p['rpm']:.0f} rpm\n{p['a_lim_mm']:.2g} mm", (p["rpm"], p["a_lim_mm"]),
                        textcoords="offset points", xytext=(0, 8), ha="center", fontsize=7)
    top = max(float(np.nanmax(a)) if a.size else 0.0, a_crit_mm)
    ax.set_ylim(0, 1.2 * top if top > 0 else 1.0)
    ax.set_xlim(rpm.min(), rpm.max())
    ax.set_ylabel("axial depth of cut a_p [mm]")
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=8, loc="upper left")
    ax.set_title(_wrap(title or "stability lobes (zero-order approximation)"), fontsize=9)
    if chatter_hz is not None:
        axes[1, 0].plot(rpm, np.asarray(chatter_hz, dtype=float), ".", ms=1.5, color="#2c3e50")
        axes[1, 0].set_ylabel("chatter [Hz]")
        axes[1, 0].grid(True, alpha=0.3)
    axes[-1, 0].set_xlabel("spindle speed [rpm]")
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
