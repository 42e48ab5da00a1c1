"""Holder library at shop size: bulk import, then one save, one prediction, one search — and concurrency.

Run from the repository root (under ``nice -n 10``; the 100,000-holder run takes minutes)::

    python benchmarks/bench_library.py                       # SQLite 100,000 and PostgreSQL 10,000
    python benchmarks/bench_library.py --sqlite 20000 --postgresql 0

The holders are copies of one real identified holder (``taptune demo``, seed 1: about
9 KB with its 24 near-optimal parameter sets), each under its own name. Steps, each a
command run as its own process (wall time; CPU time and peak memory from GNU time):

1. ``taptune library import all.json`` of one JSON export with every holder (bound 60 s);
2. ``taptune library import one.json`` of one new holder (bound 1 s, 250 MB);
3. ``taptune predict ASSEMBLY --holder NAME`` (bound 1 s, 250 MB);
4. ``taptune library list --match TEXT`` (bound 1 s, 250 MB);
5. 4 processes × 250 saves each into one new library: all 1,000 present, each with its
   history (two identification records);
6. a process saving in a loop, killed with SIGKILL at random moments (seeded), 8 times:
   every save it reported finished is there, and the library opens.

PostgreSQL runs on a throw-away server (``tests/library/pg.py``: initdb in /tmp). The
commands run from compiled bytecode, as an installed taptune does (a cache in the work
folder; ``--compile-each-run`` keeps ``PYTHONDONTWRITEBYTECODE`` and its ≈ 0.1 s per start).
On a busy machine the wall times count the waits for a core: the CPU times are the cost.
"""

from __future__ import annotations

import argparse
import json
import os
import random
import signal
import subprocess
import sys
import tempfile
import time
from dataclasses import replace
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from taptune.library import HolderEntry, HolderLibrary  # noqa: E402
from taptune.library.exchange import holder_json, library_document_head  # noqa: E402
from taptune.library.schema import library_document  # noqa: E402

PY = sys.executable
ENV = {**os.environ, "OPENBLAS_NUM_THREADS": "1", "PYTHONPATH": str(REPO)}
# The commands run as an installed taptune runs: from compiled bytecode (pip compiles it at
# install time), kept in the benchmark's folder (see main), not compiling all of taptune at
# every start as they would where the environment sets PYTHONDONTWRITEBYTECODE (≈ 0.1 s).
BYTECODE = "pycache"
RECORDINGS = REPO / "recordings"


def run_measured(*args: str, expect: int = 0) -> tuple[float, float, float, str]:
    """Run ``python -m taptune ARGS`` under GNU time: (wall s, CPU s (user + system), peak RSS MB, stdout).

    The CPU time is what the command costs on its own; on a busy machine the wall time
    also counts the waits for a core.
    """
    start = time.perf_counter()
    proc = subprocess.run(["/usr/bin/time", "-f", "%U %S %M", PY, "-m", "taptune", *args], cwd=REPO, env=ENV,
                          capture_output=True, text=True)
    wall = time.perf_counter() - start
    if proc.returncode != expect:
        raise SystemExit(f"taptune {' '.join(args)} exited {proc.returncode}: {proc.stderr.strip()}")
    user, system, rss_kb = proc.stderr.strip().splitlines()[-1].split()
    return wall, float(user) + float(system), int(rss_kb) / 1024, proc.stdout


def template(work: Path) -> tuple[HolderEntry, Path]:
    """One real identified holder (``taptune demo``, seed 1) and an assembly file of it."""
    lib = work / "demo.json"
    if not lib.exists():
        run_measured("demo", "--library", str(lib), "--seed", "1")
    entry = next(iter(HolderLibrary(lib).entries().values()))
    case = json.loads((RECORDINGS / "demo.json").read_text())["cases"][0]
    assembly = RECORDINGS / case["assembly"]
    return entry, assembly


def name_of(i: int) -> str:
    kinds = ("ER32 collet chuck HSK-A63 x 100", "shrink fit SK40 x 120", "Weldon HSK-A100 x 80", "hydraulic BT30 x 90")
    return f"{kinds[i % 4]} pocket {i:06d}"


def write_export(path: Path, entry: HolderEntry, count: int) -> None:
    """A library export of ``count`` copies of ``entry`` (streamed, as ``library export`` writes it)."""
    version = library_document({entry.name: entry})["version"]
    with open(path, "w", encoding="utf-8") as f:
        f.write(library_document_head(version))
        for i in range(count):
            f.write((",\n" if i else "\n") + holder_json(name_of(i), replace(entry, name=name_of(i))))
        f.write("\n  }\n}\n")


def bench(kind: str, location: str, entry: HolderEntry, assembly: Path, count: int, work: Path) -> None:
    print(f"\n{kind}: {count:,} holders")
    export = work / f"all-{count}.json"
    if not export.exists():
        t = time.perf_counter()
        write_export(export, entry, count)
        print(f"  wrote the export {export.stat().st_size / 1e6:.0f} MB in {time.perf_counter() - t:.1f} s")
    if HolderLibrary(location).count() >= count:
        print("  import all        (the library holds them already: skipped)")
    else:
        wall, cpu, rss, out = run_measured("library", "import", str(export), "--library", location)
        print(f"  import all        {wall:6.1f} s wall  {cpu:6.1f} s CPU ({cpu / count * 1e3:.2f} ms per holder)  "
              f"{rss:5.0f} MB  (bound 60 s)\n    {out.splitlines()[0]}")
    one = work / "one.json"
    one.unlink(missing_ok=True)
    HolderLibrary(one).put(replace(entry, name="new holder from the presetter"))
    for label, args, expect in (
        ("import one.json", ("library", "import", str(one), "--library", location), 0),
        ("predict --holder", ("predict", str(assembly), "--holder", name_of(count // 2), "--library", location), 0),
        ("predict, JSON library", ("predict", str(assembly), "--holder", entry.name, "--library",
                                   str(work / "demo.json")), 0),
        ("list --match", ("library", "list", "--match", f"pocket {count // 3:06d}"[:-1], "--library", location), 0),
        ("list (first 1000)", ("library", "list", "--library", location), 0),
        ("show NAME", ("library", "show", name_of(7), "--no-predict", "--library", location), 0),
        ("unknown (did you mean)", ("library", "show", name_of(7).replace("pocket", "pokcet"), "--library",
                                    location), 2),
        ("taptune --version", ("--version",), 0),
    ):
        samples = [run_measured(*args, expect=expect) for _ in range(3)]
        walls = sorted(s[0] for s in samples)
        cpus = sorted(s[1] for s in samples)
        rss = max(s[2] for s in samples)
        print(f"  {label:<22} {walls[1]:5.2f} s wall  {cpus[1]:5.2f} s CPU (medians of 3)  {rss:5.0f} MB peak  "
              "(bounds 1 s, 250 MB)")


WORKER = """
import sys
from dataclasses import replace
from taptune.library import HolderLibrary, HolderEntry
import json
location, first, count = sys.argv[1], int(sys.argv[2]), int(sys.argv[3])
entry = HolderEntry.from_dict(json.loads(sys.stdin.read()))
lib = HolderLibrary(location, lock_timeout=60)
for i in range(first, first + count):
    name = f"concurrent {i:05d}"
    record = entry.identifications[0]
    second = replace(record, sha256=f"{i:064x}", recording=f"tap{i}.wav")
    lib.put(replace(entry, name=name, identifications=(record, second)))
    print(name, flush=True)
"""


def concurrency(kind: str, location: str, entry: HolderEntry, workers: int = 4, saves: int = 250) -> None:
    doc = json.dumps(entry.to_dict())
    t = time.perf_counter()
    procs = [subprocess.Popen([PY, "-c", WORKER, location, str(w * saves), str(saves)], cwd=REPO, env=ENV,
                              stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True) for w in range(workers)]
    for p in procs:
        p.stdin.write(doc)
        p.stdin.close()
    for p in procs:
        p.wait()
    wall = time.perf_counter() - t
    lib = HolderLibrary(location)
    names = [f"concurrent {i:05d}" for i in range(workers * saves)]
    complete = sum(len(e.identifications) == 2 for e in lib.page(match="concurrent ").values())
    present = sum(n in lib for n in names)
    print(f"  {workers} processes x {saves} saves: {present} of {workers * saves} present, {complete} with both "
          f"identification records, {wall:.1f} s ({workers * saves / wall:.0f} saves/s)")
    lib.close()


def kill_test(kind: str, location: str, entry: HolderEntry, kills: int = 8, seed: int = 7) -> None:
    rng = random.Random(seed)
    doc = json.dumps(entry.to_dict())
    acknowledged: list[str] = []
    for k in range(kills):
        p = subprocess.Popen([PY, "-c", WORKER, location, str(10000 + k * 1000), "1000"], cwd=REPO, env=ENV,
                             stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True)
        p.stdin.write(doc)
        p.stdin.close()
        time.sleep(rng.uniform(1.0, 2.5))  # start-up is ~0.5 s; then it saves
        os.kill(p.pid, signal.SIGKILL)
        out = p.stdout.read()
        p.wait()
        acknowledged += out.split("\n")[:-1] if not out.endswith("\n") else out.splitlines()
    lib = HolderLibrary(location)
    missing = [n for n in acknowledged if n not in lib]
    total = lib.count()
    print(f"  kill -9 x {kills}: {len(acknowledged)} saves reported finished, {len(missing)} of them missing; "
          f"library opens with {total} holders")
    lib.close()


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sqlite", type=int, default=100_000, help="holders on SQLite (0 skips)")
    parser.add_argument("--postgresql", type=int, default=10_000, help="holders on PostgreSQL (0 skips)")
    parser.add_argument("--work", help="folder for the files (default: a temporary one)")
    parser.add_argument("--keep", action="store_true", help="reuse a filled SQLite library of --work (skip its import)")
    parser.add_argument("--no-concurrency", action="store_true", help="skip the concurrency and kill -9 runs")
    parser.add_argument("--compile-each-run", action="store_true",
                        help="run the commands without a bytecode cache when PYTHONDONTWRITEBYTECODE is set")
    args = parser.parse_args()
    work = Path(args.work or tempfile.mkdtemp(prefix="taptune-bench-library-"))
    work.mkdir(parents=True, exist_ok=True)
    if not args.compile_each_run:
        ENV.pop("PYTHONDONTWRITEBYTECODE", None)
        ENV["PYTHONPYCACHEPREFIX"] = str(work / BYTECODE)
        run_measured("--version")  # compiles what the first command would otherwise compile
    entry, assembly = template(work)
    print(f"template holder {entry.name!r}: {len(json.dumps(entry.to_dict(), indent=2)) / 1e3:.1f} KB, "
          f"{len(entry.param_sets)} parameter sets; files in {work}; bytecode "
          f"{'compiled at every run' if 'PYTHONDONTWRITEBYTECODE' in ENV else 'cached, as installed'}")
    if args.sqlite:
        db = work / f"bench-{args.sqlite}.db"
        if not args.keep:
            for f in (db, Path(f"{db}-wal"), Path(f"{db}-shm")):
                f.unlink(missing_ok=True)
        bench("SQLite", str(db), entry, assembly, args.sqlite, work)
        conc = work / "concurrent.db"
        for f in (conc, Path(f"{conc}-wal"), Path(f"{conc}-shm")):
            f.unlink(missing_ok=True)
        if not args.no_concurrency:
            concurrency("SQLite", str(conc), entry)
            kill_test("SQLite", str(conc), entry)
    if args.postgresql:
        from tests.library.pg import fresh_database, start_server

        server_gen = start_server()
        server = next(server_gen)
        try:
            bench("PostgreSQL", server.url(fresh_database(server)), entry, assembly, args.postgresql, work)
            url = server.url(fresh_database(server))
            if not args.no_concurrency:
                concurrency("PostgreSQL", url, entry)
                kill_test("PostgreSQL", url, entry)
        finally:
            next(server_gen, None)


if __name__ == "__main__":
    main()
