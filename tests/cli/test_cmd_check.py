"""taptune check: verdicts with exit 0, one check more in the history per run, one line and exit 2 for bad input."""

import json

import numpy as np
import pytest

from taptune.cli import main
from taptune.library import HolderLibrary
from tests.identify.check_setup import HOLDER_NAME, identified_holder, tap_file


@pytest.fixture(scope="module")
def setup(tmp_path_factory):
    """A library holding holder A (identified once per session) and its folder of taps."""
    folder, toml, _, entry = identified_holder()
    lib = tmp_path_factory.mktemp("lib") / "holders.json"
    HolderLibrary(lib).put(entry)
    return folder, toml, lib


def _doc(lib):
    return json.loads(lib.read_text())


def _run(args, capsys):
    code = main(args)
    captured = capsys.readouterr()
    return code, captured.out, captured.err


def _without_checks(doc):
    """The document without the check history (and the format version, 2 once there are checks)."""
    for h in doc["holders"].values():
        h.pop("checks", None)
    doc.pop("version")
    return doc


def test_good_and_worn_taps_give_their_verdicts_and_grow_the_history(setup, tmp_path, capsys):
    folder, _, lib = setup
    before = _doc(lib)
    good_wav, good_toml = tap_file(folder, 63.5)
    out = tmp_path / "check.json"
    code, text, _ = _run(["check", str(good_wav), "--assembly", str(good_toml), "--holder", HOLDER_NAME,
                          "--library", str(lib), "--json", str(out)], capsys)
    assert code == 0
    d = json.loads(out.read_text())
    assert d["verdict"] == "consistent" and d["holder"] == HOLDER_NAME and d["stickout"] == 63.5
    assert [m["mode"] for m in d["modes"]] == [1, 2, 3]
    assert {"measured_hz", "predicted_hz", "band_hz", "deviation_pct", "z"} <= set(d["modes"][0])
    # The band is the prediction's honest band as it stands, with its make-up.
    assert [m["band_hz"] for m in d["modes"]] == d["band"]["half_width_hz"]
    assert {"set", "geometry", "model_form"} == set(d["band"]["components_hz"])
    assert "verdict: consistent" in text and "predicted [Hz]" in text and "holds the true frequency" in text
    after = _doc(lib)
    checks = after["holders"][HOLDER_NAME]["checks"]
    assert len(checks) == 1 and checks[0]["verdict"] == "consistent" and checks[0]["recording"] == good_wav.name
    assert checks[0]["tool"] == "solid carbide end mill D16 4FL" and checks[0]["stickout_mm"] == 63.5
    assert _without_checks(after) == _without_checks(before), "a check changes nothing but the history"

    worn_wav, worn_toml = tap_file(folder, 63.5, factor=0.5)
    code, text, _ = _run(["check", str(worn_wav), "--assembly", str(worn_toml), "--holder", HOLDER_NAME,
                          "--library", str(lib), "--json", "-"], capsys)
    assert code == 0 and json.loads(text)["verdict"] == "differs"
    assert [c["verdict"] for c in _doc(lib)["holders"][HOLDER_NAME]["checks"]] == ["consistent", "differs"]

    code, text, _ = _run(["library", "show", HOLDER_NAME, "--library", str(lib), "--no-predict"], capsys)
    assert code == 0 and "checks by one tap (2)" in text and "differs" in text and worn_wav.name in text


def test_a_tap_without_bending_peaks_is_inconclusive(setup, tmp_path, capsys):
    """Only the interface's local modes ring: no verdict on the holder, but a verdict (exit 0)."""
    from taptune.io.audio import write_audio
    from taptune.signal.synth import Nuisances, modal_receptance, synthesize_recording, tap_grid
    from taptune.synthetic import HSK_A63_LOCAL_MODES

    _, toml, lib = setup
    nuisances = Nuisances(duration_s=1.3, tap_times_s=(0.15, 0.55, 0.95), snr_db=36.0)
    grid = tap_grid(nuisances.sample_rate)
    h = modal_receptance(grid, [(f, z, 1.0) for f, z, _ in HSK_A63_LOCAL_MODES])
    rec = synthesize_recording(grid, h, nuisances, np.random.default_rng(4), extra_modes=())
    wav = tmp_path / "interface_only.wav"
    write_audio(wav, rec.samples, rec.sample_rate)
    code, text, err = _run(["check", str(wav), "--assembly", str(toml), "--holder", HOLDER_NAME,
                            "--library", str(lib), "--json", "-", "--no-save"], capsys)
    assert code == 0, err
    d = json.loads(text)
    assert d["verdict"] == "inconclusive" and all(m["measured_hz"] is None for m in d["modes"])


def test_bad_inputs_exit_2_with_one_line_and_leave_the_library_alone(setup, tmp_path, capsys):
    folder, toml, lib = setup
    wav, _ = tap_file(folder, 63.5)
    broken_wav = tmp_path / "broken.wav"
    broken_wav.write_bytes(wav.read_bytes()[:30])
    broken_lib = tmp_path / "broken.json"
    broken_lib.write_text('{"schema": "taptune-holder-library", "version": 1, "holders": {')
    raw = lib.read_bytes()
    cases = [
        (["check", str(wav), "--assembly", str(toml), "--holder", "ER32", "--library", str(lib)], "did you mean"),
        (["check", str(broken_wav), "--assembly", str(toml), "--holder", HOLDER_NAME, "--library", str(lib)],
         "not a readable audio file"),
        (["check", str(wav), "--assembly", str(toml), "--holder", HOLDER_NAME, "--library", str(broken_lib)],
         "not valid JSON"),
        (["check", str(wav), "--assembly", str(tmp_path / "none.toml"), "--holder", HOLDER_NAME, "--library", str(lib)],
         "none.toml"),
    ]
    for args, fragment in cases:
        code, _, err = _run(args, capsys)
        assert code == 2 and err.count("\n") == 1 and fragment in err and "Traceback" not in err, (args, err)
    assert lib.read_bytes() == raw
