"""Picture of a tap spectrum: the average in dB, the taps faint behind, labeled peaks.

matplotlib is imported inside the function (Agg backend) so that importing this module
costs nothing and works without a display.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

#: Colours per peak kind (colour-blind safe, after Okabe & Ito).
KIND_COLOURS = {"bending": "#D55E00", "local": "#0072B2", "other": "#7f7f7f"}


def _db(magnitude, reference: float) -> np.ndarray:
    return 20.0 * np.log10(np.maximum(np.asarray(magnitude, dtype=float), 1e-300) / reference)


def plot_spectrum(analysis, path, expected_hz=None, title: str | None = None, dpi: int = 120) -> None:
    """Write a PNG of a :class:`~taptune.signal.analysis.SpectrumAnalysis`.

    The averaged spectrum in dB re its maximum, each tap's spectrum faint behind it,
    every peak marked (bending peaks with "f1 = … Hz", local and other peaks with
    their frequency, smaller), the interface bands shaded and, when given, the model's
    expected bending frequencies as dotted lines.

    Parameters
    ----------
    analysis : SpectrumAnalysis
    path : str or Path
        PNG file to write.
    expected_hz : array_like, optional
        Model bending frequencies [Hz].
    title : str, optional
        Default: the file name, taps used and sample rate.
    dpi : int
    """
    import matplotlib

    matplotlib.use("Agg", force=False)
    from matplotlib.figure import Figure

    a = analysis
    f_khz = np.asarray(a.freq_hz) / 1e3
    ref = float(np.max(a.magnitude)) if np.size(a.magnitude) else 1.0
    fig = Figure(figsize=(11, 5.5), dpi=dpi)
    ax = fig.add_subplot(1, 1, 1)
    for mag in np.atleast_2d(a.tap_magnitudes):
        if a.n_taps > 1:
            ax.plot(f_khz, _db(mag, ref), color="0.6", lw=0.5, alpha=0.35, zorder=1)
    avg_db = _db(a.magnitude, ref)
    ax.plot(f_khz, avg_db, color="black", lw=1.0, zorder=2,
            label=f"average of {a.n_taps} tap{'s' if a.n_taps != 1 else ''}")
    if a.noise_magnitude is not None:
        ax.plot(f_khz, _db(a.noise_magnitude, ref), color="#009E73", lw=0.6, alpha=0.7, zorder=1,
                label="between taps (noise, hum)")
    for lo, hi in a.excluded_bands_hz:
        ax.axvspan(lo / 1e3, hi / 1e3, color=KIND_COLOURS["local"], alpha=0.12, zorder=0, lw=0)
    if a.excluded_bands_hz:
        ax.plot([], [], color=KIND_COLOURS["local"], alpha=0.3, lw=8, label="interface band")
    if expected_hz is not None:
        for n, f in enumerate(np.asarray(expected_hz, dtype=float)):
            ax.axvline(f / 1e3, color=KIND_COLOURS["bending"], ls=":", lw=1.0, zorder=1,
                       label="model (nominal)" if n == 0 else None)
    floor = float(np.percentile(avg_db, 2))
    seen = set()
    for p in a.peaks:
        y = float(np.interp(p.hz, a.freq_hz, avg_db))
        colour = KIND_COLOURS.get(p.kind, "black")
        label = p.kind if p.kind not in seen else None
        seen.add(p.kind)
        ax.plot([p.hz / 1e3], [y], marker="v" if p.kind == "bending" else "o", color=colour,
                ms=8 if p.kind == "bending" else 5, zorder=4, ls="none", label=label)
        if p.note.startswith("stationary"):
            continue  # hum and its harmonics: marked, not labelled (they crowd 0-1 kHz)
        if p.kind == "bending":
            text, size, weight = f"f{p.mode} = {p.hz:,.1f} Hz", 9, "bold"
        else:
            text, size, weight = f"{p.hz:,.0f}", 7, "normal"
        ax.annotate(text, (p.hz / 1e3, y), xytext=(0, 8), textcoords="offset points", ha="center",
                    va="bottom", rotation=90 if p.kind != "bending" else 0, fontsize=size,
                    color=colour, fontweight=weight, zorder=5)
    # Up to 24 kHz (the band of interest) or a little beyond the highest peak.
    top_hz = max([24000.0] + [1.15 * p.hz for p in a.peaks])
    ax.set_xlim(0, min(top_hz / 1e3, f_khz[-1]) if f_khz.size else 1)
    ax.set_ylim(max(floor - 5, -120), 12)
    ax.set_xlabel("frequency [kHz]")
    ax.set_ylabel("magnitude [dB re maximum]")
    ax.grid(True, color="0.9", lw=0.6)
    ax.legend(loc="lower left", fontsize=8, ncol=3, framealpha=0.9)
    name = Path(a.file).name if a.file else "recording"
    ax.set_title(title or f"{name}: {a.n_taps} of {len(a.taps)} taps, {a.sample_rate} Hz", fontsize=10)
    if a.warnings:
        fig.text(0.01, 0.005, "\n".join("! " + w for w in a.warnings[:4]), fontsize=7, color="#B8860B",
                 va="bottom", ha="left")
        fig.subplots_adjust(bottom=0.1 + 0.03 * min(len(a.warnings), 4))
    from taptune.report.figures import save_png

    save_png(fig, path)
