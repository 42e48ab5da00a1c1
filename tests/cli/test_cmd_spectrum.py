"""taptune spectrum: the docs/cli.md JSON, the plot, and one line with exit 2 for bad files."""

import json

import numpy as np
import pytest

from taptune.cli import main
from taptune.io.audio import write_audio
from tests.signal.synthetic import workshop_recording


@pytest.fixture(scope="module")
def tap_wav(tmp_path_factory):
    path = tmp_path_factory.mktemp("rec") / "tap.wav"
    rec = workshop_recording(21, reflections=((0.7e-3, 0.25),))
    write_audio(path, rec.samples, rec.sample_rate, "PCM_24")
    return path


def test_json_per_contract_and_plot(tap_wav, tmp_path, capsys):
    out, png = tmp_path / "s.json", tmp_path / "s.png"
    assert main(["spectrum", str(tap_wav), "--json", str(out), "--plot", str(png)]) == 0
    d = json.loads(out.read_text())
    assert {"file", "sample_rate", "channels", "taps", "peaks", "warnings"} <= set(d)
    assert d["file"] == str(tap_wav) and d["sample_rate"] == 48000 and d["channels"] == 1 and d["taps"] == 3
    kinds = {p["kind"] for p in d["peaks"]}
    assert kinds == {"bending", "local", "other"}
    assert all({"hz", "level_db", "kind"} <= set(p) for p in d["peaks"])
    bending = [p["hz"] for p in d["peaks"] if p["kind"] == "bending"]
    assert bending == pytest.approx([3520.0, 10950.0, 15300.0], rel=3e-4)
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and png.stat().st_size > 20000
    assert "bending: f1 =" in capsys.readouterr().out


def test_json_to_stdout_is_only_json(tap_wav, capsys):
    assert main(["spectrum", str(tap_wav), "--json", "-"]) == 0
    assert json.loads(capsys.readouterr().out)["taps"] == 3


def test_assembly_guides_the_labels(tap_wav, reference_toml, capsys):
    # The reference assembly's model is far from this synthetic tool: the labels still
    # come out, with the model's frequencies reported beside them.
    assert main(["spectrum", str(tap_wav), "--assembly", str(reference_toml), "--json", "-"]) == 0
    d = json.loads(capsys.readouterr().out)
    assert len(d["model_bending_hz"]) == 3 and len(d["model_bounds_hz"]) == 3
    assert d["interface"] == "HSK-A63"


def _bad_files(tmp_path):
    empty = tmp_path / "empty.wav"
    empty.write_bytes(b"")
    text = tmp_path / "notes.wav"
    text.write_text("not audio\n" * 50)
    trunc = tmp_path / "trunc.wav"
    write_audio(trunc, np.zeros(1000), 48000)
    trunc.write_bytes(trunc.read_bytes()[:20])
    silent = tmp_path / "silent.wav"
    write_audio(silent, np.zeros(48000), 48000)
    noise = tmp_path / "noise.flac"
    write_audio(noise, np.random.default_rng(0).normal(0, 0.05, 96000), 48000)
    short = tmp_path / "short.wav"
    write_audio(short, 0.1 * np.ones(200), 48000)
    low = tmp_path / "low.wav"
    write_audio(low, np.zeros(4000), 4000)
    nan = tmp_path / "nan.wav"
    x = np.zeros(48000)
    x[10] = np.nan
    write_audio(nan, x, 48000, "FLOAT")
    return [tmp_path / "missing.wav", empty, text, trunc, silent, noise, short, low, nan]


def test_every_bad_file_exits_2_with_one_line(tmp_path, capsys):
    for path in _bad_files(tmp_path):
        assert main(["spectrum", str(path)]) == 2, path
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and str(path) in err and "Traceback" not in err, err


def test_bad_band_table_and_interface_tap(tap_wav, tmp_path, capsys):
    bad = tmp_path / "bands.toml"
    bad.write_text("x = [[3, 1]]")
    assert main(["spectrum", str(tap_wav), "--bands", str(bad)]) == 2
    assert str(bad) in capsys.readouterr().err
    assert main(["spectrum", str(tap_wav), "--interface-tap", str(tmp_path / "none.wav")]) == 2


def test_an_output_never_overwrites_the_band_table_the_environment_names(tap_wav, tmp_path, capsys, monkeypatch):
    table = tmp_path / "bands.toml"
    table.write_text('"HSK-A63" = [[9400, 10600]]\n')
    monkeypatch.setenv("TAPTUNE_INTERFACE_BANDS", str(table))
    assert main(["spectrum", str(tap_wav), "--json", str(table)]) == 2
    err = capsys.readouterr().err
    assert "is also an input of this command" in err and err.count("\n") == 1
    assert table.read_text() == '"HSK-A63" = [[9400, 10600]]\n'
