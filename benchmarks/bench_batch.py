"""Batch throughput: recordings identified per minute with --jobs 1 and --jobs 2.

Writes N synthetic recordings (taptune.synthetic; reference assembly, nominal holder,
stick-outs 45–60 mm, 8 holder names) into a temporary folder and runs
``python -m taptune batch`` on them once per --jobs value (repeat a value to run it
again), each with a fresh output folder and library. The wall time includes process start, analysis, the fits, library
writes and summary.csv.

    OPENBLAS_NUM_THREADS=1 python benchmarks/bench_batch.py [--count 50] [--jobs 1 2]
        [--population 64 --generations 90] [--machine]

With ``--machine`` every run also puts each identified holder on the example machine
(recordings/machine/machine.toml; 4 teeth, al6082, ae 4 mm down-milling), and the extra
CPU of that part per recording is measured on its own, in this process
(``time.process_time`` around the tool-point FRF, the lobes and the lobes CSV).

On a shared machine the wall-clock numbers move with the other load (the load average
before each run is printed); the CPU seconds per recording do not, much.
"""

from __future__ import annotations

import argparse
import os
import resource
import subprocess
import sys
import tempfile
import time
import tomllib
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))
ASSEMBLY = REPO / "recordings" / "er32_d16.toml"
MACHINE = REPO / "recordings" / "machine" / "machine.toml"
CUT = ["--teeth", "4", "--material", "al6082", "--ae", "4", "--milling", "down"]


def write_recordings(folder: Path, count: int) -> None:
    """``count`` recordings, each with its own assembly TOML (8 holder names, 6 stick-outs)."""
    from taptune.io.assembly import assembly_to_toml, parse_assembly
    from taptune.model import NOMINAL
    from taptune.synthetic import write_tap_recording

    text = ASSEMBLY.read_text()
    for i in range(count):
        holder = f"ER32 bench {i % 8}"
        data = tomllib.loads(text)
        data["holder"]["name"] = holder
        data["setup"]["stickout"] = 45.0 + 3.0 * (i % 6)
        asm = parse_assembly(data, f"r{i:03d}.toml")
        (folder / f"r{i:03d}.toml").write_text(assembly_to_toml(asm))
        write_tap_recording(folder / f"r{i:03d}.wav", asm, NOMINAL, seed=i, sample_rate=96000)


def run_batch(folder: Path, out: Path, jobs: int, budget: list[str]) -> tuple[float, float, int, str]:
    """(wall seconds, CPU seconds of the batch and its workers, exit status, last lines of output) of one run."""
    env = dict(os.environ, OPENBLAS_NUM_THREADS="1", PYTHONPATH=str(REPO))
    cmd = [sys.executable, "-m", "taptune", "batch", str(folder), "--out", str(out),
           "--library", str(out / "lib.json"), "--jobs", str(jobs), *budget]
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    proc = subprocess.run(cmd, capture_output=True, text=True, env=env)
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return wall, cpu, proc.returncode, "\n".join(proc.stdout.splitlines()[-5:])


def machine_cpu_per_recording(folder: Path, count: int) -> float:
    """CPU seconds of the batch's machine part (tool point, lobes, CSV) per recording, nominal holder."""
    from taptune.batch.on_machine import machine_part
    from taptune.cli.cmd_batch import add_parser, machine_setup
    from taptune.io.assembly import load_assembly
    from taptune.model import NOMINAL

    sub = argparse.ArgumentParser().add_subparsers()
    args = add_parser(sub, "batch", "").parse_args([str(folder), "--machine", str(MACHINE), *CUT])
    setup = machine_setup(args)
    assemblies = [load_assembly(folder / f"r{i:03d}.toml") for i in range(count)]
    t0 = time.process_time()
    for i, asm in enumerate(assemblies):
        part = machine_part(NOMINAL, None, asm, setup, folder / f"machine{i:03d}.json")
        assert not part.error, part.error
    return (time.process_time() - t0) / count


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--count", type=int, default=50)
    ap.add_argument("--jobs", type=int, nargs="+", default=[1, 2])
    ap.add_argument("--population", type=int, default=None, help="GA population (default: the library default)")
    ap.add_argument("--generations", type=int, default=None, help="GA generations (default: the library default)")
    ap.add_argument("--machine", action="store_true", help="put each holder on the example machine too")
    args = ap.parse_args(argv)
    budget = CUT + ["--machine", str(MACHINE)] if args.machine else []
    if args.population:
        budget += ["--population", str(args.population)]
    if args.generations:
        budget += ["--generations", str(args.generations)]

    with tempfile.TemporaryDirectory() as tmp:
        work = Path(tmp)
        folder = work / "recordings"
        folder.mkdir()
        t0 = time.perf_counter()
        write_recordings(folder, args.count)
        print(f"{args.count} recordings written in {time.perf_counter() - t0:.1f} s; "
              f"budget: {' '.join(budget) or 'library defaults'}; {os.cpu_count()} CPUs\n")
        print(f"{'jobs':>4}  {'wall [s]':>9}  {'recordings/min':>15}  {'CPU [s]':>8}  {'CPU s/recording':>15}  "
              f"{'load before':>11}  {'exit':>4}")
        for run, jobs in enumerate(args.jobs):
            load = os.getloadavg()[0]
            seconds, cpu, code, tail = run_batch(folder, work / f"run{run}", jobs, budget)  # fresh: nothing skipped
            print(f"{jobs:>4}  {seconds:9.1f}  {60 * args.count / seconds:15.1f}  {cpu:8.1f}  "
                  f"{cpu / args.count:15.2f}  {load:11.1f}  {code:>4}", flush=True)
            if code != 0:
                print(tail)
        if args.machine:
            n = min(args.count, 8)
            print(f"\nmachine part alone: {machine_cpu_per_recording(folder, n):.3f} CPU-s per recording "
                  f"(mean of {n}, in-process)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
