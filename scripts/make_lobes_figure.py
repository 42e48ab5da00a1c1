"""Write docs/figures/lobes_band.png: the picture of docs/machine.md's lobes section.

Insperger & Stépán's 1-DOF milling benchmark (2 teeth, K_t 6e8 N/m², K_n 2e8 N/m²,
f_n 922 Hz, ζ 0.011, k 1.34e6 N/m), a/D = 0.05 down-milling, 12,000–26,000 rpm:
semi-discretization lobes with a ±2 % band on the modal frequency, the safe depth, the
safe pockets and a 5 mm flute length, and the zero-order lobes for comparison.

    python scripts/make_lobes_figure.py [OUT.png]
"""

from __future__ import annotations

import sys
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))


def main() -> None:
    import numpy as np

    from taptune.machine import stability_lobes
    from taptune.machine.band import lobes_with_band
    from taptune.machine.simulate import ModalSet
    from taptune.report.fit_plot import _pyplot, _save
    from taptune.report.machine_plot import draw_lobes

    out = Path(sys.argv[1]) if len(sys.argv) > 1 else REPO / "docs" / "figures" / "lobes_band.png"
    mode = ModalSet([922.0], [0.011], [1.34e6])
    f = np.arange(100.0, 3000.0, 1.0)
    g = mode.frf(f)
    cut = dict(teeth=2, ktc=6e8, krc=2e8, diameter=20e-3, ae=1e-3, milling="down")
    rpm = np.arange(12000.0, 26000.0 + 1, 20.0)
    lobes, band = lobes_with_band(f, g, np.zeros_like(g), rpm=rpm, method="sdm", band=(0.02, 0.9, "±2 %"),
                                  depth_cap=5e-3, **cut)
    zoa = stability_lobes(f, g, np.zeros_like(g), rpm=rpm, method="zoa", **cut)
    d = lobes.to_dict()
    plt = _pyplot()
    fig, ax = plt.subplots(figsize=(8, 5.2), layout="constrained")
    mm = lambda a: np.minimum(a, 5e-3) * 1e3  # noqa: E731 (SDM: inf is stable up to the flute length)
    draw_lobes(ax, rpm, mm(lobes.a_lim), d["a_crit_mm"], d["pockets"], safe_mm=band.a_safe * 1e3,
               band_mm=(band.a_low * 1e3, band.a_high * 1e3), depth_cap_mm=5.0,
               safe_pockets=[p.to_dict() for p in band.safe_pockets])
    ax.plot(rpm, mm(zoa.a_lim), color="#c0392b", lw=0.9, ls="-.", label="zero-order (for comparison)")
    flip = np.array(lobes.instability) == "flip"
    ax.plot(rpm[flip], mm(lobes.a_lim)[flip], ".", ms=2, color="#8e44ad", label="flip (period doubling)")
    ax.set_ylim(0, 5.6)
    ax.legend(fontsize="x-small", loc="upper center", bbox_to_anchor=(0.5, -0.13), ncol=4, frameon=False)
    ax.set_title("1-DOF milling benchmark, a/D = 0.05 down-milling: semi-discretization, ±2 % band, "
                 "90 % safe pockets", fontsize=9)
    _save(fig, out)
    print(f"wrote {out}")


if __name__ == "__main__":
    main()
