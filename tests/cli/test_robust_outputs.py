"""Outputs that must not destroy anything: no command writes onto the holder library, and
``taptune record`` writes nothing before the first tap."""

import json
import os

import pytest

from taptune.cli import main
from taptune.errors import InputError
from taptune.io import recording
from taptune.io.assembly import load_assembly
from taptune.io.recording import FakeInputStream, InputDevice, Recorder, TriggerSettings
from taptune.library.schema import HolderEntry
from taptune.library.store import HolderLibrary
from taptune.model.params import NOMINAL
from tests.cli.test_review_inputs import one_line_exit_2
from tests.io.test_recording import FS, synthetic_taps


@pytest.fixture
def library(tmp_path, reference_toml):
    lib = HolderLibrary(tmp_path / "lib" / "holders.json")
    lib.put(HolderEntry.create(load_assembly(reference_toml).holder, NOMINAL, (NOMINAL,)))
    return lib




# --------------------------------------------------------------------------- the library is never an output


@pytest.mark.parametrize("argv", [
    ["model", "{toml}", "--json", "{lib}", "--library", "{lib}"],
    ["predict", "{toml}", "--holder", "x", "--json", "{lib}", "--library", "{lib}"],
    ["predict", "{toml}", "--holder", "x", "--plot", "{lib}", "--library", "{lib}"],
    ["toolpoint", "{toml}", "--machine", "{toml}", "--csv", "{lib}", "--library", "{lib}"],
    ["spectrum", "{toml}", "--json", "{lib}"],            # no --library: $TAPTUNE_LIBRARY
    ["model", "{toml}", "--json", "{lib}"],
    ["lobes", "{toml}", "--machine", "{toml}", "--teeth", "4", "--ae", "2", "--milling", "down", "--json", "{lib}"],
    ["spindle", "--dummy", "{toml}", "--aa", "{toml}", "--ab", "{toml}", "--bb", "{toml}", "--points", "10", "20",
     "--out", "{lib}.csv"],
    ["library", "export", "{lib}", "--library", "{other}"],  # the default library while exporting another
    ["library", "receptance", "x", "--assembly", "{toml}", "--out", "{lib}.csv", "--library", "{other}"],
    ["model", "{toml}", "--json", "{lib}.lock", "--library", "{lib}"],
    ["demo", "--json", "{lib}"],
])
def test_no_command_writes_its_output_onto_the_holder_library(argv, library, reference_toml, tmp_path,
                                                              monkeypatch, capsys):
    # Before, model/predict/spectrum/lobes/toolpoint/demo --json and a library export
    # onto the default library replaced the library with their output.
    monkeypatch.setenv("TAPTUNE_LIBRARY", str(library.path))
    lib = str(library.path)
    if argv[0] == "spindle" or argv[:2] == ["library", "receptance"]:
        os.link(library.path, tmp_path / "hardlink.csv")  # another name of the same file
        lib = str(tmp_path / "hardlink")
    argv = [a.format(toml=reference_toml, lib=lib, other=tmp_path / "other.json") for a in argv]
    before = library.path.read_bytes()
    one_line_exit_2(capsys, main(argv), "holder library")
    assert library.path.read_bytes() == before
    assert sorted(p.name for p in library.path.parent.iterdir()) == ["holders.json", "holders.json.lock"]


def test_refuse_library_output_is_silent_for_other_files_and_stdout(library, tmp_path):
    from taptune.cli.common import refuse_library_output

    refuse_library_output(None, "JSON", library.path)
    refuse_library_output("-", "JSON", library.path)
    refuse_library_output(tmp_path / "result.json", "JSON", library.path)


# --------------------------------------------------------------------------- record writes nothing before a tap


def test_a_missing_microphone_leaves_no_file_and_no_folder(monkeypatch, tmp_path, reference_toml, capsys):
    monkeypatch.setattr(recording, "input_devices", lambda: [])
    out = tmp_path / "new" / "deeper" / "tap.wav"
    code = main(["record", "--out", str(out), "--assembly", str(reference_toml)])
    one_line_exit_2(capsys, code, "no audio input device")
    assert not (tmp_path / "new").exists()


def test_a_device_that_fails_to_start_leaves_no_sidecar(tmp_path):
    class Broken(FakeInputStream):
        def start(self):
            raise OSError("device busy")

    out = tmp_path / "rec" / "tap.wav"
    recorder = Recorder(out, TriggerSettings(sample_rate=FS), assembly_toml="[holder]\n",
                        stream_factory=Broken([0.0]).factory)
    with pytest.raises(recording.DeviceError, match="device busy"):
        recorder.start()
    assert not (tmp_path / "rec").exists()  # before: rec/tap.toml was written first


def test_no_tap_heard_leaves_no_files(monkeypatch, tmp_path, reference_toml, capsys):
    stream = FakeInputStream(synthetic_taps([0.1], amplitude=0.0, seconds=0.5))  # a quiet room, no tap
    monkeypatch.setattr(recording, "input_devices", lambda: [InputDevice(4, "Fake USB mic", 1, 48000.0)])
    monkeypatch.setattr(recording, "default_input_index", lambda: 4)
    monkeypatch.setattr(recording, "sounddevice_stream", stream.factory)
    out = tmp_path / "quiet" / "tap.wav"
    assert main(["record", "--out", str(out), "--seconds", "0.3", "--assembly", str(reference_toml)]) == 1
    assert "no tap heard" in capsys.readouterr().err
    assert not (tmp_path / "quiet").exists()


def test_the_sidecar_appears_with_the_first_tap(tmp_path):
    out = tmp_path / "rec" / "tap.wav"
    fake = FakeInputStream(synthetic_taps([0.3, 1.1]))
    with Recorder(out, TriggerSettings(sample_rate=FS, n_taps=2), assembly_toml="[holder]\n",
                  stream_factory=fake.factory) as recorder:
        first = []
        while not recorder.done:
            for event in recorder.poll(timeout=1.0):
                if event.kind == "saved" and event.index == 1:
                    first = sorted(p.name for p in out.parent.iterdir())
    assert first == ["tap.toml", "tap.wav"]


def test_a_sidecar_that_cannot_be_written_is_refused_before_listening(tmp_path):
    out = tmp_path / "rec" / "tap.wav"
    (tmp_path / "rec" / "tap.toml").mkdir(parents=True)  # a folder where the sidecar goes
    recorder = Recorder(out, TriggerSettings(sample_rate=FS), assembly_toml="[holder]\n",
                        stream_factory=FakeInputStream(synthetic_taps([0.3])).factory)
    with pytest.raises(InputError, match="tap.toml: is a folder"):
        recorder.start()
    assert not out.exists()


def test_a_failing_save_keeps_the_taps_and_says_why(tmp_path, monkeypatch):
    out = tmp_path / "rec" / "tap.wav"
    fake = FakeInputStream(synthetic_taps([0.3, 1.1]))

    def full_disk(path, text):
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(recording, "_atomic_write_text", full_disk)
    with Recorder(out, TriggerSettings(sample_rate=FS, n_taps=2), assembly_toml="[holder]\n",
                  stream_factory=fake.factory) as recorder:
        with pytest.raises(recording.DeviceError, match="tap.toml: No space left.*1 tap.*saved in"):
            while not recorder.done:
                recorder.poll(timeout=1.0)
    assert out.exists()  # the first tap is in the WAV; only the sidecar is missing


@pytest.mark.skipif(os.name != "posix" or os.geteuid() == 0, reason="needs POSIX permissions, not root")
def test_record_into_a_read_only_folder_is_refused_before_listening(monkeypatch, tmp_path, capsys):
    monkeypatch.setattr(recording, "input_devices", lambda: [InputDevice(4, "Fake USB mic", 1, 48000.0)])
    locked = tmp_path / "locked"
    locked.mkdir()
    locked.chmod(0o555)
    try:
        code = main(["record", "--out", str(locked / "sub" / "tap.wav")])
        one_line_exit_2(capsys, code, "cannot be written", str(locked))
        assert list(locked.iterdir()) == []
    finally:
        locked.chmod(0o755)


# --------------------------------------------------------------------------- an output is never an input


@pytest.mark.parametrize("argv", [
    ["spectrum", "{wav}", "--json", "{wav}"],
    ["spectrum", "{wav}", "--assembly", "{toml}", "--plot", "{toml}"],
    ["model", "{toml}", "--json", "{toml}"],
    ["identify", "{wav}", "--assembly", "{toml}", "--no-save", "--json", "{wav}"],
    ["predict", "{toml}", "--holder", "x", "--json", "{toml}"],
    ["check", "{wav}", "--assembly", "{toml}", "--holder", "x", "--json", "{wav}"],
    ["record", "--out", "{toml}", "--assembly", "{toml}"],
    ["batch", "{wav}", "--assembly", "{toml}", "--report", "{wav}"],
])
def test_an_output_onto_one_of_the_inputs_is_refused_and_the_input_kept(argv, tmp_path, reference_toml, capsys):
    # Before, spectrum --json tap.wav replaced the recording with JSON and model --json
    # a.toml the assembly file, exit 0.
    wav = tmp_path / "tap.wav"
    wav.write_bytes(b"RIFF not really audio")
    before = {p: p.read_bytes() for p in (wav, reference_toml)}
    argv = [a.format(wav=wav, toml=reference_toml) for a in argv] + ["--library", str(tmp_path / "lib.json")] * (
        argv[0] in ("identify", "predict", "check", "batch", "model"))
    one_line_exit_2(capsys, main(argv), "is also an input of this command")
    assert {p: p.read_bytes() for p in before} == before


# --------------------------------------------------------------------------- the cut: plausible numbers only


@pytest.mark.parametrize("flags, message", [
    (["--diameter", "1e9"], "--diameter must be > 0 mm and at most 1000 mm, got 1e+09"),
    (["--diameter", "inf"], "--diameter must be > 0 mm and at most 1000 mm, got inf"),
    (["--ae", "nan"], "--ae must be > 0 mm (and at most 1000), got nan"),
    (["--teeth", "5000"], "--teeth must lie in 1…200, got 5000"),
    (["--ktc", "9e8", "--krc", "200"], "--ktc must lie in 0…20000 MPa (N/mm², not Pa), got 9e+08"),
])
def test_an_absurd_cut_is_refused_before_any_work(flags, message, tmp_path, capsys):
    # Before, --diameter 1e9 drew a lobe diagram from a one-kilometre cutter.
    frf = tmp_path / "frf.csv"
    frf.write_text("f_hz,xx_re,xx_im\n100,1e-8,-1e-9\n200,2e-8,-2e-9\n")
    base = {"--teeth": "4", "--ae": "2", "--diameter": "16", "--material": "al7075"}
    if "--ktc" in flags:
        base.pop("--material")
    for flag, value in zip(flags[::2], flags[1::2]):
        base[flag] = value
    argv = ["lobes", "--frf", str(frf), "--milling", "down"] + [x for kv in base.items() for x in kv]
    one_line_exit_2(capsys, main(argv), message)


@pytest.mark.parametrize("flags, message", [
    (["--seconds", "nan"], "--taps and --seconds must be > 0 (and finite), got 5 and nan"),
    (["--taps", "0"], "--taps and --seconds must be > 0"),
    (["--sample-rate", "1000"], "--sample-rate must lie in 8000…384000 Hz"),
])
def test_record_refuses_impossible_settings_before_listening(flags, message, monkeypatch, tmp_path, capsys):
    # Before, --seconds nan listened for no time and said "no tap heard in nan s" (exit 1).
    monkeypatch.setattr(recording, "input_devices", lambda: [InputDevice(4, "Fake USB mic", 1, 48000.0)])
    one_line_exit_2(capsys, main(["record", "--out", str(tmp_path / "x.wav")] + flags), message)
    assert list(tmp_path.iterdir()) == []


# --------------------------------------------------------------------------- a fit is never lost to the library


def _tiny_identification(monkeypatch):
    """identify with a tiny optimiser budget (the machinery, not the fit, is under test)."""
    from dataclasses import replace

    from taptune.cli import cmd_identify
    from taptune.identify import GAOptions, IdentifyOptions
    from taptune.identify.pipeline import identify_recordings

    def tiny(recordings, assemblies, seed=0, jobs=None, progress=None):
        options = replace(IdentifyOptions(seed=seed, jobs=1, ga=GAOptions(population=8, generations=2)),
                          polish_evaluations=20)
        return identify_recordings(recordings, assemblies, options, progress)

    monkeypatch.setattr(cmd_identify, "run_identification", tiny)


@pytest.fixture(scope="module")
def tap_wav(tmp_path_factory):
    from tests.library.entries import REFERENCE
    from taptune.synthetic import write_tap_recording

    return write_tap_recording(tmp_path_factory.mktemp("tap") / "tap.wav", REFERENCE, NOMINAL, seed=3,
                               sample_rate=96000, mic_lp_hz=None, snr_db=60.0)


def test_a_library_that_refuses_the_save_still_gets_the_fit_into_the_json(monkeypatch, tap_wav, reference_toml,
                                                                          tmp_path, capsys):
    from taptune.errors import LibraryError
    from taptune.library import record

    _tiny_identification(monkeypatch)

    def full_disk(*_args, **_kwargs):
        raise LibraryError("lib.json: cannot write the holder library (No space left on device); it was not changed")

    monkeypatch.setattr(record, "save_identification", full_disk)
    out = tmp_path / "fit.json"
    code = main(["identify", str(tap_wav), "--assembly", str(reference_toml), "--library", str(tmp_path / "lib.json"),
                 "--json", str(out)])
    err = capsys.readouterr().err
    assert code == 1 and "No space left on device" in err and "Traceback" not in err
    assert set(json.loads(out.read_text())["params"]) >= {"k_tt", "k_rr"}  # before: no JSON, the fit was lost
    # Without --json the fit goes to the screen before the error.
    code = main(["identify", str(tap_wav), "--assembly", str(reference_toml), "--library", str(tmp_path / "lib.json")])
    captured = capsys.readouterr()
    assert code == 1 and "No space left on device" in captured.err and "k_tt = " in captured.out


def test_outputs_are_checked_without_a_home_folder(monkeypatch, tmp_path):
    from pathlib import Path

    from taptune.cli.common import refuse_library_output

    monkeypatch.delenv("TAPTUNE_LIBRARY", raising=False)

    def no_home():
        raise RuntimeError("Could not determine home directory.")

    monkeypatch.setattr(Path, "home", staticmethod(no_home))
    lib = tmp_path / "lib.json"
    refuse_library_output(tmp_path / "out.json", "JSON", library=lib)  # no default library: nothing to refuse
    monkeypatch.delenv("XDG_DATA_HOME", raising=False)
    refuse_library_output(tmp_path / "out.json", "JSON")  # no --library either (taptune model --json): no traceback
    with pytest.raises(InputError, match="is the holder library"):
        refuse_library_output(lib, "JSON", library=lib)


def test_an_unwritable_library_is_refused_before_the_fit(monkeypatch, tap_wav, reference_toml, tmp_path, capsys):
    from taptune.io import atomic

    calls = []
    # Only writing is denied (the recording must still be readable).
    monkeypatch.setattr(atomic.os, "access", lambda path, mode: not mode & os.W_OK or calls.append(path) or False)
    code = main(["identify", str(tap_wav), "--assembly", str(reference_toml), "--library",
                 str(tmp_path / "lib" / "holders.json")])
    one_line_exit_2(capsys, code, "holders.json: cannot be written (no permission to write into")
    assert calls


@pytest.mark.parametrize("argv, message", [
    (["identify", "{wav}", "--assembly", "{toml}", "--no-save", "--seed", "-1"], "--seed must be >= 0, got -1"),
    (["identify", "{wav}", "--assembly", "{toml}", "--no-save", "--jobs", "0"], "--jobs must be at least 1, got 0"),
    (["batch", "{wav}", "--assembly", "{toml}", "--no-save", "--seed", "-2", "--out", "{tmp}/out"],
     "--seed must be >= 0, got -2"),
    (["demo", "--seed", "-1"], "--seed must be >= 0, got -1"),
])
def test_a_negative_seed_or_no_jobs_is_bad_input_not_a_worker_traceback(argv, message, tap_wav, reference_toml,
                                                                         tmp_path, capsys):
    # Before, identify --seed -1 ended in a multiprocessing RemoteTraceback (ValueError).
    argv = [a.format(wav=tap_wav, toml=reference_toml, tmp=tmp_path) for a in argv]
    one_line_exit_2(capsys, main(argv), message)
    assert not (tmp_path / "out").exists()


def test_record_writes_flac_as_flac_and_refuses_other_names(monkeypatch, tmp_path, capsys):
    # Before, --out taps.flac (or taps.mp3) held WAV data under the misleading name.
    import soundfile

    stream = FakeInputStream(synthetic_taps([0.3]))
    monkeypatch.setattr(recording, "input_devices", lambda: [InputDevice(4, "Fake USB mic", 1, 48000.0)])
    monkeypatch.setattr(recording, "default_input_index", lambda: 4)
    monkeypatch.setattr(recording, "sounddevice_stream", stream.factory)
    one_line_exit_2(capsys, main(["record", "--out", str(tmp_path / "taps.mp3")]), "saved as .wav or .flac")
    assert main(["record", "--out", str(tmp_path / "taps.flac"), "--taps", "1"]) == 0
    assert soundfile.info(tmp_path / "taps.flac").format == "FLAC"


@pytest.mark.parametrize("argv, message", [
    (["spectrum", "{wav}", "--plot", "{tmp}/fit.pdf"], "fit.pdf: the plot is written as .png; name the file so"),
    (["predict", "{toml}", "--holder", "x", "--plot", "{tmp}/p.txt"], "p.txt: the plot is written as .png"),
    (["identify", "{wav}", "--assembly", "{toml}", "--no-save", "--report", "{tmp}/r.png"],
     "r.png: the report is written as .pdf"),
    (["batch", "{wav}", "--assembly", "{toml}", "--no-save", "--report", "{tmp}/r", "--out", "{tmp}/o"],
     "the report is written as .pdf"),
])
def test_a_plot_or_report_named_for_another_format_is_refused(argv, message, tap_wav, reference_toml, tmp_path, capsys):
    # Before, --plot fit.pdf wrote PNG data into fit.pdf (and --report r.png a PDF into r.png).
    argv = [a.format(wav=tap_wav, toml=reference_toml, tmp=tmp_path) for a in argv]
    one_line_exit_2(capsys, main(argv + ["--library", str(tmp_path / "lib.json")] * (argv[0] != "spectrum")), message)
    assert [p.name for p in tmp_path.iterdir()] in ([], ["reference.toml"])  # nothing written


def test_an_output_into_a_read_only_folder_is_refused_before_the_work(monkeypatch, tap_wav, reference_toml,
                                                                       tmp_path, capsys):
    # os.access stands in for a read-only folder (the tests may run as root, who may write anywhere).
    from taptune.io import atomic

    locked = tmp_path / "locked"
    locked.mkdir()
    real = atomic.os.access
    monkeypatch.setattr(atomic.os, "access", lambda path, mode: False if str(path) == str(locked) else real(path, mode))
    called = []
    monkeypatch.setattr("taptune.cli.cmd_identify.run_identification", lambda *a, **k: called.append(1))
    code = main(["identify", str(tap_wav), "--assembly", str(reference_toml), "--no-save",
                 "--json", str(locked / "fit.json")])
    one_line_exit_2(capsys, code, "fit.json: cannot be written (no permission to write into")
    assert not called


def test_a_reader_that_closes_the_pipe_gets_no_traceback(reference_toml):
    """``taptune model x.toml | head -0``: the reader is gone before the first line."""
    import subprocess
    import sys

    env = dict(os.environ, OPENBLAS_NUM_THREADS="1")
    proc = subprocess.Popen([sys.executable, "-m", "taptune", "model", str(reference_toml)], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, env=env)
    proc.stdout.close()
    err = proc.stderr.read().decode()
    assert proc.wait(60) == 1 and err == "", err
