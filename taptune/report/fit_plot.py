"""Pictures of an identification (measured spectrum vs fitted model) and of predictions.

matplotlib is imported inside the functions (Agg backend), so importing this module
costs nothing on the CLI's fast paths.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from taptune.report.text import signed


KIND_COLOURS = {"bending": "#c0392b", "local": "#7f8c8d", "other": "#2980b9"}


def _pyplot():
    import matplotlib

    matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt

    return plt


def _save(fig, path) -> None:
    from taptune.report.figures import save_png

    try:
        save_png(fig, path, dpi=110)
    finally:
        _pyplot().close(fig)


def draw_identification(fig, result, analyses, title: str = "") -> None:
    """Fill ``fig`` with the spectrum (top) and the fit in the mode-1 window (bottom), per recording."""
    n = len(analyses)
    axes = fig.subplots(2, n, squeeze=False, gridspec_kw={"height_ratios": [3, 2]})
    for i, analysis in enumerate(analyses):
        ax, bx = axes[0, i], axes[1, i]
        f = np.asarray(analysis.freq_hz)
        mag = np.asarray(analysis.magnitude)
        db = 20 * np.log10(np.maximum(mag / mag.max(), 1e-8))
        ax.plot(f / 1e3, db, color="0.15", lw=0.8)
        for lo, hi in getattr(analysis, "excluded_bands_hz", ()):
            ax.axvspan(lo / 1e3, hi / 1e3, color="0.85", zorder=0)
        w = result.window_hz[i]
        ax.axvspan(w[0] / 1e3, w[-1] / 1e3, color="#f5b041", alpha=0.5, zorder=0, label="fit window")
        for peak in analysis.peaks:
            if peak.kind == "other":
                continue
            colour = KIND_COLOURS.get(peak.kind, "k")
            ax.plot(peak.hz / 1e3, peak.level_db - 20 * np.log10(mag.max()) if peak.level_db is not None else 0,
                    "v", color=colour, ms=6)
            label = f"{peak.hz:.0f}" if peak.kind == "bending" else "local"
            ax.annotate(label, (peak.hz / 1e3, 0), xytext=(0, -2), textcoords="offset points",
                        ha="center", va="top", fontsize=8, color=colour, rotation=90)
        for fm in result.bending_model_hz[i]:
            ax.axvline(fm / 1e3, color=KIND_COLOURS["bending"], lw=0.6, ls="--")
        ax.set_xlim(0, f[-1] / 1e3)
        ax.set_ylim(-90, 8)
        ax.set_xlabel("frequency [kHz]")
        ax.set_ylabel("level [dB re peak]")
        name = getattr(analysis, "file", None) or getattr(analysis, "path", "")
        ax.set_title(Path(name).name if name else "", fontsize=9)
        ax.grid(alpha=0.3)
        bx.plot(w, result.measured_shape[i], color="0.15", lw=1.2, label="measured")
        bx.plot(w, result.model_shape[i], color=KIND_COLOURS["bending"], lw=1.2, ls="--", label="model")
        bx.set_xlabel("frequency [Hz] (window around mode 1)")
        bx.set_ylabel("normalised")
        bx.grid(alpha=0.3)
        bx.legend(fontsize=8, loc="upper right")
        meas = result.bending_measured_hz[i]
        model = result.bending_model_hz[i]
        text = "\n".join(
            f"f{n + 1}: {'—' if m is None else f'{m:.1f}'} / {fm:.1f} Hz" for n, (m, fm) in enumerate(zip(meas, model))
        )
        bx.text(0.02, 0.95, "measured / model\n" + text, transform=bx.transAxes, va="top", fontsize=8,
                family="monospace", bbox={"fc": "white", "ec": "0.8", "alpha": 0.9})
    p = result.params
    fig.suptitle(
        (title + "\n" if title else "")
        + f"k_tt {p.k_tt:.3g} N/m/mm · k_rr {p.k_rr:.3g} N·m/rad/mm · eta_tt {p.eta_tt:.2g} · eta_rr {p.eta_rr:.2g} 1/mm · "
        f"alpha {signed(p.alpha, 1)} % · ρ×{p.density_factor:.3f} · E×{p.modulus_factor:.3f}",
        fontsize=9,
    )


def plot_identification(result, analyses, path, title: str = "") -> None:
    """Write a PNG of the measured spectrum with labelled peaks, the fit window and the fit."""
    plt = _pyplot()
    fig = plt.figure(figsize=(5.5 * len(analyses) + 3, 7), layout="constrained")
    draw_identification(fig, result, analyses, title)
    _save(fig, path)


def draw_predictions(ax, curves, predictions) -> None:
    """Tip receptance magnitude per stick-out on ``ax`` (curves: list of (freq_hz, H))."""
    for (f, h), p in zip(curves, predictions):
        line, = ax.semilogy(f / 1e3, np.abs(h), lw=1.1, label=f"{p.stickout_mm:g} mm: f1 {p.bending_hz[0]:.0f} ± {p.bending_hz_spread[0]:.0f} Hz")
        for fn in p.bending_hz:
            ax.axvline(fn / 1e3, color=line.get_color(), lw=0.5, ls=":")
    ax.set_xlabel("frequency [kHz]")
    ax.set_ylabel("|H_tip| [m/N] (free-free)")
    ax.grid(alpha=0.3, which="both")
    ax.legend(fontsize=8, title="stick-out", title_fontsize=8)


def prediction_curves(entry_params, assemblies, model_options=None, f_max_hz: float = 20000.0):
    """(freq_hz, tip receptance) for the best parameters on each assembly."""
    from taptune.model import ModelOptions, build_model, tip_receptance

    f = np.linspace(200.0, f_max_hz, 2000)
    return [(f, tip_receptance(build_model(a, model_options or ModelOptions()), entry_params, f)) for a in assemblies]


def plot_predictions(entry, assemblies, predictions, path) -> None:
    """Write a PNG of the predicted tip receptances, one curve per stick-out."""
    plt = _pyplot()
    fig, ax = plt.subplots(figsize=(8, 5), layout="constrained")
    options = entry.options()
    draw_predictions(ax, prediction_curves(entry.params, assemblies, options), predictions)
    ax.set_title(f"{entry.name}\n{assemblies[0].tool.name}", fontsize=9)
    _save(fig, path)
