"""Evaluations, wall and CPU seconds of one identification, and prediction accuracy where truth is known.

Runs ``identify`` (analysis + evaluator build + GA islands + polishes + near-optimal set
+ full-model check) on the bundled example recordings and, when ``../shared/cases-dev``
is present, on the development cases, then predicts their other stick-outs and compares
with the truth. Per case it prints the model evaluations, the wall time, the CPU time
(this process and its worker processes), the fit error, the prediction errors, how many
truths lie inside the reported ± band and the band's mean half-width (the near-optimal
set's spread). The load average is printed with the wall times: the machine may be shared.

With ``--app`` it times instead, in the offscreen app, the click on Identify to the fitted
view: with one process, then with the app's warm process pool.

With ``--cli`` it times ``taptune identify`` as the user runs it, one process per tap
(imports, analysis, fit, outlook, library and JSON writes): first with no reduced model in
the disk cache (a new assembly), then again (the assembly tapped before).

The in-process figures are measured cold: the disk cache is off, each repeat builds its
evaluator, as for an assembly never tapped before.

With ``--split`` the analysis (model-guided labels, which build the reduced evaluator),
the fit (search, near-optimal set, full-model check) and the transfer outlook the JSON
record adds after it (a prediction 20 mm further out with its band) are timed apart.

Run: ``python benchmarks/bench_identify.py [--jobs N] [--seed N] [--repeat N] [--profile] [--app] [--cli] [--split]``.
"""

from __future__ import annotations

import argparse
import itertools
import json
import os
import resource
import sys
import time
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ["TAPTUNE_CACHE_DIR"] = "off"  # cold: every identification builds its evaluator (--cli sets its own)
REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

import numpy as np  # noqa: E402

from taptune.identify import IdentifyOptions, predict  # noqa: E402
from taptune.identify import identify  # noqa: E402
from taptune.identify.bands import clear_caches as clear_sensitivities  # noqa: E402
from taptune.identify.pipeline import analyse_for_assembly, identify_recordings, transfer_outlook  # noqa: E402
from taptune.model.fe import mesh_frequency_hz  # noqa: E402
from taptune.model.reduced import cached_evaluator  # noqa: E402
from taptune.io.assembly import load_assembly  # noqa: E402
from taptune.io.audio import read_audio  # noqa: E402


def cases():
    """(name, wav, assembly, {stickout_mm: (truth f1-f3, assembly file or None)})."""
    demo = json.loads((REPO / "recordings" / "demo.json").read_text())
    for c in demo["cases"]:
        truth = json.loads((REPO / "recordings" / c["truth"]).read_text())["bending_hz_by_stickout"]
        yield (c["name"], REPO / "recordings" / c["recording"], REPO / "recordings" / c["assembly"],
               {float(s): (truth[f"{s:g}"], None) for s in c["predict_stickouts_mm"]})
    dev = REPO.parent / "shared" / "cases-dev"
    for d in sorted(dev.glob("d*")) if dev.is_dir() else []:
        truth = json.loads((d / "truth.json").read_text())
        other = {float(k): (v["bending_hz"], d / v["assembly_file"]) for k, v in truth["other_stickouts"].items()}
        yield (f"dev {d.name}", d / "tap.wav", d / "assembly.toml", other)


def cpu_seconds() -> float:
    """CPU time of this process and of its finished (joined) worker processes [s]."""
    own = resource.getrusage(resource.RUSAGE_SELF)
    kids = resource.getrusage(resource.RUSAGE_CHILDREN)
    return own.ru_utime + own.ru_stime + kids.ru_utime + kids.ru_stime


def app_figures(n_cases: int | None = None, jobs_list=(1, None)) -> None:
    """Click-to-fitted-view wall time in the (offscreen) app: one process, then the warm pool.

    Per case the first identification builds the evaluator; the second, as after the next
    tap on the same assembly, reuses it.
    """
    os.environ.setdefault("QT_QPA_PLATFORM", "offscreen")
    from PySide6.QtCore import QEventLoop, QTimer

    from taptune.gui.app import application, start_process_pool, stop_process_pool, wait_for
    from taptune.gui.main_window import MainWindow
    from taptune.model.reduced import cached_evaluator

    app = application()
    library = Path(os.environ.get("TMPDIR", "/tmp")) / f"bench-app-{os.getpid()}.json"
    for jobs in jobs_list:
        pool = start_process_pool() if jobs is None else None
        if pool is not None:
            pool.warming.wait(60)  # the app starts its workers with the window
        options = IdentifyOptions(seed=0, jobs=pool.processes if pool else 1)
        label = f"pool of {pool.processes}" if pool else "one process"
        for name, wav, toml, _ in itertools.islice(cases(), n_cases):
            cached_evaluator.cache_clear()
            window = MainWindow(library, identify_options=options, devices=lambda: [])
            window.show()
            window.load_recording(str(wav), str(toml))
            wait_for(window.analysis_ready, 120)
            times = []
            for _ in range(2):
                t0 = time.perf_counter()
                window.start_identification()
                ended = wait_for(window.identification_ended, 300)
                loop = QEventLoop()
                QTimer.singleShot(0, loop.quit)  # let the fitted view paint
                loop.exec()
                times.append(time.perf_counter() - t0)
                assert ended and ended[0] == "finished", ended
            print(f"app, {label:12s} {name:16s} click to fitted view: {times[0]:.2f} s, again {times[1]:.2f} s "
                  f"(load {os.getloadavg()[0]:.1f})", flush=True)
            window.close()
        if pool is not None:
            stop_process_pool()
    del app


def cli_figures(n_cases: int | None = None, repeat: int = 1) -> None:
    """Wall time of ``taptune identify`` (a fresh process per tap), cold then warm disk cache."""
    import subprocess
    import tempfile

    print(f"load average at start: {os.getloadavg()[0]:.2f} (cores: {os.cpu_count()})")
    cold, warm = [], []
    with tempfile.TemporaryDirectory(prefix="bench-cli-") as tmp:
        for name, wav, toml, _ in itertools.islice(cases(), n_cases):
            row = []
            for r in range(repeat):
                env = dict(os.environ, OPENBLAS_NUM_THREADS="1", TAPTUNE_CACHE_DIR=str(Path(tmp) / f"cache-{len(cold)}"))
                argv = [sys.executable, "-m", "taptune", "identify", str(wav), "--assembly", str(toml),
                        "--library", str(Path(tmp) / "holders.json"), "--json", str(Path(tmp) / "out.json")]
                for times in (cold, warm):  # the first run fills the empty cache folder
                    t0 = time.perf_counter()
                    subprocess.run(argv, env=env, check=True, stdout=subprocess.DEVNULL)
                    times.append(time.perf_counter() - t0)
                    row.append(times[-1])
            print(f"taptune identify {name:16s} cold {' '.join(f'{t:.2f}' for t in row[::2])} s, "
                  f"warm {' '.join(f'{t:.2f}' for t in row[1::2])} s (load {os.getloadavg()[0]:.1f})", flush=True)
    print(f"\ntaptune identify wall time over {len(cold)} runs: cold (new assembly) median {np.median(cold):.2f} s, "
          f"max {max(cold):.2f} s; warm (assembly tapped before) median {np.median(warm):.2f} s, max {max(warm):.2f} s")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--jobs", type=int, default=None)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--repeat", type=int, default=1)
    ap.add_argument("--profile", action="store_true", help="cProfile the identifications (use with --jobs 1)")
    ap.add_argument("--app", action="store_true", help="time click-to-fitted-view in the offscreen app instead")
    ap.add_argument("--cli", action="store_true", help="time taptune identify, one process per tap, instead")
    ap.add_argument("--cases", type=int, default=None, help="only the first N cases")
    ap.add_argument("--split", action="store_true",
                    help="time the analysis (labels, evaluator build) and the fit apart")
    args = ap.parse_args()
    if args.app:
        app_figures(args.cases)
        return
    if args.cli:
        cli_figures(args.cases, args.repeat)
        return
    profiler = None
    if args.profile:
        import cProfile

        profiler = cProfile.Profile()
    print(f"load average at start: {os.getloadavg()[0]:.2f} (cores: {os.cpu_count()})")
    print(f"{'case':16s} {'evals':>6s} {'wall [s]':>8s} {'CPU [s]':>7s} {'fit err [%]':>11s} "
          f"{'pred err [%] f1 f2 f3 per stick-out':>40s} {'inside':>6s} {'± [%]':>6s}")
    walls, cpus, errors, inside, widths, splits = [], [], [], [], [], []
    for name, wav, toml, other in itertools.islice(cases(), args.cases):
        asm = load_assembly(toml)
        rec = read_audio(wav)
        times, cpu, split = [], [], []
        for _ in range(args.repeat):
            # Each run builds its evaluator, meshes and solves its outlook's sensitivities, as a
            # fresh CLI run does (a repeat reusing them would hide their cost in the minimum).
            cached_evaluator.cache_clear()
            mesh_frequency_hz.cache_clear()
            clear_sensitivities()
            t0, c0 = time.perf_counter(), cpu_seconds()
            if profiler:
                profiler.enable()
            options = IdentifyOptions(seed=args.seed, jobs=args.jobs)
            if args.split:
                # The same steps as identify_recordings, timed apart.
                analysis = analyse_for_assembly(rec, asm, None, options.model)
                t1, c1 = time.perf_counter(), cpu_seconds()
                result = identify([analysis], [asm], options)
                t2, c2 = time.perf_counter(), cpu_seconds()
                transfer_outlook(result, [asm])
                split.append((t1 - t0, c1 - c0, t2 - t1, c2 - c1, time.perf_counter() - t2, cpu_seconds() - c2))
            else:
                analyses, result = identify_recordings([rec], [asm], options)
                t2, c2 = time.perf_counter(), cpu_seconds()
            if profiler:
                profiler.disable()
            times.append(t2 - t0)  # the identification (the outlook is timed apart)
            cpu.append(c2 - c0)
        walls.append(min(times))
        cpus.append(min(cpu))
        meas = np.array([np.nan if f is None else f for f in result.bending_measured_hz[0]])
        fit_err = np.nanmax(np.abs(np.array(result.bending_model_hz[0]) / meas - 1)) * 100
        texts, case_inside, case_width = [], [], []
        for so, (truth, path) in sorted(other.items()):
            target = load_assembly(path) if path else asm.with_stickout(so * 1e-3)
            p = predict(result.param_sets, target)
            e = (np.array(p.bending_hz) / np.array(truth) - 1) * 100
            errors.extend(np.abs(e))
            case_inside.extend(np.abs(np.array(p.bending_hz) - truth) <= np.array(p.bending_hz_spread))
            case_width.extend(np.array(p.bending_hz_spread) / np.array(p.bending_hz) * 100)
            texts.append(" ".join(f"{x:+.2f}" for x in e))
        inside.extend(case_inside)
        widths.extend(case_width)
        print(f"{name:16s} {result.evaluations:6d} {walls[-1]:8.2f} {cpus[-1]:7.2f} {fit_err:11.3f} "
              f"{' | '.join(texts):>40s} {np.mean(case_inside):6.0%} {np.mean(case_width):6.3f}", flush=True)
        if split:
            best = min(split, key=lambda x: x[0] + x[2] + x[4])
            splits.append(best)
            print(f"{'':16s} analysis (labels, evaluator build) {best[0]:.2f} s wall, {best[1]:.2f} s CPU; "
                  f"fit (search, set, full-model check) {best[2]:.2f} s wall, {best[3]:.2f} s CPU; "
                  f"outlook {best[4]:.2f} s wall, {best[5]:.2f} s CPU")
    errors = np.array(errors)
    if splits:
        a = np.median(np.array(splits), axis=0)
        print(f"\nmedian analysis {a[0]:.2f} s wall / {a[1]:.2f} s CPU, fit {a[2]:.2f} s wall / {a[3]:.2f} s CPU, "
              f"outlook {a[4]:.2f} s wall / {a[5]:.2f} s CPU")
    print(f"\nidentification wall time: median {np.median(walls):.2f} s, max {max(walls):.2f} s "
          f"(jobs={args.jobs or 'all cores'}; load average now {os.getloadavg()[0]:.2f}); "
          f"CPU time: median {np.median(cpus):.2f} s, max {max(cpus):.2f} s")
    print(f"prediction error over {len(errors)} frequencies: median {np.median(errors):.3f} %, max {errors.max():.3f} %; "
          f"truth inside the reported ± band: {np.mean(inside):.0%}; band half-width: mean {np.mean(widths):.3f} %")
    if profiler:
        import pstats

        pstats.Stats(profiler).sort_stats("cumulative").print_stats(45)


if __name__ == "__main__":
    main()
