"""The batch engine: discovery, pairing, result names, skip-by-hash, isolation of failures.

The end-to-end runs (real identifications in worker processes) use tap recordings
synthesised from the model (:mod:`taptune.synthetic`; reference assembly of
docs/assembly-format.md, nominal holder) with a tiny optimiser budget: they check the machinery, not the
accuracy of the fit.
"""

from __future__ import annotations

import json
import os
from pathlib import Path

import pytest

from tests.conftest import REFERENCE_TOML

from taptune.batch import (
    SUMMARY_HEADER,
    BatchOptions,
    Row,
    discover,
    find_assembly,
    one_line,
    plan,
    read_summary,
    result_names,
    run_batch,
)
from taptune.errors import InputError

TINY = dict(population=8, generations=2, polish_evaluations=20)


# ----------------------------------------------------------------------------- test data


def assembly_text(holder: str = "ER32 test holder", stickout_mm: float = 53.5) -> str:
    """The reference assembly TOML with another holder name and stick-out."""
    return (REFERENCE_TOML.replace('name = "ER32 collet chuck HSK-A63 x 100"', f'name = "{holder}"')
            .replace("stickout = 53.5", f"stickout = {stickout_mm}"))


def write_case(folder: Path, stem: str, holder: str, stickout_mm: float = 53.5, seed: int = 0,
               with_toml: bool = True, suffix: str = ".wav") -> Path:
    """A synthetic recording ``folder/stem.wav`` of the nominal holder and (optionally) its ``stem.toml``.

    96 kHz, no microphone low-pass and 60 dB SNR, so f1–f3 are all in the recording.
    """
    import tomllib

    from taptune.io.assembly import parse_assembly
    from taptune.model import NOMINAL
    from taptune.synthetic import write_tap_recording

    folder.mkdir(parents=True, exist_ok=True)
    text = assembly_text(holder, stickout_mm)
    wav = folder / f"{stem}{suffix}"
    write_tap_recording(wav, parse_assembly(tomllib.loads(text), stem), NOMINAL, seed=seed,
                        sample_rate=96000, mic_lp_hz=None, snr_db=60.0)
    if with_toml:
        (folder / f"{stem}.toml").write_text(text)
    return wav


def write_bad_files(folder: Path) -> dict[str, Path]:
    """A truncated WAV, a text file named .wav and a good WAV without assembly, each with its toml where it has one."""
    folder.mkdir(parents=True, exist_ok=True)
    good = write_case(folder / "tmp", "donor", "ER32 donor")
    truncated = folder / "truncated.wav"
    truncated.write_bytes(good.read_bytes()[:30])
    (folder / "truncated.toml").write_text(assembly_text("ER32 truncated"))
    text = folder / "notes.wav"
    text.write_text("these are my notes, not audio\n")
    (folder / "notes.toml").write_text(assembly_text("ER32 notes"))
    orphan = folder / "orphan" / "lonely.wav"
    orphan.parent.mkdir()
    orphan.write_bytes(good.read_bytes())
    for f in (folder / "tmp").iterdir():
        f.unlink()
    (folder / "tmp").rmdir()
    return {"truncated": truncated, "text": text, "orphan": orphan}


# ----------------------------------------------------------------------------- discovery and pairing


def test_discover_is_recursive_sorted_case_insensitive_and_reports_missing_paths(tmp_path):
    for name in ("b/z.WAV", "a/y.flac", "a/x.wav", "a/notes.txt", "c.wav"):
        (tmp_path / name).parent.mkdir(parents=True, exist_ok=True)
        (tmp_path / name).write_bytes(b"x")
    files, missing = discover([tmp_path, tmp_path / "a" / "x.wav", tmp_path / "nope"])
    rel = [str(f.relative_to(tmp_path)) for f in files]
    assert rel == ["a/x.wav", "a/y.flac", "b/z.WAV", "c.wav"]  # sorted, once each, no .txt
    assert [r.status for r in missing] == ["failed"]
    assert "no such file or folder" in missing[0].message


def test_discover_takes_every_suffix_read_audio_reads(tmp_path):
    # A folder of phone memos (M4A), MP3, Ogg and FLAC is batched like a folder of WAVs;
    # before, only .wav/.flac were found and the rest was silently left out.
    from taptune.io.audio import AUDIO_SUFFIXES

    names = ["a.m4a", "b.MP3", "c.ogg", "d.flac", "e.opus", "f.wav", "g.txt", "h.toml"]
    for name in names:
        (tmp_path / name).write_bytes(b"x")
    files, _ = discover([tmp_path])
    assert [f.name for f in files] == names[:6]
    assert {".m4a", ".mp3", ".ogg", ".flac", ".opus", ".wav"} <= set(AUDIO_SUFFIXES)


def test_an_explicitly_named_file_is_taken_whatever_its_extension(tmp_path):
    f = tmp_path / "recording.aiff"
    f.write_bytes(b"x")
    assert discover([f])[0] == [f]


def test_assembly_is_the_option_then_the_same_stem_then_assembly_toml(tmp_path):
    wav = tmp_path / "tap1.wav"
    assert find_assembly(wav) is None
    (tmp_path / "assembly.toml").write_text("")
    assert find_assembly(wav) == tmp_path / "assembly.toml"
    (tmp_path / "tap1.toml").write_text("")
    assert find_assembly(wav) == tmp_path / "tap1.toml"
    (tmp_path / "er32.toml").write_text("")
    assert find_assembly(tmp_path / "er32_tap.flac") == tmp_path / "er32.toml"  # recordings/ naming
    assert find_assembly(wav, "other.toml") == Path("other.toml")


def test_result_names_keep_folders_and_separate_equal_stems(tmp_path):
    files = [tmp_path / "d01" / "tap.wav", tmp_path / "d02" / "tap.wav", tmp_path / "d02" / "tap.flac"]
    names = result_names(files)
    assert [str(names[f]) for f in files] == ["d01/tap.json", "d02/tap.wav.json", "d02/tap.flac.json"]
    assert result_names([tmp_path / "x.wav"]) == {tmp_path / "x.wav": Path("x.json")}


def test_rows_become_csv_cells_in_header_order():
    row = Row("a.wav", "H", "ok", (1000.0, 2000.0, None), (1000.25, 2000.0, 3000.0), 0.5, 1.234, "")
    assert row.csv_cells() == ["a.wav", "H", "ok", "1000.00", "2000.00", "", "1000.25", "2000.00", "3000.00",
                               "0.500000", "1.23", "", "", "", ""]  # no machine part: its three cells empty
    on_machine = Row("a.wav", "H", "ok", a_crit_mm=2.46521, best_pocket_rpm=22560.0, best_pocket_a_lim_mm=28.97931)
    cells = dict(zip(SUMMARY_HEADER, on_machine.csv_cells()))
    assert (cells["a_crit_mm"], cells["best_pocket_rpm"], cells["best_pocket_a_lim_mm"]) == ("2.4652", "22560", "28.9793")
    assert len(SUMMARY_HEADER) == len(cells) and SUMMARY_HEADER[-1] == "message"
    assert not row.failed and Row("b.wav", "", "error").failed


def test_one_line_messages_name_unexpected_types_and_never_span_lines():
    assert one_line(InputError("x.wav: the file is empty")) == "x.wav: the file is empty"
    assert one_line(ValueError("bad\n  value")) == "ValueError: bad value"
    assert len(one_line("y" * 5000)) == 400


def test_plan_fails_each_unusable_file_and_keeps_the_rest(tmp_path):
    write_case(tmp_path, "good", "ER32 good")
    bad = write_bad_files(tmp_path)
    (tmp_path / "broken.wav").write_bytes(b"x")
    (tmp_path / "broken.toml").write_text("[holder\n")
    options = BatchOptions(out_dir=tmp_path / "out", library=str(tmp_path / "lib.json"))
    p = plan([tmp_path], options)
    assert [str(job[0].path) for job in p.jobs] == [str(tmp_path / f) for f in ("good.wav", "notes.wav", "truncated.wav")]
    decided = {Path(r.file).name: r for r in p.decided}
    assert set(decided) == {"broken.wav", bad["orphan"].name}
    assert "broken.toml" in decided["broken.wav"].message
    assert "no assembly" in decided["lonely.wav"].message


def test_plan_with_nothing_to_do_is_bad_input(tmp_path):
    with pytest.raises(InputError, match="no recording"):
        plan([tmp_path], BatchOptions(out_dir=tmp_path / "out"))


def test_an_output_folder_that_is_a_file_is_named_as_such_and_kept(tmp_path):
    # Before: "cannot create the output folder (File exists)".
    out = tmp_path / "results"
    out.write_text("my notes")
    wav = tmp_path / "x.wav"
    wav.write_bytes(b"x")
    with pytest.raises(InputError, match=r"results: is a file, not a folder; --out needs a folder"):
        run_batch([wav], BatchOptions(out_dir=str(out), save=False))
    assert out.read_text() == "my notes"


def test_a_result_that_would_overwrite_the_library_is_refused_before_any_work(tmp_path):
    # holders.wav's result JSON is out/holders.json: the library itself when --out is its folder.
    (tmp_path / "rec").mkdir()
    (tmp_path / "rec" / "holders.wav").write_bytes(b"x")
    (tmp_path / "rec" / "holders.toml").write_text(assembly_text())
    library = tmp_path / "out" / "holders.json"
    library.parent.mkdir()
    library.write_bytes(b"saved holders")
    for save in (True, False):
        options = BatchOptions(out_dir=tmp_path / "out", library=str(library), save=save)
        with pytest.raises(InputError, match="is the holder library"):
            plan([tmp_path / "rec"], options)
    assert library.read_bytes() == b"saved holders"


def test_joint_plan_groups_by_holder_name(tmp_path):
    for stem, holder in (("a1", "A"), ("b1", "B"), ("a2", "A")):
        (tmp_path / f"{stem}.wav").write_bytes(b"x")
        (tmp_path / f"{stem}.toml").write_text(assembly_text(holder))
    options = BatchOptions(out_dir=tmp_path / "out", library=str(tmp_path / "lib.json"), joint=True)
    jobs = plan([tmp_path], options).jobs
    assert [[i.path.name for i in job] for job in jobs] == [["a1.wav", "a2.wav"], ["b1.wav"]]
    separate = plan([tmp_path], BatchOptions(out_dir=tmp_path / "out", library=str(tmp_path / "lib.json")))
    assert any("holder 'A'" in n and "--joint" in n for n in separate.notes)


# ----------------------------------------------------------------------------- real runs


def tiny(tmp_path, **kw) -> BatchOptions:
    return BatchOptions(out_dir=tmp_path / "out", library=str(tmp_path / "lib.json"), jobs=2, **TINY, **kw)


def junk_pair_with_a_misbehaving_worker(tmp_path, monkeypatch, misbehave) -> None:
    """a.wav and b.wav (1 byte of junk each, with assemblies); the worker of a.wav runs ``misbehave()`` first.

    Workers are forked, so they see the monkeypatched ``run_job`` (the pool's name for it).
    """
    import taptune.batch.pool as pool

    for stem in ("a", "b"):
        (tmp_path / f"{stem}.wav").write_bytes(b"x")
        (tmp_path / f"{stem}.toml").write_text(assembly_text(stem))
    real = pool.run_job

    def patched(items, options, progress=None):
        if items[0].path.name == "a.wav":
            misbehave()
        return real(items, options, progress)

    monkeypatch.setattr(pool, "run_job", patched)


def test_a_worker_that_dies_is_an_error_row_and_the_batch_goes_on(tmp_path, monkeypatch):
    # os._exit is what a segfault or the OOM killer looks like from outside.
    junk_pair_with_a_misbehaving_worker(tmp_path, monkeypatch, lambda: os._exit(3))
    result = run_batch([tmp_path], tiny(tmp_path))
    by_name = {Path(r.file).name: r for r in result.rows}
    assert by_name["a.wav"].status == "error"
    assert "ended without a result (exit code 3)" in by_name["a.wav"].message
    assert by_name["b.wav"].status == "failed"  # b.wav is 1 byte of junk: bad input, not a crash
    assert result.exit_status == 1


def test_a_job_over_the_timeout_is_stopped_and_the_others_finish(tmp_path, monkeypatch):
    import time

    junk_pair_with_a_misbehaving_worker(tmp_path, monkeypatch, lambda: time.sleep(60))
    t0 = time.monotonic()
    result = run_batch([tmp_path], tiny(tmp_path, timeout_s=1.0))
    assert time.monotonic() - t0 < 30
    by_name = {Path(r.file).name: r for r in result.rows}
    assert by_name["a.wav"].status == "error" and "stopped after 1 s" in by_name["a.wav"].message
    assert by_name["b.wav"].status == "failed"


def test_an_unexpected_exception_is_one_line_and_its_traceback_goes_to_the_log(tmp_path, monkeypatch):
    import taptune.batch.job as job

    write_case(tmp_path, "a", "ER32 a")

    def boom(*args, **kwargs):
        raise ZeroDivisionError("division by zero\nsecond line")

    monkeypatch.setattr(job, "analyse_for_assembly", boom)
    result = run_batch([tmp_path], tiny(tmp_path))
    (row,) = result.rows
    assert (row.status, row.message) == ("error", "ZeroDivisionError: division by zero second line")
    assert "Traceback" in (tmp_path / "out" / "errors.log").read_text()


@pytest.fixture(scope="module")
def joint_folder(tmp_path_factory):
    folder = tmp_path_factory.mktemp("joint")
    write_case(folder, "short", "ER32 joint", stickout_mm=48.5, seed=1)
    write_case(folder, "long", "ER32 joint", stickout_mm=58.5, seed=2)
    return folder


def test_joint_batch_fits_a_holder_once_and_writes_one_json_per_recording(joint_folder, tmp_path):
    from taptune.library import HolderLibrary

    result = run_batch([joint_folder], tiny(tmp_path, joint=True))
    assert [r.status for r in result.rows] == ["ok", "ok"], result.rows
    docs = {name: json.loads((tmp_path / "out" / f"{name}.json").read_text()) for name in ("long", "short")}
    assert docs["long"]["params"] == docs["short"]["params"]  # one parameter set for the holder
    assert docs["long"]["joint"]["files"] == [str(joint_folder / "long.wav"), str(joint_folder / "short.wav")]
    assert docs["short"]["file"] == str(joint_folder / "short.wav")
    assert len(docs["short"]["bending_model_hz"]) == 3  # this recording's modes, not a list per recording
    entry = HolderLibrary(tmp_path / "lib.json").get("ER32 joint")
    assert sorted(r.recording for r in entry.identifications) == ["long.wav", "short.wav"]

    again = run_batch([joint_folder], tiny(tmp_path, joint=True))
    assert [r.status for r in again.rows] == ["skipped", "skipped"]
    # The same recordings fitted one by one are new work: a joint result does not stand for them.
    single = run_batch([joint_folder / "short.wav"], tiny(tmp_path))
    assert [r.status for r in single.rows] == ["ok"]


def test_a_misspelt_assembly_key_reaches_the_result_json_and_the_summary(tmp_path):
    # Before, the batch dropped the assembly's warnings: gauge_lenght was ignored without a word.
    write_case(tmp_path, "a", "ER32 a")
    toml = tmp_path / "a.toml"
    toml.write_text(toml.read_text().replace("clamp_length = 40.0", "clamp_length = 40.0\ngauge_lenght = 100.0"))
    result = run_batch([tmp_path], tiny(tmp_path, save=False))
    assert [r.status for r in result.rows] == ["ok"]
    warning = json.loads((tmp_path / "out" / "a.json").read_text())["warnings"][0]
    assert "unknown key 'gauge_lenght' is ignored; did you mean 'gauge_length'?" in warning
    assert "gauge_lenght" in read_summary(result.summary_path)[0]["message"]


def test_summary_csv_round_trips(tmp_path):
    write_case(tmp_path, "a", "ER32 a")
    result = run_batch([tmp_path], tiny(tmp_path, save=False))
    rows = read_summary(result.summary_path)
    assert [r["status"] for r in rows] == ["ok"]
    assert float(rows[0]["f1_model_hz"]) == pytest.approx(result.rows[0].model_hz[0], abs=0.01)
    assert not (tmp_path / "lib.json").exists()  # save=False leaves the library alone


def test_a_report_page_that_cannot_be_made_leaves_the_identification_ok(tmp_path, monkeypatch):
    import taptune.batch.job as job

    write_case(tmp_path, "a", "ER32 a")

    def broken(*args, **kwargs):
        raise RuntimeError("no page today")

    monkeypatch.setattr(job, "report_pages", broken)
    result = run_batch([tmp_path], tiny(tmp_path, keep_pages=True))
    assert [r.status for r in result.rows] == ["ok"] and result.pages == ()
    assert "no page today" in (tmp_path / "out" / "errors.log").read_text()


# ----------------------------------------------------------------------------- on the machine (--machine)

MACHINE_TOML = Path(__file__).resolve().parents[1] / "recordings" / "machine" / "machine.toml"
CUT = dict(teeth=4, material="al6082", ktc=None, krc=None, diameter=None, ae=4.0, milling="down", rpm=None)


def machine_setup_for_tests(**cut):
    """The MachineSetup ``taptune batch --machine recordings/machine/machine.toml --teeth 4 ...`` builds."""
    from types import SimpleNamespace

    from taptune.cli.cmd_batch import machine_setup

    return machine_setup(SimpleNamespace(machine=str(MACHINE_TOML), freq=None, contact="distributed", **{**CUT, **cut}))


@pytest.fixture(scope="module")
def machine_batch(tmp_path_factory):
    """Two good recordings and one whose holder's coupling plane (gauge_length 30 mm) lies in front of the tool's shank end."""
    folder = tmp_path_factory.mktemp("machine")
    write_case(folder, "one", "ER32 one", stickout_mm=50.0, seed=0)
    write_case(folder, "two", "ER32 two", stickout_mm=56.0, seed=1)
    behind = write_case(folder, "behind", "ER32 behind", stickout_mm=53.5, seed=2)
    toml = behind.with_suffix(".toml")
    toml.write_text(toml.read_text().replace("clamp_length = 40.0", "clamp_length = 40.0\ngauge_length = 30.0"))
    out = tmp_path_factory.mktemp("machine_out")
    options = BatchOptions(out_dir=out, save=False, jobs=2, keep_pages=True, machine=machine_setup_for_tests(), **TINY)
    return folder, out, run_batch([folder], options)


def test_machine_batch_fills_the_summary_with_the_critical_depth_and_the_best_pocket(machine_batch):
    folder, out, result = machine_batch
    rows = {Path(r["file"]).stem: r for r in read_summary(out / "summary.csv")}
    for stem in ("one", "two"):
        row = rows[stem]
        a_crit, rpm, a_best = (float(row[k]) for k in ("a_crit_mm", "best_pocket_rpm", "best_pocket_a_lim_mm"))
        # A 16 mm end mill on an HSK-A63 spindle in aluminium: critical depth of a few mm,
        # pockets several times deeper, inside the 500–24,000 rpm diagram of the machine.
        assert 0.2 < a_crit < 20 and a_best > 2 * a_crit and 500 <= rpm <= 24000, row
        doc = json.loads((out / f"{stem}.json").read_text())
        machine = doc["machine"]
        assert machine["a_crit_mm"] == pytest.approx(a_crit, rel=1e-3)
        assert machine["cut"]["diameter_mm"] == 16.0  # the tool's flute diameter from the assembly
        # The summary's best pocket is the best safe pocket (a speed window a machinist can hold).
        assert machine["safe_pockets"][0]["rpm"] == pytest.approx(rpm, abs=0.5) and machine["method"] in ("sdm", "zoa")
        assert len(machine["pockets"]) <= 10 and "a_lim_mm" not in machine  # moderate JSON: the curve is in the CSV
        lines = (out / machine["lobes_csv"]).read_text().splitlines()
        assert lines[0] == "rpm,a_lim_mm,a_lim_mm_safe,chatter_hz,instability"
        a_lim = [float(line.split(",")[1]) for line in lines[1:] if line.split(",")[1]]
        assert min(a_lim) == pytest.approx(a_crit, rel=1e-3)  # the critical depth is the lowest limit
        assert max(a_lim) >= a_best * (1 - 1e-9)  # the safe pocket lies under the highest peak
        # The tool point on the spindle is softer than nothing: its strongest mode is a real peak.
        assert machine["modes"][0]["magnitude_um_per_n"] > 0.05 and 500 < machine["modes"][0]["hz"] < 15000


def test_a_machine_failure_keeps_the_identification_and_says_why(machine_batch):
    folder, out, result = machine_batch
    row = {Path(r.file).stem: r for r in result.rows}["behind"]
    assert row.status == "ok" and row.model_hz[0] is not None  # identified all the same
    assert row.message.startswith("machine part failed:") and "coupling plane" in row.message, row.message
    assert (row.a_crit_mm, row.best_pocket_rpm) == (None, None)
    doc = json.loads((out / "behind.json").read_text())
    assert "coupling plane" in doc["machine"]["error"] and doc["params"]
    assert result.exit_status == 0  # the identifications are all done


def test_machine_batch_report_pages_carry_the_frf_and_the_lobes(machine_batch):
    folder, out, result = machine_batch
    views = {Path(p.file).stem: p.machine for p in result.pages}
    assert set(views) == {"one", "two", "behind"}
    assert views["behind"].error and not views["one"].error
    one = views["one"]
    assert len(one.freq_hz) == len(one.xx) == len(one.yy) > 1000 and len(one.rpm) == len(one.a_lim_mm) > 100
    assert one.a_crit_mm == pytest.approx(result.rows[[Path(r.file).stem for r in result.rows].index("one")].a_crit_mm)


def test_a_rerun_on_the_same_machine_skips_and_keeps_the_machine_numbers(machine_batch, tmp_path):
    import shutil

    folder, first_out, first = machine_batch
    out = tmp_path / "out"
    shutil.copytree(first_out, out)  # the other tests keep reading the first run's files
    again = run_batch([folder / "one.wav"], BatchOptions(out_dir=out, save=False, jobs=1, machine=machine_setup_for_tests(),
                                                        **TINY))
    (row,) = again.rows
    assert row.status == "skipped" and row.a_crit_mm == pytest.approx(
        next(r.a_crit_mm for r in first.rows if Path(r.file).stem == "one"))
    other_cut = run_batch([folder / "one.wav"], BatchOptions(out_dir=out, save=False, jobs=1,
                                                            machine=machine_setup_for_tests(ae=2.0), **TINY))
    (row,) = other_cut.rows
    # Another cut: the lobes are computed now from the parameters identified before, and stored.
    assert row.status == "skipped" and row.a_crit_mm is not None and "machine part computed now" in row.message
    assert json.loads((out / "one.json").read_text())["machine"]["cut"]["ae_mm"] == 2.0


def test_a_fit_that_does_not_describe_its_recording_is_a_failed_row_and_not_stored(tmp_path):
    """A hydraulic chuck's tap with the ER32 file: the fit misses a mode by about 10 %."""
    import shutil

    from tests.conftest import REPO

    shutil.copy(REPO / "recordings" / "hydraulic_d20_tap.wav", tmp_path / "h.wav")
    (tmp_path / "h.toml").write_text(assembly_text("ER32 h"))
    result = run_batch([tmp_path / "h.wav"], tiny(tmp_path))
    (row,) = result.rows
    assert row.status == "failed" and "the fitted model misses bending mode" in row.message, row
    assert "not stored in the library" in row.message and row.measured_hz[0] and row.model_hz[0]
    assert not (tmp_path / "lib.json").exists() and not (tmp_path / "out" / "h.json").exists()
