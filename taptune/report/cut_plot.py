"""Pictures of a listened cut: its spectrum with the forced lines and the chatter, and the observed cuts on the lobes.

matplotlib is imported inside the functions (Agg backend), as everywhere in ``report``.

Signatures::

    draw_cut_spectrum(ax, analysis) -> None
    draw_observations(ax, observations, depth_mm=None) -> None
    plot_cut(analysis, path, lobes=None, title="") -> None
"""

from __future__ import annotations

import numpy as np

from taptune.report.fit_plot import _pyplot, _save

STABLE_COLOUR = "#1e8449"
CHATTER_COLOUR = "#c0392b"
UNCLEAR_COLOUR = "#b9770e"


def draw_cut_spectrum(ax, analysis) -> None:
    """The steady cut's spectrum [dB], the idle part's under it, tooth-passing harmonics and the chatter marked."""
    a = analysis
    f = np.asarray(a.freq_hz)
    top = float(np.max(a.level_db))
    if a.idle_db is not None:
        ax.plot(f, a.idle_db - top, color="#aab7b8", lw=0.7, label="idle (machine's own tones)")
    ax.plot(f, a.level_db - top, color="#2c3e50", lw=0.8, label="cut")
    h = np.arange(1, int(f[-1] // a.tooth_passing_hz) + 1) * a.tooth_passing_hz
    for i, x in enumerate(h):
        ax.axvline(x, color=STABLE_COLOUR, ls=":", lw=0.8,
                   label=f"tooth passing × k ({a.tooth_passing_hz:.1f} Hz, {a.spindle_rpm:.0f} rpm)" if i == 0 else None)
    if a.chatter_hz is not None and a.verdict != "stable":
        colour = CHATTER_COLOUR if a.verdict == "chatter" else UNCLEAR_COLOUR
        y = float(np.interp(a.chatter_hz, f, a.level_db) - top)
        ax.plot([a.chatter_hz], [y], "v", color=colour, ms=9,
                label=f"{a.verdict} {a.chatter_hz:.0f} Hz ({a.chatter_level_db:+.0f} dB)")
        for x in a.family_hz:
            ax.plot([x], [float(np.interp(x, f, a.level_db) - top)], "v", color=colour, ms=5, alpha=0.6)
    ax.set_xlim(0, min(f[-1], max(6 * a.tooth_passing_hz, 1.5 * (a.chatter_hz or 0), 2000.0)))
    ax.set_ylim(-90, 5)
    ax.set_xlabel("frequency [Hz]")
    ax.set_ylabel("level [dB re the loudest line]")
    ax.legend(fontsize="x-small", loc="upper right")
    ax.grid(alpha=0.3)


def draw_observations(ax, observations, depth_mm=None) -> None:
    """Observed cuts on a lobe diagram: ✓ stable (green), ✗ chatter (red), ? unclear; the last one larger."""
    for i, o in enumerate(observations):
        last = i == len(observations) - 1
        colour, mark = {"stable": (STABLE_COLOUR, "$\u2713$"), "chatter": (CHATTER_COLOUR, "$\u2717$")}.get(
            o.verdict, (UNCLEAR_COLOUR, "$?$"))
        ax.plot(o.rpm, o.depth_mm, marker=mark, color=colour, ms=14 if last else 9, ls="none")
    if depth_mm is not None:
        ax.axhline(depth_mm, color="#7f8c8d", lw=0.6, ls="--")


def plot_cut(analysis, path, lobes=None, title: str = "") -> None:
    """Write a PNG: the cut's spectrum; below, with ``lobes`` = (rpm, a_lim [m], a_safe [m] or None,
    observations, depth [mm]), the lobe diagram with the observed cuts."""
    plt = _pyplot()
    rows = 2 if lobes is not None else 1
    fig, axes = plt.subplots(rows, 1, figsize=(8, 7 if rows == 2 else 4.2), layout="constrained", squeeze=False)
    draw_cut_spectrum(axes[0, 0], analysis)
    axes[0, 0].set_title(title or "cut spectrum", fontsize=9)
    if lobes is not None:
        from taptune.report.machine_plot import draw_lobes

        rpm, a_lim, a_safe, observations, depth = lobes
        a_mm = np.asarray(a_lim, float) * 1e3
        ax = axes[1, 0]
        draw_lobes(ax, rpm, np.where(np.isfinite(a_mm), a_mm, np.nan), None, [])
        if a_safe is not None:
            ax.plot(rpm, np.asarray(a_safe) * 1e3, color="#117a65", ls="--", lw=1.0, label="safe limit")
        draw_observations(ax, observations, depth)
        ax.set_ylim(0, max(ax.get_ylim()[1], 1.3 * max([o.depth_mm for o in observations] + [depth or 0])))
        ax.set_title("stability lobes with the observed cuts (✓ stable, ✗ chatter)", fontsize=9)
    _save(fig, path)
