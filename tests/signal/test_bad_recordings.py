"""Recordings a tap analysis cannot trust, and what the user is told: a phone's low sample
rate (the spectrum ends below the bending modes) and an overloaded input (clipped taps)."""

from dataclasses import replace

import numpy as np
import pytest
from scipy.signal import resample_poly

from taptune.cli import main
from taptune.errors import InputError
from taptune.io.audio import make_recording, read_audio, write_audio
from taptune.signal.analysis import analyse_recording
from taptune.signal.taps import find_taps, full_scale_runs, to_mono

from .synthetic import BENDING, workshop_recording

#: An ER32 assembly's bending modes (docs/tap-test.md: f1 ≈ 4.7, f2 ≈ 14.9, f3 ≈ 19.9 kHz)
#: and its HSK-A63 interface mode: all above the 4 kHz an 8 kHz voice recording holds.
ER32 = ((4700.0, 0.004, 1.0), (14900.0, 0.002, 0.6), (19900.0, 0.003, 0.8))
#: A short, stiff tool: f1 above the 5.5 kHz of an 11.025 kHz recording.
STIFF = ((6500.0, 0.004, 1.0), (16900.0, 0.002, 0.6), (21900.0, 0.003, 0.8))


def _phone(modes, rate: int, up: int, down: int, path: str):
    """The 48 kHz workshop recording of ``modes`` as a phone recorder at ``rate`` keeps it."""
    rec = workshop_recording(0, modes=modes, extra=((9710.0, 0.0016, 2.0),))
    return make_recording(resample_poly(rec.samples[:, 0], up, down), rate, path=path)


@pytest.mark.parametrize("modes,rate,up,down,nyquist", [
    (ER32, 8000, 1, 6, "4000"),
    (STIFF, 11025, 147, 640, "5512.5"),
])
def test_a_phone_rate_below_the_bending_modes_says_so_not_only_no_tap(modes, rate, up, down, nyquist):
    with pytest.raises(InputError) as info:
        analyse_recording(_phone(modes, rate, up, down, "voice.wav"))
    message = str(info.value)
    assert message.startswith("voice.wav: no tap found: ") and "\n" not in message
    assert f"sample rate is {rate} Hz, so its spectrum ends at {nyquist} Hz, below what a tap analysis needs" in message
    assert "44100 Hz or more" in message and "clipped" not in message


def test_the_low_rate_message_names_the_file_on_the_command_line(tmp_path, capsys):
    path = tmp_path / "voice memo.wav"
    write_audio(path, _phone(ER32, 8000, 1, 6, "").samples, 8000, subtype="PCM_16")
    assert main(["spectrum", str(path)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and str(path) in err and "8000 Hz" in err and "4000 Hz" in err
    assert "Traceback" not in err


def test_a_supported_rate_still_says_no_tap_as_before():
    noise = np.random.default_rng(0).normal(0, 0.01, (96000, 1))
    with pytest.raises(InputError) as info:
        analyse_recording(make_recording(noise, 48000, path="noise.wav"))
    assert str(info.value) == "noise.wav: no tap found (the recording holds only noise or a steady sound)"


def test_a_mode_near_nyquist_at_8_khz_is_no_clipped_tap():
    # At 8 kHz the 3.52 kHz mode swings from its maximum to its minimum in one sample;
    # before, that pair counted as a two-sample flat top and a clean tap was left out.
    rec = workshop_recording(1)
    x = resample_poly(rec.samples[:, 0], 1, 6)
    taps = find_taps(to_mono(x, 8000), 8000, raw=x)
    assert len(taps) == 3 and not any(t.clipped for t in taps)


@pytest.mark.parametrize("level,clipped,used", [(3.0, 3, 3), (0.6 / 0.5, 1, 2)])
def test_clipped_taps_warn_naming_the_file_and_frequencies_still_come_out(level, clipped, used):
    # level x tap strengths (1, 0.7, 0.85) over full scale 1: all three, or only the first, clip.
    rec = replace(workshop_recording(4, level=level, clip=1.0), path="loud.wav")
    a = analyse_recording(rec)
    warning = [w for w in a.warnings if "clipped" in w]
    assert warning == [f"loud.wav: clipped at full scale in {clipped} of 3 taps: the levels are unreliable; tap softer "
                       "or lower the input gain" + (" (used anyway: no tap is clean)" if used == 3
                                                    else " (the clipped taps are left out of the average)")]
    assert a.n_taps == used
    # The bending frequencies are still measured (to 0.3 %: clipping distorts levels, not frequencies).
    f1 = min(a.bending_hz, key=lambda f: abs(f - BENDING[0][0]))
    assert f1 == pytest.approx(BENDING[0][0], rel=3e-3)


def test_no_tap_in_a_clipped_recording_says_it_is_clipped():
    # An input so hot that a 50 Hz hum saturates it: the flat tops hide every tap.
    fs = 48000
    t = np.arange(fs) / fs
    rng = np.random.default_rng(3)
    x = np.clip(4.0 * np.sin(2 * np.pi * 50 * t) + rng.normal(0, 0.01, t.size), -1.0, 1.0)
    assert full_scale_runs(x) == 100  # two flat tops per cycle, 50 cycles
    with pytest.raises(InputError) as info:
        analyse_recording(make_recording(x, fs, path="hot.wav"))
    assert str(info.value) == ("hot.wav: no tap found: it is clipped at full scale (100 flat tops of 3 or more samples): "
                               "the input is overloaded; lower the input gain and tap softer")


def test_a_loud_clean_ring_down_has_no_full_scale_run():
    fs = 48000
    t = np.arange(fs // 4) / fs
    x = 0.98 * np.exp(-t / 0.02) * np.sin(2 * np.pi * 3520 * t)
    assert full_scale_runs(x) == 0
    assert full_scale_runs(np.clip(1.5 * x, -1, 1)) > 0


def test_a_wav_read_back_keeps_the_clipping_warning(tmp_path):
    path = tmp_path / "loud.wav"
    rec = workshop_recording(4, level=3.0, clip=1.0)
    write_audio(path, rec.samples, rec.sample_rate, subtype="PCM_16")
    a = analyse_recording(read_audio(path))
    assert any(w.startswith(f"{path}: clipped at full scale in 3 of 3 taps") for w in a.warnings)
