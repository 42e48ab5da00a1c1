"""Make the example recordings in recordings/ (synthetic, from the model).

Each example is a tool-holder assembly from assets/ with known ("true") holder
parameters, rendered as a tap recording by taptune's synthesis (``signal.synth``): the
model's tool-tip receptance, a half-sine tap force, radiation, microphone roll-off, a
reflection, mains hum, noise, and the HSK-A63 interface's local modes. Next to each
recording: its assembly file, and a truth file with the parameters and the true bending
frequencies at the recorded and at two other stick-outs (what the demo compares its
predictions with).

The recordings are fixed data that tests and documentation quote, so this script
reproduces the committed files byte for byte: it renders with the model mesh and the
synthesis settings they were made with (:data:`RECORDING_MESH`, ``rigid_body="keep"``),
not with today's defaults, which are finer (f1–f3 lower by at most 0.008 % on these
assemblies) and remove the free body's rigid-body line (the microphone's 80 Hz
high-pass takes most of it out here anyway). The truth is the same model's, so it
describes exactly what was rendered.

Run: ``python scripts/make_recordings.py`` (rewrites recordings/), ``--out DIR`` to write
elsewhere, ``--check`` to compare a fresh rendering with the committed files (exit 1 on
any difference).
"""

from __future__ import annotations

import argparse
import filecmp
import json
import os
import shutil
import sys
import tempfile
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

import numpy as np  # noqa: E402

from taptune.io.assembly import load_assembly  # noqa: E402
from taptune.io.audio import write_audio  # noqa: E402
from taptune.model import ModelOptions, analyse, build_model, tip_receptance  # noqa: E402
from taptune.model.params import HolderParams  # noqa: E402
from taptune.signal.synth import Nuisances, synthesize_recording, tap_grid  # noqa: E402
from taptune.synthetic import HSK_A63_LOCAL_MODES  # noqa: E402

# The mesh the committed recordings were rendered with (the defaults of November 2026
# before the mesh was refined for slender tools and stubby sections).
RECORDING_MESH = ModelOptions(layer_h_min_ratio=0.2, layer_h_max_ratio=2.0, zone_growth=1.3, zone_h_max_mm=1.5,
                              elements_per_wavelength=0.0)
CASES = [
    {
        "name": "er32_d16",
        "description": "ER32 collet chuck, HSK-A63, Ø16 end mill at 53.5 mm (the reference assembly drawn in docs/physics.md)",
        "asset": "er32_hsk63_d16.toml",
        # Published holder A (CIRP Journal of Manufacturing Science and Technology, 2022).
        "params": HolderParams(1.90e9, 9.37e3, 1.98e-3, 8.20e-3, -10.0, 7478 / 7800, 1.0),
        "predict_stickouts_mm": [63.5, 73.5],
        "audio": {"file": "er32_d16_tap.wav", "subtype": "PCM_16", "sample_rate": 48000, "seed": 11,
                  "tap_times_s": (0.25, 0.95, 1.6), "tap_strengths": (1.0, 0.7, 0.85), "snr_db": 38.0,
                  "hum_hz": 50.0},
    },
    {
        "name": "shrinkfit_d12",
        "description": "Shrink-fit chuck, HSK-A63, Ø12 end mill at 40 mm",
        "asset": "shrinkfit_hsk63_d12.toml",
        "params": HolderParams(4.2e9, 3.1e4, 2.6e-3, 4.0e-4, 6.0, 1.01, 1.02),
        "predict_stickouts_mm": [48.0, 56.0],
        "audio": {"file": "shrinkfit_d12_tap.flac", "subtype": "PCM_16", "sample_rate": 48000, "seed": 12,
                  "tap_times_s": (0.2, 0.8, 1.45), "tap_strengths": (0.8, 1.0, 0.6), "snr_db": 34.0,
                  "hum_hz": 60.0},
    },
    {
        "name": "hydraulic_d20",
        "description": "Hydraulic chuck, HSK-A63, Ø20 end mill",
        "asset": "hydraulic_hsk63_d20.toml",
        "params": HolderParams(2.6e9, 1.2e4, 6.5e-3, 5.5e-3, -15.0, 0.98, 0.97),
        "predict_stickouts_mm": None,  # filled from the asset's stick-out: +10 and +20 mm
        "audio": {"file": "hydraulic_d20_tap.wav", "subtype": "PCM_16", "sample_rate": 48000, "seed": 13,
                  "tap_times_s": (0.3, 1.1), "tap_strengths": (1.0, 0.9), "snr_db": 32.0, "hum_hz": 50.0},
    },
]

COMMON = {"contact_s": 50e-6, "radiation_exponent": 2.0, "mic_lp_hz": 20000.0, "mic_hp_hz": 80.0,
          "duration_s": 2.2, "level": 0.45}


def stickouts_of(case: dict, assembly) -> list[float]:
    """The two other stick-outs [mm] the demo predicts at."""
    so = assembly.stickout * 1e3
    return case["predict_stickouts_mm"] or [round(so + 10, 1), round(so + 20, 1)]


def truth_of(case: dict) -> dict:
    """The truth file's content: parameters, true f1–f3 by stick-out, nuisance settings."""
    assembly = load_assembly(REPO / "assets" / case["asset"])
    so = assembly.stickout * 1e3
    audio = {k: v for k, v in case["audio"].items() if k not in ("file", "subtype", "seed")}
    return {
        "synthetic": True,
        "made_by": "scripts/make_recordings.py (taptune model + signal.synth nuisances)",
        "true_params": case["params"].to_dict(),
        "bending_hz_by_stickout": {
            f"{s:g}": [round(f, 1) for f in
                       analyse(assembly.with_stickout(s * 1e-3), case["params"], RECORDING_MESH).bending_hz[:3]]
            for s in [so] + stickouts_of(case, assembly)
        },
        "nuisances": {**COMMON, **audio, "seed": case["audio"]["seed"], "subtype": case["audio"]["subtype"]},
    }


def manifest() -> dict:
    """demo.json: the examples, their files and the stick-outs to predict at."""
    cases = []
    for case in CASES:
        assembly = load_assembly(REPO / "assets" / case["asset"])
        cases.append({"name": case["name"], "description": case["description"], "recording": case["audio"]["file"],
                      "assembly": f"{case['name']}.toml", "truth": f"{case['name']}.truth.json",
                      "predict_stickouts_mm": stickouts_of(case, assembly)})
    return {"cases": cases}


def render(case: dict, path: Path) -> None:
    """Write the case's tap recording to ``path``."""
    assembly = load_assembly(REPO / "assets" / case["asset"])
    audio = dict(case["audio"])
    audio.pop("file")
    subtype, seed = audio.pop("subtype"), audio.pop("seed")
    nuisances = Nuisances(**COMMON, **audio)
    grid = tap_grid(nuisances.sample_rate)
    h = np.zeros(grid.shape, dtype=complex)
    h[1:] = tip_receptance(build_model(assembly, RECORDING_MESH), case["params"], grid[1:])  # undefined at 0 Hz
    rec = synthesize_recording(grid, h, nuisances, np.random.default_rng(seed), extra_modes=HSK_A63_LOCAL_MODES,
                               path=str(path), rigid_body="keep")
    write_audio(str(path), rec.samples, rec.sample_rate, subtype)


def write_all(out: Path) -> list[str]:
    """Write every example file into ``out``; return their names."""
    out.mkdir(parents=True, exist_ok=True)
    names = []
    for case in CASES:
        name = case["audio"]["file"]
        render(case, out / name)
        shutil.copyfile(REPO / "assets" / case["asset"], out / f"{case['name']}.toml")
        truth = truth_of(case)
        (out / f"{case['name']}.truth.json").write_text(json.dumps(truth, indent=1) + "\n")
        names += [name, f"{case['name']}.toml", f"{case['name']}.truth.json"]
        print(f"{name}: {(out / name).stat().st_size / 1024:.0f} kB, truth {truth['bending_hz_by_stickout']}")
    (out / "demo.json").write_text(json.dumps(manifest(), indent=1) + "\n")
    return names + ["demo.json"]


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--out", type=Path, default=REPO / "recordings", help="folder to write (default: recordings/)")
    ap.add_argument("--check", action="store_true", help="render into a temporary folder and compare with recordings/")
    args = ap.parse_args(argv)
    if not args.check:
        write_all(args.out)
        return 0
    with tempfile.TemporaryDirectory() as tmp:
        names = write_all(Path(tmp))
        differ = [n for n in names if not filecmp.cmp(Path(tmp) / n, REPO / "recordings" / n, shallow=False)]
    print("identical to the committed files" if not differ else f"differ from the committed files: {', '.join(differ)}")
    return 1 if differ else 0


if __name__ == "__main__":
    sys.exit(main())
