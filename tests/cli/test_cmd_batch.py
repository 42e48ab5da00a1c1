"""``taptune batch``: a folder with good, corrupt and unmatched recordings; reruns; concurrency.

Recordings are synthesised from the model (tests/test_batch.py); the optimiser budget is
tiny (hidden --population/--generations/--polish-evaluations), so these runs check the
batch behaviour, not the quality of the fit.
"""

from __future__ import annotations

import json
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

from tests.test_batch import assembly_text, write_bad_files, write_case

from taptune.batch import read_summary
from taptune.cli import main
from taptune.library import HolderLibrary

REPO = Path(__file__).resolve().parents[2]
BUDGET = ["--population", "8", "--generations", "2", "--polish-evaluations", "20"]
GOOD = {"a/one": "ER32 alpha", "a/two": "Shrink beta", "b/three": "Weldon gamma"}


def run_cli(args, capsys):
    code = main(["batch", *map(str, args)])
    out, err = capsys.readouterr()
    return code, out, err


def failed_list(stdout: str) -> list[str]:
    """The file names of the final 'N files failed:' list."""
    lines = stdout.split("files failed:\n", 1)[-1].splitlines() if "failed:\n" in stdout else []
    return sorted(Path(line.strip().split(": ", 1)[0]).name for line in lines if line.startswith("  "))


@pytest.fixture(scope="module")
def folder(tmp_path_factory):
    root = tmp_path_factory.mktemp("recordings")
    for i, (stem, holder) in enumerate(GOOD.items()):
        write_case(root / Path(stem).parent, Path(stem).name, holder, stickout_mm=50.0 + 3 * i, seed=i)
    write_bad_files(root / "bad")
    return root


def test_bad_files_are_listed_and_never_stop_the_batch_then_a_rerun_skips_and_force_redoes(folder, tmp_path, capsys):
    out, lib = tmp_path / "out", tmp_path / "lib.json"
    args = [folder, "--out", out, "--library", lib, "--jobs", "2", *BUDGET]

    code, stdout, stderr = run_cli(args, capsys)
    assert code == 1
    assert "Traceback" not in stdout + stderr
    assert failed_list(stdout) == ["lonely.wav", "notes.wav", "truncated.wav"]
    rows = {Path(r["file"]).name: r for r in read_summary(out / "summary.csv")}
    assert {n: r["status"] for n, r in rows.items()} == {
        "one.wav": "ok", "two.wav": "ok", "three.wav": "ok",
        "truncated.wav": "failed", "notes.wav": "failed", "lonely.wav": "failed",
    }
    assert "notes.wav" in rows["notes.wav"]["message"] and "\n" not in rows["notes.wav"]["message"]
    assert "no assembly" in rows["lonely.wav"]["message"]
    assert rows["one.wav"]["holder"] == "ER32 alpha"
    for name in ("one", "two", "three"):
        assert float(rows[f"{name}.wav"]["f1_model_hz"]) > 1000
        assert float(rows[f"{name}.wav"]["f1_measured_hz"]) > 1000
    assert HolderLibrary(lib).names() == sorted(GOOD.values())

    # One JSON per good recording, with the keys of `taptune identify --json`.
    doc = json.loads((out / "a" / "one.json").read_text())
    for key in ("file", "holder", "sample_rate", "taps", "peaks", "bending_measured_hz", "bending_model_hz",
                "params", "objective", "evaluations", "seconds", "warnings"):
        assert key in doc
    assert doc["file"] == str(folder / "a" / "one.wav") and len(doc["sha256"]) == 64
    assert not (out / "bad" / "notes.json").exists()

    code, stdout, _ = run_cli(args, capsys)
    assert code == 1  # the bad files are still bad
    statuses = {Path(r["file"]).name: r["status"] for r in read_summary(out / "summary.csv")}
    assert [statuses[f"{n}.wav"] for n in ("one", "two", "three")] == ["skipped"] * 3
    assert failed_list(stdout) == ["lonely.wav", "notes.wav", "truncated.wav"]

    code, _, _ = run_cli([*args, "--force"], capsys)
    assert code == 1
    statuses = {Path(r["file"]).name: r["status"] for r in read_summary(out / "summary.csv")}
    assert [statuses[f"{n}.wav"] for n in ("one", "two", "three")] == ["ok"] * 3
    history = HolderLibrary(lib).get("ER32 alpha").identifications
    assert [r.recording for r in history] == ["one.wav", "one.wav"]


def test_the_library_alone_is_enough_to_skip(folder, tmp_path, capsys):
    lib = tmp_path / "lib.json"
    good = [folder / "a" / "one.wav"]
    assert run_cli([*good, "--out", tmp_path / "first", "--library", lib, *BUDGET], capsys)[0] == 0
    code, stdout, _ = run_cli([*good, "--out", tmp_path / "second", "--library", lib, *BUDGET], capsys)
    assert code == 0
    assert stdout.startswith("skipped")
    assert read_summary(tmp_path / "second" / "summary.csv")[0]["status"] == "skipped"


def test_a_changed_assembly_is_identified_again(tmp_path, capsys):
    wav = write_case(tmp_path / "rec", "x", "ER32 x")
    args = [wav, "--out", tmp_path / "out", "--library", tmp_path / "lib.json", *BUDGET]
    assert run_cli(args, capsys)[0] == 0
    (tmp_path / "rec" / "x.toml").write_text(assembly_text("ER32 x", stickout_mm=54.0))
    run_cli(args, capsys)
    assert read_summary(tmp_path / "out" / "summary.csv")[0]["status"] == "ok"


def test_batch_report_has_a_summary_and_a_page_per_identified_recording(folder, tmp_path, capsys):
    pdf = tmp_path / "report.pdf"
    args = [folder / "a", folder / "bad" / "notes.wav", "--out", tmp_path / "out", "--no-save", "--report", pdf, *BUDGET]
    code, stdout, _ = run_cli(args, capsys)
    assert code == 1
    pages = re.findall(rb"/Type\s*/Page\b(?!s)", pdf.read_bytes())
    assert len(pages) == 1 + 2  # summary + one.wav + two.wav
    assert f"report: {pdf}" in stdout


@pytest.mark.parametrize("args, message", [
    (["--jobs", "0"], "--jobs must be at least 1"),
    (["--population", "0"], "--population must be at least 1"),
    (["--library", "lib.json", "--report", "lib.json"], "lib.json: is the holder library"),
])
def test_bad_options_exit_2_with_one_line(tmp_path, capsys, args, message):
    code, _, err = run_cli([tmp_path, *args], capsys)
    assert code == 2
    assert message in err and err.count("\n") == 1


def test_a_bad_assembly_option_is_bad_input_before_any_work(tmp_path, capsys):
    (tmp_path / "x.wav").write_bytes(b"x")
    code, _, err = run_cli([tmp_path, "--assembly", tmp_path / "missing.toml", "--out", tmp_path / "out"], capsys)
    assert (code, err.count("\n")) == (2, 1)
    assert "missing.toml" in err
    assert not (tmp_path / "out" / "summary.csv").exists()


def test_nothing_to_do_is_bad_input(tmp_path, capsys):
    code, _, err = run_cli([tmp_path, "--out", tmp_path / "out"], capsys)
    assert (code, err.count("\n")) == (2, 1)
    assert "no recording (WAV, FLAC" in err


def test_two_batches_at_once_on_one_library_lose_nothing(tmp_path):
    """Real processes (python -m taptune batch) write the same library file at the same time."""
    holders = {}
    for batch in ("p", "q"):
        for i in range(3):
            holder = f"ER32 {batch}{i}"
            write_case(tmp_path / batch, f"{batch}{i}", holder, stickout_mm=49.0 + 2 * i, seed=i)
            holders[holder] = batch
    lib = tmp_path / "shared" / "lib.json"
    env = dict(os.environ, OPENBLAS_NUM_THREADS="1",
               PYTHONPATH=os.pathsep.join(filter(None, [str(REPO), os.environ.get("PYTHONPATH")])))
    procs = [
        subprocess.Popen(
            [sys.executable, "-m", "taptune", "batch", str(tmp_path / batch), "--out", str(tmp_path / f"out-{batch}"),
             "--library", str(lib), "--jobs", "2", *BUDGET],
            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env, cwd=tmp_path,
        )
        for batch in ("p", "q")
    ]
    results = [p.communicate(timeout=600) for p in procs]
    assert [p.returncode for p in procs] == [0, 0], results
    entries = HolderLibrary(lib).entries()
    assert sorted(entries) == sorted(holders)
    assert all(len(e.identifications) == 1 for e in entries.values())


@pytest.mark.slow
def test_fifty_recordings_with_a_few_bad_ones(tmp_path, capsys):
    """The 50-recording run: 46 good (8 holders), 4 bad; completes and lists exactly the bad ones."""
    for i in range(46):
        write_case(tmp_path / "rec" / f"h{i % 8}", f"r{i:02d}", f"ER32 h{i % 8}", stickout_mm=45.0 + (i % 6) * 3, seed=i)
    write_bad_files(tmp_path / "rec" / "bad")
    (tmp_path / "rec" / "bad" / "empty.wav").write_bytes(b"")
    (tmp_path / "rec" / "bad" / "empty.toml").write_text(assembly_text("ER32 empty"))
    code, stdout, _ = run_cli([tmp_path / "rec", "--out", tmp_path / "out", "--library", tmp_path / "lib.json",
                               "--joint", *BUDGET], capsys)
    assert code == 1
    assert failed_list(stdout) == ["empty.wav", "lonely.wav", "notes.wav", "truncated.wav"]
    rows = read_summary(tmp_path / "out" / "summary.csv")
    assert len(rows) == 50 and sum(r["status"] == "ok" for r in rows) == 46
    assert HolderLibrary(tmp_path / "lib.json").names() == sorted(f"ER32 h{k}" for k in range(8))


# ----------------------------------------------------------------------------- --machine

MACHINE = REPO / "recordings" / "machine" / "machine.toml"
CUT = ["--teeth", "4", "--material", "al6082", "--ae", "4", "--milling", "down"]


def test_batch_on_the_machine_matches_taptune_lobes_and_draws_the_frf_and_lobes(folder, tmp_path, capsys, monkeypatch):
    import taptune.report.machine_page as machine_page

    drawn = []
    real_draw = machine_page.draw_machine
    monkeypatch.setattr(machine_page, "draw_machine", lambda fig, view: (drawn.append(view), real_draw(fig, view)))
    out, pdf = tmp_path / "out", tmp_path / "report.pdf"
    code, stdout, stderr = run_cli([folder / "a", "--out", out, "--no-save", "--report", pdf, "--machine", MACHINE,
                                    *CUT, *BUDGET], capsys)
    assert code == 0, stdout + stderr
    rows = {Path(r["file"]).name: r for r in read_summary(out / "summary.csv")}
    assert set(rows) == {"one.wav", "two.wav"}
    assert all(float(r["a_crit_mm"]) > 0 and float(r["best_pocket_a_lim_mm"]) > float(r["a_crit_mm"])
               and float(r["best_pocket_rpm"]) > 0 for r in rows.values())
    pages = re.findall(rb"/Type\s*/Page\b(?!s)", pdf.read_bytes())
    assert len(pages) == 1 + 2  # the machine row is on each recording's page, not a page of its own
    assert len(drawn) == 2 and all(not v.error and len(v.rpm) > 100 for v in drawn)

    # The same holder through 'taptune lobes --params <result JSON>': another route to the same lobes.
    lobes_json = tmp_path / "lobes.json"
    code = main(["lobes", str(folder / "a" / "one.toml"), "--params", str(out / "one.json"), "--machine", str(MACHINE),
                 *CUT, "--json", str(lobes_json)])
    capsys.readouterr()
    assert code == 0
    # The semi-discretization samples the speeds it computes over the range it is given, and the
    # batch's range is widened for the holder's band: the two agree to the sampling (a few per mille
    # to 2 %), not to rounding as the zero-order lobes did.
    assert json.loads(lobes_json.read_text())["a_crit_mm"] == pytest.approx(float(rows["one.wav"]["a_crit_mm"]), rel=0.03)


def test_without_machine_the_machine_columns_are_empty(folder, tmp_path, capsys):
    out = tmp_path / "out"
    run_cli([folder / "a" / "one.wav", "--out", out, "--no-save", *BUDGET], capsys)
    (row,) = read_summary(out / "summary.csv")
    assert (row["a_crit_mm"], row["best_pocket_rpm"], row["best_pocket_a_lim_mm"]) == ("", "", "")


@pytest.mark.parametrize("extra, message", [
    (["--machine", "{tmp}/nope.toml", *CUT], "nope.toml"),
    (["--machine", "{tmp}/broken.toml", *CUT], "broken.toml"),
    (["--machine", str(MACHINE), "--teeth", "4", "--material", "al6082"], "the cut needs --ae, --milling"),
    (["--machine", str(MACHINE), *CUT, "--material", "unobtainium"], "unobtainium"),
    (["--machine", str(MACHINE), *CUT, "--diameter", "3"], "--ae 4 mm exceeds the tool diameter 3 mm"),
    (["--machine", str(MACHINE), *CUT, "--rpm", "9000", "1000", "10"], "--rpm 9000 1000 10"),
    (["--machine", str(MACHINE), *CUT, "--freq", "10", "90000", "2"], "choose a grid inside"),
    ([*CUT], "--teeth, --material, --ae, --milling describe the machine part: give --machine"),
])
def test_a_bad_machine_or_cut_exits_2_before_anything_is_written(tmp_path, capsys, extra, message):
    recordings = tmp_path / "rec"
    recordings.mkdir()
    (recordings / "x.wav").write_bytes(b"x")
    (tmp_path / "broken.toml").write_text("[machine]\nname = 'no spindle'\n")
    out, lib, pdf = tmp_path / "out", tmp_path / "lib.json", tmp_path / "reports" / "r.pdf"
    args = [recordings, "--out", out, "--library", lib, "--report", pdf, *[a.format(tmp=tmp_path) for a in extra]]
    code, stdout, err = run_cli(args, capsys)
    assert (code, err.count("\n")) == (2, 1), err
    assert message in err and "Traceback" not in err
    assert not out.exists() and not lib.exists() and not pdf.parent.exists()  # nothing written, not even a folder


def test_the_final_list_names_recordings_identified_but_not_put_on_the_machine(tmp_path):
    import io

    from taptune.batch import BatchResult, Row
    from taptune.cli.cmd_batch import print_result

    rows = (Row("a.wav", "A", "ok", a_crit_mm=2.5),
            Row("b.wav", "B", "ok", message="machine part failed: b.toml: the tool reaches behind the coupling plane; "
                                            "1 warning: something"))
    stream = io.StringIO()
    print_result(BatchResult(rows, tmp_path / "summary.csv"), tmp_path, stream)
    text = stream.getvalue()
    assert "2 recordings: 2 ok" in text and "failed:" not in text.replace("machine part failed:", "")
    assert "identified, but not on the machine (1):\n  b.wav: b.toml: the tool reaches behind the coupling plane\n" in text
