"""Make the bundled example recordings in recordings/ (synthetic, from the model).

Each example is a tool-holder assembly from assets/ with known ("true") holder
parameters, rendered as a tap recording by taptune.synthetic: the model's tool-tip
receptance, a half-sine tap force, radiation, microphone roll-off, a reflection, mains
hum, noise, and the HSK-A63 interface's local modes. Next to each recording: its
assembly file, and a truth file with the parameters and the true bending frequencies
at the recorded and at two other stick-outs (what the demo compares its predictions
with).

Run: ``python scripts/make_recordings.py`` (deterministic; rewrites recordings/).
"""

from __future__ import annotations

import json
import os
import shutil
import sys
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from taptune.io.assembly import load_assembly  # noqa: E402
from taptune.model import analyse  # noqa: E402
from taptune.model.params import HolderParams  # noqa: E402
from taptune.synthetic import write_tap_recording  # noqa: E402

CASES = [
    {
        "name": "er32_d16",
        "description": "ER32 collet chuck, HSK-A63, Ø16 end mill at 53.5 mm (the MODEL.md §13.4 reference)",
        "asset": "er32_hsk63_d16.toml",
        # Published holder A (CIRP JMST 2022), as in MODEL.md §13.4.
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


def main() -> None:
    out = REPO / "recordings"
    out.mkdir(exist_ok=True)
    manifest = []
    for case in CASES:
        asset = REPO / "assets" / case["asset"]
        assembly = load_assembly(asset)
        so = assembly.stickout * 1e3
        stickouts = case["predict_stickouts_mm"] or [round(so + 10, 1), round(so + 20, 1)]
        audio = dict(case["audio"])
        name, subtype, seed = audio.pop("file"), audio.pop("subtype"), audio.pop("seed")
        write_tap_recording(out / name, assembly, case["params"], seed=seed, subtype=subtype, **COMMON, **audio)
        toml = out / f"{case['name']}.toml"
        shutil.copyfile(asset, toml)
        truth = {
            "synthetic": True,
            "made_by": "scripts/make_recordings.py (taptune model + signal.synth nuisances)",
            "true_params": case["params"].to_dict(),
            "bending_hz_by_stickout": {
                f"{s:g}": [round(f, 1) for f in analyse(assembly.with_stickout(s * 1e-3), case["params"]).bending_hz[:3]]
                for s in [so] + stickouts
            },
            "nuisances": {**COMMON, **{k: v for k, v in audio.items()}, "seed": seed, "subtype": subtype},
        }
        (out / f"{case['name']}.truth.json").write_text(json.dumps(truth, indent=1) + "\n")
        manifest.append({"name": case["name"], "description": case["description"], "recording": name,
                         "assembly": toml.name, "truth": f"{case['name']}.truth.json", "predict_stickouts_mm": stickouts})
        print(f"{name}: {(out / name).stat().st_size / 1024:.0f} kB, truth {truth['bending_hz_by_stickout']}")
    (out / "demo.json").write_text(json.dumps({"cases": manifest}, indent=1) + "\n")


if __name__ == "__main__":
    main()
