"""Make the figures of docs/ (tap-test guide, physics page) with taptune's own code.

The tap-test figures are synthetic recordings of the bundled ER32 example
(``assets/er32_hsk63_d16.toml`` with the holder parameters of ``recordings/er32_d16``)
made by :mod:`taptune.synthetic`, analysed as ``taptune spectrum --assembly`` does and
drawn by :func:`taptune.report.spectrum_plot.plot_spectrum`: one good recording and one
for each common mistake (clipped, double hits, too quiet, loud hum). The physics figure
draws the same assembly to scale with its contact zone and its first three free-free
bending modes from the model.

Run: ``python scripts/make_doc_figures.py`` (deterministic; rewrites docs/figures/).
"""

from __future__ import annotations

import json
import os
import sys
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

import numpy as np  # noqa: E402

from taptune.identify.pipeline import analyse_for_assembly, model_expectation  # noqa: E402
from taptune.io.assembly import load_assembly  # noqa: E402
from taptune.model import ModelOptions, build_model, mode_shapes, solve_modes  # noqa: E402
from taptune.model.params import HolderParams  # noqa: E402
from taptune.report.figures import save_png  # noqa: E402
from taptune.report.spectrum_plot import plot_spectrum  # noqa: E402
from taptune.signal.synth import Nuisances  # noqa: E402
from taptune.synthetic import simulate_tap_recording  # noqa: E402

OUT = REPO / "docs" / "figures"
ASSEMBLY = REPO / "assets" / "er32_hsk63_d16.toml"
TRUTH = REPO / "recordings" / "er32_d16.truth.json"
DPI = 80  # 880 x 440 px: readable on a page, < 150 kB
DPI_PHYSICS = 100

# Six taps about 0.6 s apart, as the guide asks; 48 kHz; a measurement microphone's roll-off.
GOOD = dict(
    sample_rate=48000, duration_s=4.0, tap_times_s=(0.3, 0.9, 1.5, 2.1, 2.7, 3.3),
    tap_strengths=(1.0, 0.8, 0.9, 0.75, 0.95, 0.85), contact_s=5e-5, radiation_exponent=2.0,
    mic_hp_hz=80.0, mic_lp_hz=20000.0, snr_db=40.0, level=0.5, hum_rel_db=-40.0,
)
# What goes wrong at the machine, as changes to the good recording.
CASES = {
    "tap-good": {},
    "tap-clipped": dict(level=2.5, clip=1.0),  # input gain too high: flat tops at full scale
    "tap-double-hit": dict(double_hits=tuple((k, 0.006 + 0.002 * k, 0.6) for k in range(6))),  # the rod bounced
    "tap-quiet": dict(snr_db=24.0, level=0.02),  # tapped too softly, microphone far away
    "tap-hum": dict(hum_rel_db=-24.0, hum_harmonics=10),  # mains hum from a charger or a lamp
}


def holder_params() -> HolderParams:
    """The true holder of the bundled ER32 example recording."""
    return HolderParams(**json.loads(TRUTH.read_text(encoding="utf-8"))["true_params"])


def tap_figures(assembly, params) -> list[Path]:
    guidance = model_expectation(assembly, None, None)  # nominal model, as taptune spectrum uses it
    written = []
    for name, change in CASES.items():
        recording = simulate_tap_recording(assembly, params, Nuisances(**{**GOOD, **change}),
                                           np.random.default_rng(3), path=f"{name}.wav")
        analysis = analyse_for_assembly(recording, assembly, guidance=guidance)
        path = OUT / f"{name}.png"
        plot_spectrum(analysis, path, expected_hz=guidance[0], dpi=DPI)
        written.append(path)
        print(f"{path.name}: {analysis.n_taps} of {len(analysis.taps)} taps, bending "
              f"{', '.join(f'{f:.0f}' for f in analysis.bending_hz)} Hz; warnings: {analysis.warnings or 'none'}")
    return written


def _outline(ax, z0_mm, segments, colour, hatch=None, bore=None):
    """Draw coaxial cylinders (section: outer contour, bore left open) from z0 along +z."""
    z = z0_mm
    for s in segments:
        length, od, bore_d = s.length * 1e3, s.od * 1e3, s.id * 1e3
        for sign in (1, -1):
            ax.fill_between([z, z + length], sign * bore_d / 2, sign * od / 2, color=colour, lw=0, hatch=hatch)
        if bore is not None and bore_d > 0:
            ax.fill_between([z, z + length], -bore_d / 2, bore_d / 2, color=bore, lw=0)
        z += length


def physics_figure(assembly, params) -> Path:
    """The assembly to scale with the contact zone, and its first three bending modes."""
    import matplotlib

    matplotlib.use("Agg", force=False)
    from matplotlib.figure import Figure

    fe = build_model(assembly, ModelOptions())
    modes = solve_modes(fe, params, 3)
    z_h, w_h, z_t, w_t = mode_shapes(fe, modes)
    mm = 1e3
    # Axes placed by hand so that the drawing has one scale for both axes and shares the
    # z range of the mode shapes below it: its height follows from its width.
    zlim = (-5.0, assembly.z_tip * mm + 5.0)
    half_height_mm, width_in, left, bottom_in, gap_in, modes_in = 42.0, 6.9, 0.6, 0.55, 0.35, 2.7
    top_in = width_in * 2 * half_height_mm / (zlim[1] - zlim[0])
    height_in = bottom_in + modes_in + gap_in + top_in + 0.3
    fig = Figure(figsize=(width_in + left + 0.2, height_in), dpi=DPI_PHYSICS)
    fw = width_in + left + 0.2
    bottom = fig.add_axes((left / fw, bottom_in / height_in, width_in / fw, modes_in / height_in))
    top = fig.add_axes((left / fw, (bottom_in + modes_in + gap_in) / height_in, width_in / fw, top_in / height_in))
    _outline(top, 0.0, assembly.holder.segments, "#a9b4bf", bore="#eef1f4")
    _outline(top, assembly.z_tool_start * mm, assembly.tool.segments, "#4f5b66")
    z0, z1 = assembly.z_contact_start * mm, assembly.holder.length * mm
    top.axvspan(z0, z1, color="#E69F00", alpha=0.25, lw=0)
    top.annotate(f"contact zone L_c = {z1 - z0:.0f} mm: a sloped, lossy layer\n"
                 f"(k_tt, k_rr, η_tt, η_rr, α) joins tool and holder",
                 ((z0 + z1) / 2, -27), ha="center", va="top", fontsize=8, color="#8a5a00")
    top.annotate("", (z1, 36), (assembly.z_tip * mm, 36), arrowprops=dict(arrowstyle="<->", lw=0.8))
    top.text((z1 + assembly.z_tip * mm) / 2, 38, f"stick-out {assembly.stickout * mm:.1f} mm", ha="center",
             va="bottom", fontsize=8)
    top.text(2, 36, "holder (steel, in section)", fontsize=8, va="bottom")
    top.text(assembly.z_tip * mm, -12, "tool (carbide)  tip ", fontsize=8, ha="right", va="top")
    top.set_ylim(-half_height_mm, half_height_mm)
    top.set_ylabel("radius [mm]")
    top.set_title(f"{assembly.holder.name} with {assembly.tool.name}, free-free", fontsize=10)
    colours = ("#D55E00", "#0072B2", "#009E73")
    for r in range(3):
        scale = np.max(np.abs(np.concatenate([w_h[:, r], w_t[:, r]])))
        # Real part of the (nearly real) complex mode, tip deflection positive.
        sign = np.sign(np.real(w_t[-1, r])) or 1.0
        label = f"mode {r + 1}: {modes.frequency_hz[r]:,.0f} Hz, ζ = {100 * modes.damping_ratio[r]:.2f} %"
        bottom.plot(z_t * mm, sign * np.real(w_t[:, r]) / scale, color=colours[r], lw=1.6, label=label)
        bottom.plot(z_h * mm, sign * np.real(w_h[:, r]) / scale, color=colours[r], lw=1.0, ls="--")
    bottom.axvspan(z0, z1, color="#E69F00", alpha=0.25, lw=0)
    bottom.axhline(0, color="0.6", lw=0.6)
    bottom.plot([], [], color="0.3", lw=1.0, ls="--", label="holder (dashed), tool (solid)")
    bottom.set_xlabel("z [mm] (0 at the spindle end of the holder)")
    bottom.set_ylabel("lateral deflection (normalised)")
    bottom.legend(loc="lower center", fontsize=8)
    top.set_xlim(zlim)
    bottom.set_xlim(zlim)
    top.tick_params(labelbottom=False)
    bottom.grid(True, color="0.9", lw=0.6)
    path = OUT / "physics-modes.png"
    save_png(fig, path)
    print(f"{path.name}: f1-f3 {', '.join(f'{f:.0f}' for f in modes.frequency_hz)} Hz")
    return path


def main() -> int:
    OUT.mkdir(parents=True, exist_ok=True)
    assembly, params = load_assembly(ASSEMBLY), holder_params()
    written = tap_figures(assembly, params) + [physics_figure(assembly, params)]
    for path in written:
        print(f"  {path.relative_to(REPO)}  {path.stat().st_size / 1024:.0f} kB")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
