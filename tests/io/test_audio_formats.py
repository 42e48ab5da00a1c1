"""Phone recordings: the same taps as M4A (AAC), MP3, Opus and MP4 video give the WAV's peaks.

The taps are the model's (an asset assembly with nominal holder parameters plus workshop
noise), encoded here with PyAV at phone bit rates. Lossy codecs keep the phase and
frequency of strong, slowly decaying partials; they drop what lies above their low-pass
cut-off, and the analysis must say so when a bending mode lies there.
"""

import numpy as np
import pytest

av = pytest.importorskip("av")

from taptune.cli import main  # noqa: E402
from taptune.errors import InputError  # noqa: E402
from taptune.io.audio import read_audio, write_audio  # noqa: E402
from tests.conftest import REPO  # noqa: E402

FS = 48000
#: The WAV's bending frequencies must be reproduced to this (the peaks' own accuracy).
REL_TOL = 5e-4


def _picture_stream(container):
    picture = container.add_stream("mpeg4", rate=25)
    picture.width = picture.height = 32
    picture.pix_fmt = "yuv420p"
    return picture


def _mux_black_frames(container, picture, count):
    for i in range(count):
        frame = av.VideoFrame.from_ndarray(np.zeros((32, 32, 3), np.uint8), format="rgb24")
        frame.pts = i
        for packet in picture.encode(frame):
            container.mux(packet)
    for packet in picture.encode(None):
        container.mux(packet)


def encode(path, samples, codec, bit_rate, options=None, video=False):
    """Encode mono float samples in [-1, 1] with PyAV (``codec`` e.g. "aac", "libmp3lame", "libopus")."""
    with av.open(str(path), "w") as container:
        picture = _picture_stream(container) if video else None
        stream = container.add_stream(codec, rate=FS, layout="mono")
        stream.bit_rate = bit_rate
        if options:
            stream.codec_context.options = options
        if video:
            _mux_black_frames(container, picture, 10)
        frame = av.AudioFrame.from_ndarray(np.asarray(samples, np.float32)[None, :], format="flt", layout="mono")
        frame.sample_rate = FS
        for packet in stream.encode(frame):
            container.mux(packet)
        for packet in stream.encode(None):
            container.mux(packet)
    return path


@pytest.fixture(scope="module")
def taps(tmp_path_factory):
    """The WAV, its encodings, the assembly, the model guidance and the WAV's analysis."""
    from taptune.identify.pipeline import analyse_for_assembly, model_expectation
    from taptune.io.assembly import load_assembly
    from taptune.model.params import NOMINAL
    from taptune.signal.synth import Nuisances
    from taptune.synthetic import simulate_tap_recording

    folder = tmp_path_factory.mktemp("phone")
    # 63.5 mm stick-out: f3 near 17.6 kHz, below every codec's cut-off at these rates.
    asm = load_assembly(REPO / "assets" / "er32_hsk63_d16.toml").with_stickout(0.0635)
    nuisances = Nuisances(duration_s=1.3, tap_times_s=(0.15, 0.55, 0.95), snr_db=40.0, contact_s=50e-6,
                          radiation_exponent=2.0, mic_lp_hz=20000.0)
    rec = simulate_tap_recording(asm, NOMINAL, nuisances, np.random.default_rng(3))
    wav = folder / "tap.wav"
    write_audio(wav, rec.samples, FS, "PCM_24")
    x = read_audio(wav).samples[:, 0]
    files = {
        "aac": encode(folder / "tap.m4a", x, "aac", 160_000),
        "mp3": encode(folder / "tap.mp3", x, "libmp3lame", 192_000),
        "opus": encode(folder / "tap.opus", x, "libopus", 128_000),
        "video": encode(folder / "clip.mp4", x, "aac", 128_000, video=True),
        "lowpass": encode(folder / "memo.m4a", x, "aac", 128_000, options={"cutoff": "12000"}),
    }
    guidance = model_expectation(asm)
    reference = analyse_for_assembly(read_audio(wav), asm, guidance=guidance)
    return files, asm, guidance, reference


@pytest.mark.parametrize("kind,codec", [("aac", "aac"), ("mp3", "mp3"), ("opus", "opus"), ("video", "aac")])
def test_lossy_copies_give_the_wav_labels_and_frequencies(taps, kind, codec):
    from taptune.identify.pipeline import analyse_for_assembly

    files, asm, guidance, reference = taps
    rec = read_audio(files[kind])
    assert rec.sample_rate == FS and rec.channels == 1 and rec.codec == codec and rec.lossy
    assert rec.samples.dtype == np.float64 and 0.05 < np.max(np.abs(rec.samples)) <= 1.0
    analysis = analyse_for_assembly(rec, asm, guidance=guidance)
    want = reference.bending_by_mode()
    got = analysis.bending_by_mode()
    assert sorted(want) == [1, 2, 3] and sorted(got) == sorted(want)
    for mode, f in want.items():
        assert got[mode] == pytest.approx(f, rel=REL_TOL), (kind, mode)
    assert not any("low-pass" in w for w in analysis.warnings)
    assert analysis.bandwidth_hz > 18000.0


def test_a_codec_low_pass_below_a_bending_mode_is_reported(taps):
    from taptune.identify.pipeline import analyse_for_assembly

    files, asm, guidance, reference = taps
    analysis = analyse_for_assembly(read_audio(files["lowpass"]), asm, guidance=guidance)
    assert 11500.0 <= analysis.bandwidth_hz <= 13000.0
    assert analysis.to_dict()["bandwidth_hz"] == pytest.approx(analysis.bandwidth_hz)
    hidden = [w for w in analysis.warnings if "low-pass" in w]
    # f2 (13.2 kHz) and f3 (17.6 kHz) lie above the 12 kHz cut-off.
    assert len(hidden) == 2 and all("AAC low-pass?" in w and "memo.m4a" in w for w in hidden)
    assert "bending mode 3 expected near 17.6 kHz cannot be measured" in hidden[1]
    # What the recording does carry is still measured as in the WAV.
    assert analysis.bending_by_mode()[1] == pytest.approx(reference.bending_by_mode()[1], rel=REL_TOL)
    assert reference.bandwidth_hz == FS / 2


def test_a_phone_file_with_a_wav_name_is_still_read(taps, tmp_path):
    files, *_ = taps
    renamed = tmp_path / "tap.wav"
    renamed.write_bytes(files["aac"].read_bytes())
    assert read_audio(renamed).codec == "aac"


def test_a_short_opus_file_libsndfile_calls_malformed_is_read(tmp_path):
    # libsndfile refuses some valid Ogg Opus files of about half a second as "malformed"
    # (a real one-tap recording's Opus copy); FFmpeg reads them.
    x = np.random.default_rng(0).normal(0, 0.1, int(0.53 * FS))
    rec = read_audio(encode(tmp_path / "tap.opus", x, "libopus", 96_000))
    assert rec.codec == "opus" and rec.lossy and rec.duration_s == pytest.approx(0.53, abs=0.03)


def test_without_pyav_the_message_says_what_to_install(taps, monkeypatch):
    import sys

    monkeypatch.setitem(sys.modules, "av", None)
    with pytest.raises(InputError, match="needs PyAV"):
        read_audio(taps[0]["aac"])


def test_bad_phone_files_exit_2_with_one_line(taps, tmp_path, capsys):
    files, *_ = taps
    empty = tmp_path / "empty.m4a"
    empty.write_bytes(b"")
    corrupt = tmp_path / "corrupt.m4a"
    corrupt.write_bytes(b"not an mpeg-4 file " * 100)
    # The moov atom is at the end of these files: cut it off and nothing can be decoded.
    cut = tmp_path / "cut.m4a"
    cut.write_bytes(files["aac"].read_bytes()[:4000])
    no_audio = tmp_path / "film_no_sound.mov"
    with av.open(str(no_audio), "w") as container:
        _mux_black_frames(container, _picture_stream(container), 3)
    expected = {empty: "empty", corrupt: "not a readable audio file", cut: "not a readable audio file",
                no_audio: "a video without sound"}
    for path, fragment in expected.items():
        assert main(["spectrum", str(path)]) == 2, path
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and str(path) in err and fragment in err and "Traceback" not in err, err


@pytest.mark.parametrize("delay_s,strength", [(0.004, 0.5), (0.025, 0.45)])
def test_a_real_double_hit_is_still_found_through_aac(tmp_path, delay_s, strength):
    """AAC smears the impact over a few ms; a second impact is still an event of its own."""
    from taptune.signal.taps import find_taps, to_mono
    from tests.signal.synthetic import workshop_recording

    rec = workshop_recording(6, double_hits=((1, delay_s, strength),), reflections=((0.9e-3, 0.3), (8e-3, 0.1)))
    aac = read_audio(encode(tmp_path / "bounce.m4a", rec.samples[:, 0], "aac", 96_000))
    taps = find_taps(to_mono(aac.samples, FS), FS, raw=aac.samples, subtype=aac.subtype)
    assert len(taps) == 3 and taps[1].double_hit and not taps[1].used


def test_an_audio_stream_without_a_known_codec_exits_2_with_one_line(taps, tmp_path, capsys):
    # A damaged sample-table box name: FFmpeg still lists the audio stream but finds no
    # codec for it (PyAV gives it no codec context); found by flipping bytes of an M4A.
    data = taps[0]["aac"].read_bytes()
    assert data.count(b"stbl") == 1
    damaged = tmp_path / "damaged.m4a"
    damaged.write_bytes(data.replace(b"stbl", b"\xf6tbl"))
    assert main(["spectrum", str(damaged)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "unknown audio codec" in err and "Traceback" not in err, err


def test_a_recording_too_long_for_a_tap_test_is_refused_before_it_fills_the_memory(taps, tmp_path, monkeypatch):
    """10 min at 96 kHz stereo took 4 GB; a phone's hour would take all. Refused by its
    length (read from the header, or while decoding), naming the file."""
    from taptune.io import audio

    import re

    monkeypatch.setattr(audio, "MAX_SECONDS", 0.5)  # the files here are 1.3 s long
    for kind in ("aac", "mp3", "video"):
        path = taps[0][kind]
        with pytest.raises(InputError, match=rf"{re.escape(str(path))}: 0\.0 min long; taptune reads tap "
                                             r"recordings of up to .* cut the file to the taps"):
            read_audio(path)
    wav = tmp_path / "long.wav"
    write_audio(wav, np.zeros((48000, 1)), 48000)  # 1 s
    with pytest.raises(InputError, match=r"long.wav: 0.0 min long"):
        read_audio(wav)
