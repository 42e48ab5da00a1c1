"""Import/export of the library and receptance files (CSV, UFF dataset 58 read back with pyuff)."""

from __future__ import annotations

import csv
import pickle
import sys

import numpy as np
import pytest

from taptune.errors import InputError, LibraryError
from taptune.library import HolderLibrary, LibraryFormatError
from taptune.library.exchange import (
    export_entries,
    export_library,
    frequency_grid,
    holder_receptance,
    identified_setups,
    import_library,
    predict_setup,
    write_receptance,
    write_receptance_csv,
    write_receptance_uff58,
)
from tests.library.conftest import snapshot
from tests.library.entries import REFERENCE, make_entry, make_record
from tests.library.test_schema import Exploit


@pytest.fixture
def lib(any_lib) -> HolderLibrary:
    """Every test here runs on the JSON file, SQLite and PostgreSQL."""
    return any_lib


@pytest.fixture
def filled(lib) -> HolderLibrary:
    lib.put(make_entry("ER32 collet chuck HSK-A63 x 100", records=3))
    lib.put(make_entry("Shrink fit D16", scale=1.4, records=1, first=10))
    lib.put(make_entry("no history yet", scale=0.7, records=0))
    return lib


# --------------------------------------------------------------------------- JSON


def test_json_export_then_import_round_trips_the_library_exactly(filled, tmp_path):
    out = tmp_path / "export" / "holders-export.json"
    assert export_library(filled, out) == 3
    export_entries(filled.entries(), tmp_path / "reference.json")
    assert out.read_bytes() == (tmp_path / "reference.json").read_bytes()
    if filled.kind == "json":
        assert out.read_bytes() == filled.path.read_bytes()
    fresh = HolderLibrary(tmp_path / "other" / "holders.json")
    report = import_library(fresh, out)
    assert report.added == tuple(sorted(filled.names())) and not report.conflicts
    assert fresh.entries() == filled.entries()
    assert fresh.path.read_bytes() == out.read_bytes()


def test_reimporting_the_same_file_skips_every_holder(filled, tmp_path):
    out = tmp_path / "x.json"
    filled.export(out)
    before = snapshot(filled)
    report = filled.import_file(out)
    assert report.skipped == tuple(filled.names()) and report.added == () and report.merged == ()
    assert snapshot(filled) == before


def test_same_parameters_with_new_records_are_merged(filled, tmp_path):
    other = HolderLibrary(tmp_path / "other.json")
    other.put(make_entry("Shrink fit D16", scale=1.4, records=2, first=10))  # record 10 known, 11 new
    report = import_library(filled, other.path)
    assert report.merged == ("Shrink fit D16",)
    assert [r.seed for r in filled.get("Shrink fit D16").identifications] == [10, 11]


def test_different_parameters_are_a_conflict_kept_unless_replace(filled, tmp_path):
    other = HolderLibrary(tmp_path / "other.json")
    other.put(make_entry("Shrink fit D16", scale=2.0, records=1, first=20))
    other.put(make_entry("new holder"))
    kept_before = filled.get("Shrink fit D16")

    report = import_library(filled, other.path)
    assert report.added == ("new holder",)
    assert [c.name for c in report.conflicts] == ["Shrink fit D16"] and not report.replaced
    assert "k_tt 3.934e+09 vs 5.62e+09" in report.conflicts[0].differences
    assert "--replace" in "\n".join(report.lines())
    assert filled.get("Shrink fit D16") == kept_before

    report = import_library(filled, other.path, replace=True)
    assert report.replaced and report.skipped == ("new holder",)
    now = filled.get("Shrink fit D16")
    assert now.params.k_tt == pytest.approx(2.0 * 2.81e9)
    assert [r.seed for r in now.identifications] == [10, 20]  # both histories kept


def test_an_invalid_import_changes_nothing_and_names_file_and_key(filled, tmp_path):
    before = snapshot(filled)
    bad = tmp_path / "bad.json"
    filled.export(tmp_path / "good.json")
    bad.write_text((tmp_path / "good.json").read_text().replace('"k_rr": 15100.0', '"k_rr": "soft"', 1))
    with pytest.raises(LibraryFormatError, match=rf"^{bad}: holder '.*': params.k_rr must be a finite number, got 'soft'$"):
        import_library(filled, bad)
    assert snapshot(filled) == before


def test_import_never_unpickles(filled, tmp_path):
    marker = tmp_path / "pwned"
    evil = tmp_path / "holders.pickle"
    evil.write_bytes(pickle.dumps(Exploit(str(marker))))
    with pytest.raises(LibraryFormatError, match=str(evil)):
        import_library(filled, evil)
    assert not marker.exists()


def test_import_of_a_missing_file_is_bad_input(filled, tmp_path):
    with pytest.raises(InputError, match="no such file"):
        import_library(filled, tmp_path / "nope.json")


# --------------------------------------------------------------------------- CSV


def test_csv_export_has_units_in_the_header_and_one_row_per_holder(filled, tmp_path):
    out = tmp_path / "holders.csv"
    assert export_library(filled, out, format="csv") == 3
    rows = list(csv.DictReader(out.open(encoding="utf-8")))
    assert [r["name"] for r in rows] == filled.names()
    header = list(rows[0])
    for col in ("k_tt [N/m/mm]", "k_tt_spread [N/m/mm]", "k_rr [N*m/rad/mm]", "alpha [%]", "clamp_length [mm]"):
        assert col in header
    entry = filled.get("ER32 collet chuck HSK-A63 x 100")
    row = next(r for r in rows if r["name"] == entry.name)
    assert float(row["k_tt [N/m/mm]"]) == entry.params.k_tt
    assert float(row["k_tt_spread [N/m/mm]"]) == entry.spread()["k_tt"]
    assert float(row["clamp_length [mm]"]) == 40.0 and float(row["holder_length [mm]"]) == 100.0
    assert row["identifications"] == "3" and row["last_identified"] == "2026-11-22T12:00:02Z"
    assert row["interface"] == "HSK-A63"


def test_unknown_export_format_is_bad_input(filled, tmp_path):
    with pytest.raises(InputError, match="json, csv"):
        export_library(filled, tmp_path / "x.xml", format="xml")


# --------------------------------------------------------------------------- receptance


@pytest.fixture(scope="module")
def receptance():
    entry = make_entry(records=1)
    freq = frequency_grid(10.0, 20000.0, 5.0)
    return entry, freq, holder_receptance(entry, REFERENCE, freq)


def test_frequency_grid_is_exact_and_inclusive():
    f = frequency_grid()
    assert f[0] == 10.0 and f[-1] == 20000.0 and f.size == 3999
    assert np.all(np.diff(f) == 5.0)


def test_receptance_peaks_at_the_first_bending_mode_of_the_best_parameters(receptance):
    from taptune.model import analyse

    entry, freq, H = receptance
    f1 = analyse(REFERENCE, entry.params, entry.options()).bending_hz[0]
    band = freq > 1000.0  # above the rigid-body mass line
    f_peak = freq[band][np.argmax(np.abs(H[band]))]
    # Reference assembly with nominal parameters, alpha -6.5 %: f1 ≈ 4783 Hz; grid step 5 Hz.
    assert f1 == pytest.approx(4783, abs=20)
    assert abs(f_peak - f1) <= 5.0
    # The near-optimal sets put a band around it that holds the best parameters' f1.
    prediction = predict_setup(entry, *identified_setups(entry)[0])
    assert prediction.bending_hz_spread[0] > 0
    assert abs(prediction.bending_hz[0] - f1) <= prediction.bending_hz_spread[0]


def test_receptance_csv_reads_back_exactly(receptance, tmp_path):
    _, freq, H = receptance
    path = tmp_path / "r.csv"
    write_receptance_csv(path, freq, H)
    assert path.read_text().splitlines()[0] == "frequency [Hz],real [m/N],imag [m/N]"
    data = np.loadtxt(path, delimiter=",", skiprows=1)
    assert np.array_equal(data[:, 0], freq)
    assert np.array_equal(data[:, 1] + 1j * data[:, 2], H)


@pytest.mark.parametrize("binary, rtol", [(False, 1e-10), (True, 0.0)])
def test_uff58_reads_back_with_pyuff_to_the_same_receptance(receptance, tmp_path, binary, rtol):
    pyuff = pytest.importorskip("pyuff")
    _, freq, H = receptance
    path = tmp_path / "r.uff"
    write_receptance_uff58(path, freq, H, "ER32 with D16 at 53.5 mm", binary=binary)
    ds = pyuff.UFF(str(path)).read_sets()
    assert ds["type"] == 58 and ds["func_type"] == 4
    assert (ds["ordinate_spec_data_type"], ds["orddenom_spec_data_type"], ds["abscissa_spec_data_type"]) == (8, 13, 18)
    assert (ds["rsp_dir"], ds["ref_dir"]) == (1, 1)
    assert ds["id1"].strip() == "ER32 with D16 at 53.5 mm"
    np.testing.assert_allclose(ds["x"], freq, rtol=1e-12)
    np.testing.assert_allclose(ds["data"], H, rtol=rtol, atol=0)


def test_uff58_on_an_uneven_grid(tmp_path):
    pyuff = pytest.importorskip("pyuff")
    freq = np.array([10.0, 20.0, 45.0, 100.0])
    H = 1e-6 / (1 - (freq / 50.0) ** 2 + 0.02j)
    write_receptance(tmp_path / "u.unv", freq, H, "uneven")
    ds = pyuff.UFF(str(tmp_path / "u.unv")).read_sets()
    np.testing.assert_allclose(ds["x"], freq)
    np.testing.assert_allclose(ds["data"], H, rtol=1e-10)


def test_receptance_file_type_comes_from_the_extension(receptance, tmp_path):
    _, freq, H = receptance
    assert write_receptance(tmp_path / "a.CSV", freq, H, "x") == "csv"
    with pytest.raises(InputError, match=r"\.uff or \.unv .* or \.csv"):
        write_receptance(tmp_path / "a.txt", freq, H, "x")


def test_missing_pyuff_is_a_clear_error(receptance, tmp_path, monkeypatch):
    _, freq, H = receptance
    monkeypatch.setitem(sys.modules, "pyuff", None)  # makes `import pyuff` raise ImportError
    with pytest.raises(LibraryError, match="needs pyuff"):
        write_receptance_uff58(tmp_path / "r.uff", freq, H, "x")
    assert not (tmp_path / "r.uff").exists()


def test_provenance_setups_are_distinct_tool_and_stickout_pairs():
    entry = make_entry(records=0)
    records = (make_record(0, 53.5), make_record(1, 53.5), make_record(2, 63.5))
    entry = type(entry)(**{**entry.__dict__, "identifications": records})
    assert [s for _, s in identified_setups(entry)] == [53.5, 63.5]
