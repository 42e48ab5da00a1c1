"""``taptune library``: output, exit codes and messages (docs/cli.md)."""

from __future__ import annotations

import json
import os
import pickle
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from taptune.library import HolderLibrary, store
from taptune.library.exchange import frequency_grid, holder_receptance
from tests.library.entries import REFERENCE, make_entry
from tests.library.pg import pg_url, postgres_server  # noqa: F401  (fixtures)
from tests.library.test_schema import Exploit
from tests.cli_run import taptune

REPO = Path(__file__).resolve().parents[2]
ER32 = "ER32 collet chuck HSK-A63 x 100"


@pytest.fixture
def lib(tmp_path, monkeypatch) -> HolderLibrary:
    """Two holders; TAPTUNE_LIBRARY points elsewhere so that --library must be honoured."""
    monkeypatch.setenv("TAPTUNE_LIBRARY", str(tmp_path / "not-this-one.json"))
    lib = HolderLibrary(tmp_path / "holders.json")
    lib.put(make_entry(ER32, records=2))
    lib.put(make_entry("Shrink fit D16", scale=1.4, records=1, first=5))
    return lib


def one_line(err: str) -> str:
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    return lines[0]


# --------------------------------------------------------------------------- list / show


def test_list_prints_an_aligned_table(capsys, lib):
    code, out, err = taptune(capsys, "library", "list", "--library", lib.path)
    assert code == 0 and err == ""
    lines = out.splitlines()
    assert lines[0].split()[:2] == ["name", "interface"] and "k_tt [N/m/mm]" in lines[0]
    assert lines[2].startswith(ER32) and "2.81e+09" in lines[2] and "2026-11-22 12:00" in lines[2]
    assert lines[3].startswith("Shrink fit D16") and "3.93e+09" in lines[3]
    # Aligned: every column ends at the same position on every row.
    assert len({len(line) for line in lines[:4]}) == 1
    assert lines[-1] == f"2 holders in {lib.path}"


def test_library_option_works_before_the_action_and_env_is_the_fallback(capsys, lib, monkeypatch):
    code, out, _ = taptune(capsys, "library", "--library", lib.path, "list", "--json", "-")
    assert code == 0
    assert [h["name"] for h in json.loads(out)["holders"]] == [ER32, "Shrink fit D16"]
    monkeypatch.setenv("TAPTUNE_LIBRARY", str(lib.path))
    code, out, _ = taptune(capsys, "library", "list", "--json", "-")
    assert json.loads(out)["library"] == str(lib.path)


@pytest.fixture(params=["sqlite", "postgresql"])
def db(request, tmp_path):
    """A database library (SQLite or the test PostgreSQL server) with 30 holders, some with checks."""
    from dataclasses import replace

    from tests.library.test_database import a_check

    location = str(tmp_path / "holders.db") if request.param == "sqlite" else request.getfixturevalue("pg_url")
    lib = HolderLibrary(location)
    for i in range(30):
        entry = make_entry(f"{'ER32' if i % 3 == 0 else 'Shrink fit'} pocket {i:02d}", records=1, first=i)
        lib.put(replace(entry, checks=(a_check(i, "differs"),)) if i == 3 else entry)
    yield lib
    lib.close()


def test_list_match_and_limit_on_a_database(capsys, db):
    code, out, err = taptune(capsys, "library", "list", "--match", "er32", "--library", db.url if db.kind ==
                             "postgresql" else db.path)
    assert code == 0 and err == ""
    lines = out.splitlines()
    assert "last check (UTC)" in lines[0]
    assert [line.split()[0] for line in lines[2:-1]] == ["ER32"] * 10
    assert "differs 2026-11-23 08:03" in lines[3]
    assert lines[-1] == f"10 holders whose name contains 'er32' in {db.location}"
    code, out, _ = taptune(capsys, "library", "list", "--limit", "4", "--library",
                           db.url if db.kind == "postgresql" else db.path)
    assert len(out.splitlines()) == 2 + 4 + 1
    assert out.splitlines()[-1].startswith(f"4 of 30 holders in {db.location} (--limit N shows more")
    code, out, _ = taptune(capsys, "library", "list", "--match", "pocket 1", "--json", "-", "--library",
                           db.url if db.kind == "postgresql" else db.path)
    data = json.loads(out)
    assert data["total"] == 10 and sorted(h["name"][-2:] for h in data["holders"]) == [f"{i}" for i in range(10, 20)]
    assert [h["name"] for h in data["holders"]] == sorted(h["name"] for h in data["holders"])
    code, out, _ = taptune(capsys, "library", "list", "--match", "nothing", "--library",
                           db.url if db.kind == "postgresql" else db.path)
    assert code == 0 and "no holder name contains 'nothing'" in out


def test_unknown_holder_in_a_database_suggests_close_names(capsys, db):
    where = db.url if db.kind == "postgresql" else db.path
    code, out, err = taptune(capsys, "library", "show", "ER32 pocket 4", "--library", where)
    assert code == 2 and out == ""
    msg = one_line(err)
    assert msg.startswith(f"taptune library: {db.location}: no holder 'ER32 pocket 4'") and "did you mean" in msg


def test_list_negative_limit_exits_2(capsys, tmp_path):
    code, _, err = taptune(capsys, "library", "list", "--limit", "-1", "--library", tmp_path / "h.db")
    assert code == 2 and "--limit" in one_line(err)


def test_list_of_a_missing_library_says_it_is_empty(capsys, tmp_path):
    code, out, _ = taptune(capsys, "library", "list", "--library", tmp_path / "none.json")
    assert code == 0 and "no holders yet" in out
    assert not (tmp_path / "none.json").exists()


def test_show_gives_parameters_with_spread_history_and_predictions(capsys, lib):
    code, out, err = taptune(capsys, "library", "show", ER32, "--library", lib.path)
    assert code == 0, err
    assert "k_tt" in out and "2.81e+09 ± 2.1e+08" in out  # half-width of 0.95…1.1 × 2.81e9
    assert "tap0.wav" in out and "tap1.wav" in out and "identifications (2)" in out
    # Reference assembly at 53.5 mm, nominal contact with alpha -6.5 %: f1 ≈ 4780 Hz (band centre).
    line = next(l for l in out.splitlines() if "at 53.5 mm:" in l)
    f1 = float(line.split("f1 ")[1].split(" ±")[0])
    assert f1 == pytest.approx(4783, abs=20)


def test_show_reports_a_setup_it_cannot_predict_and_goes_on(capsys, lib):
    from dataclasses import replace

    from taptune.library import tool_to_dict

    entry = lib.get(ER32)
    fat = replace(REFERENCE.tool, name="D32 shank", segments=tuple(replace(s, od=0.032) for s in REFERENCE.tool.segments))
    odd = replace(entry.identifications[0], tool=tool_to_dict(fat), sha256="f" * 64)
    lib.put(replace(entry, identifications=entry.identifications + (odd,)))
    code, out, _ = taptune(capsys, "library", "show", ER32, "--library", lib.path)
    assert code == 0
    assert "tool 'solid carbide end mill D16 4FL' at 53.5 mm: f1 " in out
    line = next(l for l in out.splitlines() if "'D32 shank' at 53.5 mm:" in l)
    assert "cannot predict" in line and "cannot fit" in line


def test_show_json_has_entry_spread_and_predictions(capsys, lib):
    code, out, _ = taptune(capsys, "library", "show", ER32, "--library", lib.path, "--json", "-")
    data = json.loads(out)
    assert code == 0 and data["holder"] == lib.get(ER32).to_dict()
    assert data["spread"]["alpha"] == pytest.approx(2.75)
    assert data["predictions"][0]["stickout"] == 53.5 and len(data["predictions"][0]["bending_hz"]) == 3


def test_unknown_holder_exits_2_with_close_matches(capsys, lib):
    for action in (["show", "ER23"], ["remove", "ER23"], ["receptance", "ER23", "--assembly", "x.toml", "--out", "r.uff"]):
        code, out, err = taptune(capsys, "library", *action, "--library", lib.path)
        assert code == 2 and out == ""
        msg = one_line(err)
        assert str(lib.path) in msg and "'ER23'" in msg and f"did you mean '{ER32}'" in msg


# --------------------------------------------------------------------------- broken library


@pytest.mark.parametrize("action", [["list"], ["show", ER32], ["remove", ER32], ["export", "out.json"]])
def test_broken_library_exits_2_naming_the_file_and_is_not_touched(capsys, lib, action, tmp_path):
    broken = lib.path.read_bytes()[:-40]
    lib.path.write_bytes(broken)
    code, out, err = taptune(capsys, "library", *action, "--library", lib.path)
    assert code == 2
    msg = one_line(err)
    assert msg.startswith(f"taptune library: {lib.path}: is not valid JSON")
    assert lib.path.read_bytes() == broken


def test_broken_library_in_a_real_process_prints_no_traceback(lib):
    lib.path.write_text('{"schema": "taptune-holder-library", "version": 1, "holders": {"A": {"name": "A"}}}')
    proc = subprocess.run(
        [sys.executable, "-m", "taptune", "library", "list", "--library", str(lib.path)],
        cwd=REPO, capture_output=True, text=True, env={**os.environ, "OPENBLAS_NUM_THREADS": "1"},
    )
    assert proc.returncode == 2 and proc.stdout == ""
    assert one_line(proc.stderr) == f"taptune library: {lib.path}: holder 'A': holder is missing"


def test_busy_lock_exits_1(capsys, lib, monkeypatch):
    monkeypatch.setattr(store, "LOCK_TIMEOUT_S", 0.1)
    with HolderLibrary(lib.path)._locked():
        code, _, err = taptune(capsys, "library", "remove", ER32, "--library", lib.path)
    assert code == 1 and "lock" in one_line(err)
    assert ER32 in lib.names()


# --------------------------------------------------------------------------- export / import / remove


def test_export_import_round_trip_through_the_cli(capsys, lib, tmp_path):
    out = tmp_path / "exchange" / "all.json"
    code, text, _ = taptune(capsys, "library", "export", out, "--library", lib.path)
    assert code == 0 and "exported 2 holders" in text
    other = tmp_path / "other.json"
    code, text, _ = taptune(capsys, "library", "import", out, "--library", other)
    assert code == 0 and "2 added" in text
    assert HolderLibrary(other).entries() == lib.entries()
    code, text, _ = taptune(capsys, "library", "import", out, "--library", other)
    assert "0 added" in text and "2 identical and skipped" in text


def test_csv_export_by_extension(capsys, lib, tmp_path):
    code, _, _ = taptune(capsys, "library", "export", tmp_path / "h.csv", "--library", lib.path)
    header = (tmp_path / "h.csv").read_text().splitlines()[0]
    assert code == 0 and "k_tt [N/m/mm]" in header and "clamp_length [mm]" in header


def test_import_conflict_is_kept_unless_replace(capsys, lib, tmp_path):
    theirs = HolderLibrary(tmp_path / "theirs.json")
    theirs.put(make_entry("Shrink fit D16", scale=2.0, records=1, first=9))
    code, out, _ = taptune(capsys, "library", "import", theirs.path, "--library", lib.path)
    assert code == 0 and "1 in conflict" in out and "--replace" in out
    assert lib.get("Shrink fit D16").params.k_tt == pytest.approx(1.4 * 2.81e9)
    code, out, _ = taptune(capsys, "library", "import", theirs.path, "--replace", "--library", lib.path)
    assert code == 0 and "replaced" in out
    assert lib.get("Shrink fit D16").params.k_tt == pytest.approx(2.0 * 2.81e9)


def test_import_of_a_pickle_exits_2_without_unpickling(capsys, lib, tmp_path):
    marker = tmp_path / "pwned"
    evil = tmp_path / "holders.pkl"
    evil.write_bytes(pickle.dumps(Exploit(str(marker))))
    before = lib.path.read_bytes()
    code, _, err = taptune(capsys, "library", "import", evil, "--library", lib.path)
    assert code == 2 and str(evil) in one_line(err)
    assert not marker.exists() and lib.path.read_bytes() == before


def test_import_of_an_invalid_entry_names_the_key(capsys, lib, tmp_path):
    bad = tmp_path / "bad.json"
    bad.write_text(lib.path.read_text().replace('"seed": 5', '"seed": "five"'))
    code, _, err = taptune(capsys, "library", "import", bad, "--library", lib.path)
    assert code == 2
    assert one_line(err) == (
        f"taptune library: {bad}: holder 'Shrink fit D16': identifications[0].seed must be an integer >= 0, got 'five'"
    )


def test_remove(capsys, lib):
    code, out, _ = taptune(capsys, "library", "remove", "Shrink fit D16", "--library", lib.path)
    assert code == 0 and "removed holder 'Shrink fit D16'" in out
    assert lib.names() == [ER32]


def test_missing_action_is_a_usage_error(capsys, lib):
    code, _, err = taptune(capsys, "library", "--library", lib.path)
    assert code == 2 and "usage" in err


# --------------------------------------------------------------------------- receptance


@pytest.fixture
def assembly_file(tmp_path) -> Path:
    from tests.conftest import REFERENCE_TOML

    path = tmp_path / "reference.toml"
    path.write_text(REFERENCE_TOML)
    return path


def test_receptance_uff58_matches_the_model(capsys, lib, assembly_file, tmp_path):
    pyuff = pytest.importorskip("pyuff")
    out = tmp_path / "r.uff"
    code, text, err = taptune(
        capsys, "library", "receptance", ER32, "--assembly", assembly_file, "--stickout", 63.5,
        "--out", out, "--fmax", 8000, "--df", 10, "--library", lib.path,
    )
    assert code == 0, err
    assert "at 63.5 mm" in text and "800 frequencies 10–8000 Hz" in text
    ds = pyuff.UFF(str(out)).read_sets()
    freq = frequency_grid(10, 8000, 10)
    expected = holder_receptance(lib.get(ER32), REFERENCE.with_stickout(0.0635), freq)
    np.testing.assert_allclose(ds["x"], freq)
    np.testing.assert_allclose(ds["data"], expected, rtol=1e-9)


def test_receptance_csv(capsys, lib, assembly_file, tmp_path):
    out = tmp_path / "r.csv"
    code, _, err = taptune(capsys, "library", "receptance", ER32, "--assembly", assembly_file, "--out", out,
                           "--library", lib.path)
    assert code == 0, err
    data = np.loadtxt(out, delimiter=",", skiprows=1)
    assert data.shape == (3999, 3)


def test_receptance_of_another_holder_notes_the_mismatch(capsys, lib, assembly_file, tmp_path):
    code, _, err = taptune(capsys, "library", "receptance", "Shrink fit D16", "--assembly", assembly_file,
                           "--out", tmp_path / "r.csv", "--fmax", 100, "--library", lib.path)
    assert code == 0 and "contact parameters of library holder 'Shrink fit D16'" in one_line(err)


@pytest.mark.parametrize(
    "extra, problem",
    [
        (["--out", "r.txt"], "unknown receptance file type"),
        (["--out", "r.uff", "--df", "0"], "step > 0"),
        (["--out", "r.uff", "--stickout", "200"], "[setup] stickout"),
    ],
)
def test_receptance_bad_input_exits_2(capsys, lib, assembly_file, tmp_path, extra, problem):
    code, _, err = taptune(capsys, "library", "receptance", ER32, "--assembly", assembly_file, *extra,
                           "--library", lib.path)
    assert code == 2 and problem in one_line(err)


def test_receptance_with_a_missing_assembly_exits_2(capsys, lib, tmp_path):
    code, _, err = taptune(capsys, "library", "receptance", ER32, "--assembly", tmp_path / "no.toml",
                           "--out", tmp_path / "r.uff", "--library", lib.path)
    assert code == 2 and "no.toml: no such file" in one_line(err)
