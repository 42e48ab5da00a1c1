"""``taptune demo``: tap → holder → predictions at two other stick-outs, on bundled data.

The example recordings that ship with taptune (:mod:`taptune.examples`; the repository's
``recordings/``) are synthetic (made by ``scripts/make_recordings.py`` from the model plus
workshop nuisances); each has a
``.truth.json`` with the parameters it was made from, so the demo can show how close
the predictions come.
"""

from __future__ import annotations

import json
import sys
import tempfile
import time
from pathlib import Path


def add_parser(sub, name, help_text):
    p = sub.add_parser(name, help=help_text, description=(
        "Identify the holder of a bundled example recording, store it in a library (a temporary one "
        "unless --library is given) and predict the same holder at two other stick-outs."))
    p.add_argument("--recordings", metavar="DIR", help="folder with demo.json (default: the example recordings that ship with taptune; "
                        "'taptune examples DIR' copies them out)")
    p.add_argument("--case", metavar="NAME", help="run only this example (default: the first)")
    p.add_argument("--all", action="store_true", help="run every example")
    p.add_argument("--library", metavar="PATH", help="keep the identified holders in this library")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--json", metavar="OUT", help="write the results as JSON")
    return p


def bundled_recordings() -> Path:
    """The example recordings that ship with taptune (package data; the clone's recordings/)."""
    from taptune.examples import recordings_dir

    return recordings_dir()


def _read_json(path: Path, what: str):
    from taptune.errors import InputError
    from taptune.io.files import read_text

    try:
        return json.loads(read_text(path, what, "JSON"))
    except json.JSONDecodeError as err:
        raise InputError(f"{path}: not valid JSON ({err.msg} at line {err.lineno})") from None


def load_manifest(folder: Path) -> list[dict]:
    """The examples of ``folder/demo.json``, checked: recording, assembly, stick-outs [mm]."""
    from taptune.errors import InputError

    path = folder / "demo.json"
    if not path.exists():
        raise InputError(f"{path}: no such file (--recordings needs a folder with demo.json, such as the "
                         "recordings/ that 'taptune examples DIR' copies out)")
    data = _read_json(path, "a demo manifest")
    cases = data.get("cases") if isinstance(data, dict) else None
    if not isinstance(cases, list) or not cases:
        raise InputError(f"{path}: not a demo manifest (needs a non-empty list 'cases')")
    for i, c in enumerate(cases):
        ok = isinstance(c, dict) and all(isinstance(c.get(k), str) for k in ("recording", "assembly"))
        stickouts = c.get("predict_stickouts_mm") if isinstance(c, dict) else None
        ok = ok and isinstance(stickouts, list) and all(
            isinstance(s, (int, float)) and not isinstance(s, bool) for s in stickouts)
        if not ok:
            raise InputError(f"{path}: cases[{i}] needs 'recording', 'assembly' and a list 'predict_stickouts_mm' of numbers")
    return cases


def run(args) -> int:
    from taptune.cli.cmd_identify import run_identification
    from taptune.cli.cmd_predict import predict_stickouts
    from taptune.cli.common import ProgressBar, command_inputs, format_table, output_path, write_json
    from taptune.errors import InputError
    from taptune.io.assembly import load_assembly
    from taptune.io.audio import read_audio
    from taptune.library.record import save_identification
    from taptune.library.store import HolderLibrary

    from taptune.cli.common import check_seed_and_jobs

    check_seed_and_jobs(args)
    output_path(args.json, "JSON", library=args.library, inputs=command_inputs(args))  # now, not after the identifications
    folder = Path(args.recordings) if args.recordings else bundled_recordings()
    cases = load_manifest(folder)
    if args.case:
        cases = [c for c in cases if c.get("name") == args.case]
        if not cases:
            raise InputError(f"{folder / 'demo.json'}: no example named {args.case!r}")
    elif not args.all:
        cases = cases[:1]

    with tempfile.TemporaryDirectory(prefix="taptune-demo-") as tmp:
        library_path = args.library or str(Path(tmp) / "holders.json")
        results = []
        for case in cases:
            wav, toml = folder / case["recording"], folder / case["assembly"]
            assembly = load_assembly(toml)
            recording = read_audio(wav)
            truth = _truth(folder, case)
            print(f"== {case.get('name', wav.stem)}: {case.get('description', '')}")
            print(f"tap recording  {wav.name}  ({recording.sample_rate} Hz, {recording.samples.shape[0] / recording.sample_rate:.1f} s)")
            print(f"assembly       {assembly.holder.name}\n               {assembly.tool.name}, stick-out {assembly.stickout * 1e3:g} mm")
            bar = ProgressBar("identify")
            started = time.perf_counter()  # what the user waits: the analysis and the fit
            try:
                analyses, result = run_identification([recording], [assembly], seed=args.seed, progress=bar)
            finally:
                bar.close()
            waited = time.perf_counter() - started
            name = save_identification(library_path, result, [recording], [assembly])
            meas, model = result.bending_measured_hz[0], result.bending_model_hz[0]
            print(f"\nidentified in {waited:.1f} s ({result.evaluations} model evaluations); "
                  f"holder '{name}' stored in {'the library' if args.library else 'a temporary library'}")
            print("measured  " + "  ".join("—" if m is None else f"{m:8.1f}" for m in meas) + "  Hz")
            print("model     " + "  ".join(f"{f:8.1f}" for f in model) + "  Hz")
            entry = HolderLibrary(library_path).get(name)
            stickouts = [assembly.stickout * 1e3] + list(case["predict_stickouts_mm"])
            predictions, _ = predict_stickouts(entry, assembly, stickouts)
            rows = []
            for p in predictions:
                row = [f"{p.stickout_mm:g}"] + [f"{f:.0f} ± {s:.0f}" for f, s in zip(p.bending_hz, p.bending_hz_spread)]
                t = truth.get(f"{p.stickout_mm:g}")
                row.append("  ".join(f"{x:.0f}" for x in t) if t else "—")
                rows.append(row)
            print("\npredicted free-free bending modes of this holder with this tool:")
            print(format_table(rows, ["stick-out [mm]", "f1 [Hz]", "f2 [Hz]", "f3 [Hz]", "truth f1 f2 f3 [Hz] (synthetic)"]))
            # The recording's own warnings (a faint peak, a codec's low-pass) first, as identify prints them.
            for w in dict.fromkeys([w for a in analyses for w in a.warnings] + list(result.warnings)):
                print(f"warning: {w}", file=sys.stderr)
            print()
            results.append({"case": case.get("name"), "identification": result.to_dict(),
                            "predictions": [p.to_dict() for p in predictions]})
        write_json({"results": results}, args.json)
    return 0


def _truth(folder: Path, case: dict) -> dict:
    """True f1–f3 by stick-out ("53.5" → [f1, f2, f3]) from the case's truth file, if any."""
    from taptune.errors import InputError

    if not case.get("truth"):
        return {}
    path = folder / case["truth"]
    data = _read_json(path, "a truth file")
    table = data.get("bending_hz_by_stickout", {}) if isinstance(data, dict) else None
    try:
        return {f"{float(k):g}": [float(f) for f in v] for k, v in table.items()}
    except (AttributeError, TypeError, ValueError):
        raise InputError(f"{path}: bending_hz_by_stickout must map stick-outs to [f1, f2, f3]") from None
