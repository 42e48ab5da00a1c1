"""``taptune cut``: the JSON contract, the rule's suggestion, the holder's lobes and history, bad input."""

from __future__ import annotations

import json

import pytest

from benchmarks.cut.sounds import lines_cut
from taptune.io.audio import write_audio
from taptune.library.store import HolderLibrary
from tests.conftest import REPO
from tests.library.entries import make_entry
from tests.cli_run import one_line_error, taptune

HOLDER = "ER32 collet chuck HSK-A63 x 100"
MACHINE = ["--assembly", REPO / "recordings" / "er32_d16.toml", "--machine", REPO / "recordings" / "machine" / "machine.toml"]
CUT = ["--depth", 2, "--ae", 8, "--milling", "down", "--material", "al7075"]
KEYS = {"verdict", "chatter_hz", "spindle_rpm", "tooth_passing_hz", "chatter_level_db", "suggested_rpm",
        "suggestion_basis", "warnings"}


@pytest.fixture(scope="module")
def cuts(tmp_path_factory):
    folder = tmp_path_factory.mktemp("cuts")
    out = {}
    for name, kw in {"stable": {}, "chatter": dict(chatter_hz=1234.0, chatter_db=12.0),
                     "tool": dict(chatter_hz=4390.0, chatter_db=12.0), "elsewhere": dict(chatter_hz=2210.0, chatter_db=12.0)}.items():
        rpm, teeth = (8000, 3) if name in ("stable", "chatter") else (10000, 4)
        rec, _ = lines_cut(rpm, teeth, seed=11, **kw)
        path = folder / f"{name}.wav"
        write_audio(path, rec.samples, rec.sample_rate)
        out[name] = path
    return out


@pytest.fixture
def library(tmp_path):
    lib = HolderLibrary(tmp_path / "holders.json")
    lib.put(make_entry(HOLDER))
    return lib


def test_a_chatter_gives_the_contract_and_speeds_by_the_rule(cuts, tmp_path, capsys):
    out = tmp_path / "cut.json"
    code, text, err = taptune(capsys, "cut", cuts["chatter"], "--rpm", 8000, "--teeth", 3, "--max-rpm", 12000,
                              "--json", out)
    assert code == 0, err
    data = json.loads(out.read_text())
    assert KEYS <= set(data)
    assert data["verdict"] == "chatter" and abs(data["chatter_hz"] / 1234.0 - 1) < 0.01
    assert data["suggestion_basis"] == "rule"
    # n = 60 f_c / (Z j): 24680/j, within the range, nearest the present speed first.
    assert data["suggested_rpm"][0] == pytest.approx(8227, abs=2)
    assert all(n <= 12000 for n in data["suggested_rpm"])
    assert "CHATTER at 1234 Hz" in text


def test_a_stable_cut_says_so_with_null_chatter(cuts, capsys):
    code, text, err = taptune(capsys, "cut", cuts["stable"], "--rpm", 8000, "--teeth", 3, "--json", "-")
    data = json.loads(text)
    assert code == 0 and data["verdict"] == "stable" and data["chatter_hz"] is None and data["suggested_rpm"] == []


@pytest.mark.parametrize("argv, words", [
    (["--rpm", 8000, "--teeth", 5], "check --rpm and --teeth"),
    (["--rpm", 5000, "--teeth", 3], "check --rpm and --teeth"),
    (["--rpm", 8000, "--teeth", 3, "--holder", "nope", *MACHINE, *CUT], "no holder 'nope'"),
    (["--rpm", 8000, "--teeth", 3, "--holder", HOLDER, *CUT], "missing --assembly, --machine"),
    (["--rpm", 8000, "--teeth", 3, "--holder", HOLDER, *MACHINE], "the cut needs --depth"),
])
def test_bad_input_is_one_line_and_saves_nothing(cuts, library, capsys, argv, words):
    raw = library.path.read_bytes()
    err = one_line_error(capsys, "cut", cuts["chatter"], *argv, "--library", library.path)
    assert words in err
    assert library.path.read_bytes() == raw


def test_a_recording_without_a_cut_is_refused(tmp_path, capsys):
    import numpy as np

    from benchmarks.cut.sounds import shop_sound

    idle = shop_sound(np.zeros(2 * 44100), 8000, 3, rng=np.random.default_rng(1), idle_before_s=0.5, idle_after_s=0.5)
    write_audio(tmp_path / "idle.wav", idle[:, None], 44100)
    err = one_line_error(capsys, "cut", tmp_path / "idle.wav", "--rpm", 8000, "--teeth", 3)
    assert "idle.wav" in err


@pytest.mark.slow
def test_with_the_holder_the_lobes_suggest_and_the_cut_is_kept(cuts, library, tmp_path, capsys):
    out = tmp_path / "cut.json"
    code, text, err = taptune(capsys, "cut", cuts["tool"], "--rpm", 10000, "--teeth", 4, "--holder", HOLDER, *MACHINE,
                              *CUT, "--library", library.path, "--json", out, "--plot", tmp_path / "lobes.png")
    assert code == 0, err
    data = json.loads(out.read_text())
    assert data["suggestion_basis"] == "lobes" and data["suggested_rpm"]
    assert (tmp_path / "lobes.png").stat().st_size > 10_000
    assert data["analysis"]["lobes"]["chatter_matches_tool_mode"] is True  # 4390 Hz: the tool's mode near 4.3 kHz
    # The holder's band, weighed by this cut (the only one of its kind so far).
    lobes = data["analysis"]["lobes"]
    assert lobes["observed_cuts_used"] <= 1 and lobes["band_width_after_pct"] <= lobes["band_width_before_pct"] + 1e-9
    (obs,) = library.get(HOLDER).observations
    assert obs.verdict == "chatter" and obs.depth_mm == 2 and obs.teeth == 4 and obs.material == "al7075"
    # A chatter far from every tool mode: the holder cannot help; --no-save keeps the history as it is.
    code, text, err = taptune(capsys, "cut", cuts["elsewhere"], "--rpm", 10000, "--teeth", 4, "--holder", HOLDER,
                              *MACHINE, *CUT, "--library", library.path, "--no-save", "--json", out)
    assert code == 0 and "matches no tool-point mode" in err
    assert json.loads(out.read_text())["analysis"]["lobes"]["chatter_matches_tool_mode"] is False
    assert len(library.get(HOLDER).observations) == 1
