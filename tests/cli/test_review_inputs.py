"""Bad inputs and outputs found in review: each is one line with exit 2, and nothing saved is lost."""

import json

import numpy as np
import pytest

from taptune.cli import main
from taptune.errors import InputError
from taptune.io.assembly import load_assembly
from taptune.io.audio import write_audio
from taptune.library.schema import HolderEntry
from taptune.library.store import HolderLibrary
from taptune.model.params import NOMINAL
from tests.conftest import REFERENCE_TOML
from tests.signal.synthetic import workshop_recording


@pytest.fixture(scope="module")
def tap_wav(tmp_path_factory):
    path = tmp_path_factory.mktemp("rec") / "tap.wav"
    rec = workshop_recording(21)
    write_audio(path, rec.samples, rec.sample_rate, "PCM_24")
    return path


@pytest.fixture
def library(tmp_path, reference_toml):
    """A library holding the reference holder with nominal parameters."""
    lib = HolderLibrary(tmp_path / "lib.json")
    lib.put(HolderEntry.create(load_assembly(reference_toml).holder, NOMINAL, (NOMINAL,)))
    return lib


def one_line_exit_2(capsys, code, *needles):
    err = capsys.readouterr().err
    assert code == 2, err
    assert len(err.strip().splitlines()) == 1 and "Traceback" not in err
    for needle in needles:
        assert needle in err
    return err


def test_exporting_onto_the_library_itself_is_refused_and_keeps_it(library, capsys):
    before = library.path.read_bytes()
    code = main(["library", "export", str(library.path), "--format", "csv", "--library", str(library.path)])
    one_line_exit_2(capsys, code, "is the holder library")
    assert library.path.read_bytes() == before


def test_identify_outputs_may_not_overwrite_the_library(library, tap_wav, reference_toml, capsys):
    before = library.path.read_bytes()
    code = main(["identify", str(tap_wav), "--assembly", str(reference_toml), "--library", str(library.path),
                 "--json", str(library.path)])
    one_line_exit_2(capsys, code, "is the holder library")
    assert library.path.read_bytes() == before


def test_plot_onto_a_folder_is_refused_and_into_a_new_folder_works(tap_wav, tmp_path, capsys):
    one_line_exit_2(capsys, main(["spectrum", str(tap_wav), "--plot", str(tmp_path)]), "is a folder")
    png = tmp_path / "new" / "deeper" / "s.png"
    assert main(["spectrum", str(tap_wav), "--plot", str(png)]) == 0
    assert png.stat().st_size > 10_000


def test_a_binary_band_table_is_a_clear_error(tap_wav, capsys):
    one_line_exit_2(capsys, main(["spectrum", str(tap_wav), "--bands", str(tap_wav)]), "not a UTF-8 text file")


def test_bad_model_options_in_the_library_are_a_clear_error(library, reference_toml, capsys):
    data = json.loads(library.path.read_text())
    entry = next(iter(data["holders"].values()))
    entry["model_options"] = {"h_max_mm": "abc"}
    library.path.write_text(json.dumps(data))
    code = main(["predict", str(reference_toml), "--holder", entry["name"], "--library", str(library.path)])
    one_line_exit_2(capsys, code, "h_max_mm must be a number")


def test_predict_reports_the_warnings_of_each_stickout(library, reference_toml, capsys):
    # At 20 mm the 32 mm flutes reach 12 mm into the holder: the user must hear of it.
    out = library.path.parent / "p.json"
    assert main(["predict", str(reference_toml), "--holder", "ER32 collet chuck HSK-A63 x 100",
                 "--library", str(library.path), "--stickout", "20", "--json", str(out)]) == 0
    assert any("flutes" in w for w in json.loads(out.read_text())["warnings"])


def test_a_negative_poisson_ratio_is_rejected(tmp_path, capsys):
    bad = tmp_path / "bad.toml"
    bad.write_text(REFERENCE_TOML.replace('[tool]', '[tool]\nmaterial = { poisson = -0.9 }'))
    one_line_exit_2(capsys, main(["model", str(bad)]), "[tool] material.poisson")


def test_record_lists_devices_without_out_and_asks_for_out_otherwise(capsys):
    assert main(["record", "--list-devices"]) == 0
    one_line_exit_2(capsys, main(["record"]), "--out")


def test_a_broken_demo_truth_file_is_reported_before_any_work(tmp_path, capsys):
    folder = tmp_path / "demo"
    folder.mkdir()
    (folder / "demo.json").write_text(json.dumps({"cases": [
        {"recording": "r.wav", "assembly": "a.toml", "truth": "t.json", "predict_stickouts_mm": [60]}]}))
    (folder / "a.toml").write_text(REFERENCE_TOML)
    write_audio(folder / "r.wav", workshop_recording(3).samples, 48000, "PCM_16")
    (folder / "t.json").write_text("{bad")
    one_line_exit_2(capsys, main(["demo", "--recordings", str(folder)]), "t.json: not valid JSON")


def test_bending_modes_outside_one_to_three_are_rejected():
    from taptune.identify.objective import make_target

    f = np.arange(1.0, 20000.0)
    with pytest.raises(InputError, match="outside 1–3"):
        make_target(f, np.ones_like(f), {1: 5000.0, 4: 18000.0})


def test_a_failed_model_evaluation_is_a_bad_candidate_not_a_crash():
    from taptune.identify.objective import Objective, make_target

    class Failing:
        def evaluate(self, p, window_hz):
            raise np.linalg.LinAlgError("singular")

    f = np.arange(1.0, 20000.0)
    objective = Objective([make_target(f, np.ones_like(f), {1: 5000.0})], [Failing()])
    assert objective(np.zeros(7)) == Objective.BAD
    # The near-optimal set's limits use the same guard: a failure lies outside the set.
    assert np.all(objective.summed_terms(np.zeros(7)) == Objective.BAD)


@pytest.mark.parametrize("key, value", [("k_tt", 1e300), ("density_factor", 1e-300), ("eta_rr", 5.0)])
def test_absurd_parameters_are_a_clear_error(tmp_path, reference_toml, capsys, key, value):
    params = tmp_path / "p.json"
    params.write_text(json.dumps({**NOMINAL.to_dict(), key: value}))
    one_line_exit_2(capsys, main(["model", str(reference_toml), "--params", str(params)]), key, "not plausible")
