"""The picture of docs/cut.md: a stable and a chattering cut of the same tool, as ``taptune cut`` hears them.

``python -m benchmarks.cut.make_figure [OUT.png]`` (default docs/figures/cut-chatter.png;
deterministic). Both cuts come from the milling simulation with the regenerative delay
(a 2-mode end mill, 3 teeth, half immersion, down-milling, 7,000 rpm) in shop sound.
"""

from __future__ import annotations

import sys
from pathlib import Path

from benchmarks.cut.bench_cut import CONFIGS, KTC, KRC
from benchmarks.cut.sounds import simulated_cuts
from taptune.signal.cut import analyse_cut

RPM = 7000.0


def main(argv=None) -> None:
    argv = sys.argv[1:] if argv is None else argv
    out = Path(argv[0]) if argv else Path(__file__).resolve().parents[2] / "docs" / "figures" / "cut-chatter.png"
    cfg = CONFIGS[0]
    cuts = simulated_cuts(cfg["mx"], cfg["my"], teeth=cfg["teeth"], ktc=KTC, krc=KRC, diameter=cfg["diameter"],
                          ae=cfg["ae"], milling=cfg["milling"], rpm=RPM, depths=[1.0e-3, 3.5e-3], seed=21,
                          noise_db=-30.0, fans=1, hum_hz=50.0)
    from taptune.report.cut_plot import draw_cut_spectrum
    from taptune.report.fit_plot import _pyplot, _save

    plt = _pyplot()
    fig, axes = plt.subplots(2, 1, figsize=(8, 6.4), layout="constrained", sharex=True)
    for ax, (rec, truth, growth), depth in zip(axes, cuts, (1.0, 3.5)):
        a = analyse_cut(rec, RPM, cfg["teeth"])
        draw_cut_spectrum(ax, a)
        ax.set_title(f"{depth:g} mm deep at {RPM:,.0f} rpm, 3 teeth: {a.verdict}", fontsize=9, loc="left")
        print(f"{depth} mm: {a.verdict}, chatter {a.chatter_hz}, level {a.chatter_level_db}, growth {growth:.3f}")
    axes[0].set_xlabel("")
    axes[1].set_xlim(0, 3000)
    _save(fig, str(out))
    print(f"wrote {out}")


if __name__ == "__main__":
    main()
