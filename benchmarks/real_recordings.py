"""Real recordings made by others, as a new user would feed them in: what the analysis makes of them.

Run: ``python benchmarks/real_recordings.py [--fetch-root /work/realcorpus] [--no-lossy]``.

The files are not part of the repository (licences, size): fetch the repositories named
in :data:`MANIFEST` (``git clone``) and copy the files to ``<fetch-root>/<folder>/``, or
point ``--fetch-root`` at a folder that holds them. Missing files are skipped with a note.
For every file this prints the taps found and kept, double hits, clipping, the peaks (with
and without a damping value) and the warnings, and checks what is known about the file
(taps counted by eye, a reference peak). With lossy copies (default) each file is also
encoded to MP3, AAC (M4A) and Opus with PyAV, and the reference peak is sought there too.
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from dataclasses import dataclass
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

import numpy as np  # noqa: E402

from taptune.errors import InputError  # noqa: E402
from taptune.io.audio import read_audio  # noqa: E402
from taptune.signal.analysis import analyse_recording  # noqa: E402


@dataclass(frozen=True)
class Entry:
    """One real recording and what is known about it.

    folder, file : where it lies under the fetch root.
    repo, path, licence : its source (GitHub repository, path in it) and licence.
    what : what was recorded, how.
    taps : impacts counted by eye in the waveform (None: not a tap recording).
    reference_hz : a peak that must be found (the strongest mode, read off the spectrum), or None.
    tap : False for a recording that is no tap at all (machinery, speech, music): it must be
        refused or warned.
    doubles : of ``taps``, how many are real double impacts (a second strike visible in the
        waveform within ~30 ms): those may rightly be left out.
    clipped : the file really is clipped (a flat top seen in the waveform): it should say so.
    """

    folder: str
    file: str
    repo: str
    path: str
    licence: str
    what: str
    taps: int | None
    reference_hz: float | None = None
    tap: bool = True
    doubles: int = 0
    clipped: bool = False


GT = "dwsdolce/guitar_tap"
XY = "floe-audio/Xylophone"
MT = "purduelamm/mt_cutting_dataset"
KM = "Kent-mak/2025-Spring-NYCU-AI-Capstone-Project-1"
KM_WHAT = "knocks by hand on {} (iPhone 13 voice memo: AAC, 48 kHz mono, automatic gain), {}"
FRF = "ladisk/pyFRF"
FRF_WHAT = ("impact-hammer test (real measurement shipped with pyFRF): the response channel (row 2 of the .npy; "
            "row 0 time, row 1 hammer force) written as a 25.6 kHz float WAV; triggered, the impact 0.8 ms after "
            "the start; {}")
PR = "LCAV/pyroomacoustics"
MANIFEST = (
    Entry("guitar_tap", "Recording.wav", GT, "tests/Recording.wav", "GPL-3.0",
          "a guitar body tapped 8 times by knuckle, 48 kHz 16-bit stereo (both channels alike); "
          "soft, ragged onsets; a faint event at 3.73 s ~44 dB below the taps", 8, 164.0),
    Entry("guitar_tap", "Recording 5.wav", GT, "tests/Recording 5.wav", "GPL-3.0",
          "one knuckle tap on a guitar body, 48 kHz 16-bit stereo, peak -6 dBFS", 1, 164.0),
    Entry("guitar_tap", "Tap Test 2.wav", GT, "tests/Tap Test 2.wav", "GPL-3.0",
          "one tap on a guitar top, 44.1 kHz 16-bit mono, peak -7.9 dBFS (not clipped); "
          "a small bump 0.3 s later", 1, 243.0),
    Entry("guitar_tap", "brace-umik-1-swift-mac-1778816093.wav", GT,
          "tests/brace-umik-1-swift-mac-1778816093.wav", "GPL-3.0",
          "one tap on a free guitar brace (a wooden bar), UMIK-1 measurement microphone, "
          "48 kHz 32-bit float, quiet (peak 0.017); a second transient 5.6 ms after the onset", 1, 512.7),
    Entry("xylophone", "C4_ff.flac", XY, "library/Samples/C4_ff.flac", "CC0-1.0",
          "one hard mallet strike on a xylophone bar (free-free, with resonator tube), "
          "44.1 kHz 24-bit stereo; the fundamental rings for seconds", 1, 526.7),
    Entry("xylophone", "C4_pp.flac", XY, "library/Samples/C4_pp.flac", "CC0-1.0",
          "one soft mallet strike, the same bar", 1, 526.8),
    Entry("xylophone", "G3_pp.flac", XY, "library/Samples/G3_pp.flac", "CC0-1.0",
          "one soft strike on the G3 bar", 1, 394.8),
    Entry("xylophone", "G4_ff.flac", XY, "library/Samples/G4_ff.flac", "CC0-1.0",
          "one hard strike on the G4 bar", 1, 789.6),
    Entry("xylophone", "C5_ff.flac", XY, "library/Samples/C5_ff.flac", "CC0-1.0",
          "one hard strike on the C5 bar", 1, 1055.7),
    Entry("xylophone", "C6_pp.flac", XY, "library/Samples/C6_pp.flac", "CC0-1.0",
          "one soft strike on the C6 bar", 1, 2113.1),
    Entry("machining", "Exp0-1_video.mp4", MT, "IMI/Exp0-1/Exp0-1_video.mp4", "none stated (kept local)",
          "CNC end milling filmed with sound (AAC, 44.1 kHz stereo, 80 s): spindle, cutting, coolant; no tap",
          None, None, tap=False),
    Entry("machining", "Exp1-5_video.mp4", MT, "IMI/Exp1-5/Exp1-5_video.mp4", "none stated (kept local)",
          "CNC end milling filmed with sound (AAC, 44.1 kHz stereo, 18 s): two loud passes, then the "
          "running machine; no tap", None, None, tap=False),
    # Second round (held out from the first): files the analysis had not been tried on.
    Entry("guitar_tap_new", "plate-umik-1-swift-mac-1778693840.wav", GT,
          "tests/plate-umik-1-swift-mac-1778693840.wav (in the history)", "GPL-3.0",
          "a guitar plate tapped 3 times 2 s apart, UMIK-1, 48 kHz float; exact digital silence between the "
          "taps", 3, 369.0),
    Entry("guitar_tap_new", "swift_Capturing_Cross-grain.wav", GT,
          "tests/swift_Capturing_Cross-grain_2026-05-13T17-36-18Z.wav (in the history)", "GPL-3.0",
          "one tap on a guitar plate for its cross-grain stiffness, 48 kHz float, 0.4 s", 1, 368.0),
    Entry("guitar_tap_new", "swift_Capturing_FLC.wav", GT,
          "tests/swift_Capturing_FLC_2026-05-13T17-36-29Z.wav (in the history)", "GPL-3.0",
          "one tap on a guitar plate held at its FLC node, 48 kHz float, 0.4 s", 1, 368.0),
    Entry("guitar_tap_new", "swift_Capturing_Longitudinal.wav", GT,
          "tests/swift_Capturing_Longitudinal_2026-05-13T17-35-52Z.wav (in the history)", "GPL-3.0",
          "one tap on a guitar plate held for its long-grain mode, 48 kHz float, 0.4 s; "
          "117.4, 207.6 and 368.8 Hz within 3 dB", 1, 117.4),
    Entry("guitar_tap_new", "brace-umik-1-python-mac-1778452289.wav", GT,
          "tests/brace-umik-1-python-mac-1778452289.wav (in the history)", "GPL-3.0",
          "one tap on a free brace, UMIK-1, 48 kHz float, quiet (peak 0.016); a click at 15 ms, 20 dB below",
          1, 512.5),
    Entry("xylophone_new", "C3_ff.flac", XY, "library/Samples/C3_ff.flac", "CC0-1.0",
          "one hard strike on the C3 bar (the file starts at the strike)", 1, 263.4),
    Entry("xylophone_new", "C3_pp.flac", XY, "library/Samples/C3_pp.flac", "CC0-1.0",
          "one soft strike on the C3 bar", 1, 263.6),
    Entry("xylophone_new", "C7_ff.flac", XY, "library/Samples/C7_ff.flac", "CC0-1.0",
          "one hard strike on the C7 bar, normalised to one sample at full scale (not clipped)", 1, 4223.7),
    Entry("xylophone_new", "G5_pp.flac", XY, "library/Samples/G5_pp.flac", "CC0-1.0",
          "one soft strike on the G5 bar, normalised to full scale", 1, 1582.5),
    Entry("xylophone_new", "G6_ff.flac", XY, "library/Samples/G6_ff.flac", "CC0-1.0",
          "one hard strike on the G6 bar", 1, 3171.1),
    Entry("knock_materials", "Ceramic_1.m4a", KM, "Data/raw/Ceramic/1.m4a", "none stated (kept local)",
          KM_WHAT.format("a ceramic object", "a knock, then 0.19 s later a light second strike 19 dB softer "
                         "(the envelope jumps 13 dB out of the first ring and the same 1664 Hz mode rings "
                         "again)"), 2, 1666.8),
    Entry("knock_materials", "Ceramic_73.m4a", KM, "Data/raw/Ceramic/73.m4a", "none stated (kept local)",
          KM_WHAT.format("a ceramic object", "one knock that is a real double strike (a small one, then the "
                         "loud one 20 ms later)"), 1, 1667.0, doubles=1),
    Entry("knock_materials", "Marble_1.m4a", KM, "Data/raw/Marble/1.m4a", "none stated (kept local)",
          KM_WHAT.format("marble", "one sharp knock"), 1),
    Entry("knock_materials", "Marble_37.m4a", KM, "Data/raw/Marble/37.m4a", "none stated (kept local)",
          KM_WHAT.format("marble", "3 knocks 0.2 s apart, the third 10 dB softer"), 3),
    Entry("knock_materials", "Marble_73.m4a", KM, "Data/raw/Marble/73.m4a", "none stated (kept local)",
          KM_WHAT.format("marble", "2 knocks 0.3 s apart, the second 14 dB softer"), 2),
    Entry("knock_materials", "Wood_1.m4a", KM, "Data/raw/Wood/1.m4a", "none stated (kept local)",
          KM_WHAT.format("wood", "4 knocks 0.25 s apart (the first 14 dB softer); two clicks ~30 dB below"), 4),
    Entry("knock_materials", "Wood_37.m4a", KM, "Data/raw/Wood/37.m4a", "none stated (kept local)",
          KM_WHAT.format("wood", "2 knocks 0.19 s apart, the second 11 dB softer; a click 33 dB below"), 2),
    Entry("knock_materials", "Wood_73.m4a", KM, "Data/raw/Wood/73.m4a", "none stated (kept local)",
          KM_WHAT.format("wood", "4 knocks 0.14-0.2 s apart, the last 13 dB softer"), 4),
    Entry("pyfrf_impact", "measurement_1_response.wav", FRF, "data/measurements_1.npy (in the history)", "MIT",
          FRF_WHAT.format("modes at 900, 2641, 3669 Hz"), 1, 3668.9),
    Entry("pyfrf_impact", "measurement_3_response.wav", FRF, "data/measurements_3.npy (in the history)", "MIT",
          FRF_WHAT.format("another impact on the same structure"), 1, 3668.9),
    Entry("pyfrf_impact", "measurement_5_response.wav", FRF, "data/measurements_5.npy (in the history)", "MIT",
          FRF_WHAT.format("another impact on the same structure"), 1, 3669.0),
    Entry("pcb_shock", "acc_pcb_a0.wav", "High-Rate-SHM-Working-Group/Dataset-5-Extended-Impact-Testing",
          "data/dataset-1/data-1/PCB repeated shock trials/acc_pcb_a0.txt", "CC-BY-SA-4.0",
          "accelerometer on a circuit board in a drop-tower shock (text file, 50 kHz, 0.11 s) written as a float "
          "WAV; the accelerometer saturated: a flat top at -547 g for 10 samples; rings at 805 Hz",
          1, 804.7, clipped=True),
    Entry("speech_music", "jfk.flac", "openai/whisper", "tests/jfk.flac", "MIT",
          "11 s of a speech (stereo FLAC, 44.1 kHz); no tap", None, None, tap=False),
    Entry("speech_music", "german_speech_8000.wav", PR, "examples/input_samples/german_speech_8000.wav", "MIT",
          "2 s of German speech, 8 kHz, peak -0.06 dBFS; no tap", None, None, tap=False),
    Entry("speech_music", "cmu_arctic_us_aew_a0001.wav", PR, "examples/input_samples/cmu_arctic_us_aew_a0001.wav",
          "MIT (CMU ARCTIC: free use)", "a spoken sentence, 16 kHz, 3.9 s; no tap", None, None, tap=False),
    Entry("speech_music", "singing_8000.wav", PR, "examples/input_samples/singing_8000.wav", "MIT",
          "5 s of singing, 8 kHz; no tap", None, None, tap=False),
)

#: Lossy copies: suffix, PyAV codec, bit rate [bit/s] (a phone's or an app's usual settings).
LOSSY = ((".mp3", "libmp3lame", 192_000), (".m4a", "aac", 128_000), (".opus", "libopus", 96_000))


def encode(src, dst: Path, codec: str, bit_rate: int) -> Path:
    """A lossy copy of recording ``src`` (mono mix of its first channel) at ``dst`` with PyAV."""
    import av

    x = np.asarray(src.samples[:, 0], np.float32)
    # Opus codes at 48 kHz only; MP3 and AAC at the usual audio rates (not 25.6 or 50 kHz).
    usual = (8000, 11025, 12000, 16000, 22050, 24000, 32000, 44100, 48000)
    rate = src.sample_rate if codec != "libopus" and src.sample_rate in usual else 48000
    if rate != src.sample_rate:
        from scipy.signal import resample_poly

        g = np.gcd(rate, src.sample_rate)
        x = resample_poly(x, rate // g, src.sample_rate // g).astype(np.float32)
    with av.open(str(dst), "w") as container:
        stream = container.add_stream(codec, rate=rate, layout="mono")
        stream.bit_rate = bit_rate
        frame = av.AudioFrame.from_ndarray(x[None, :], format="flt", layout="mono")
        frame.sample_rate = rate
        for packet in stream.encode(frame):
            container.mux(packet)
        for packet in stream.encode(None):
            container.mux(packet)
    return dst


def describe(path: Path, entry: Entry, label: str) -> dict:
    """Analyse one file and print what came out; returns the figures checked."""
    t0 = time.perf_counter()
    try:
        a = analyse_recording(read_audio(path), interface=None)
    except InputError as err:
        print(f"  {label:6s} REFUSED: {err}")
        return {"refused": True}
    dt = time.perf_counter() - t0
    used = [t for t in a.taps if t.used]
    print(f"  {label:6s} taps found {len(a.taps)}, kept {len(used)}, double hits {sum(t.double_hit for t in a.taps)}, "
          f"clipped {sum(t.clipped for t in a.taps)}  ({1000 * dt:.0f} ms)")
    with_z = [p for p in a.peaks if p.damping_ratio is not None]
    peaks = ", ".join(f"{p.hz:.1f}{'' if p.damping_ratio is not None else '*'}"
                      f"{f' b{p.mode}' if p.kind == 'bending' else ''}" for p in a.peaks[:14])
    print(f"         {len(a.peaks)} peaks ({len(a.peaks) - len(with_z)} without damping, *): {peaks}"
          + (" ..." if len(a.peaks) > 14 else ""))
    for w in a.warnings:
        print(f"         warning: {w.replace(str(path) + ': ', '')}")
    ref = None
    if entry.reference_hz:
        near = [p for p in a.peaks if abs(p.hz / entry.reference_hz - 1) < 0.01]
        ref = min(near, key=lambda p: abs(p.hz - entry.reference_hz)).hz if near else None
        print(f"         reference {entry.reference_hz:g} Hz: " + (f"found at {ref:.1f} Hz" if ref else "NOT FOUND"))
    # Side lobes: peaks within 25 Hz of a >= 20 dB louder one, a spacing a 0.25 s window's leakage makes.
    lobes = sum(any(0 < abs(q.hz - p.hz) < 25 and q.level_db - p.level_db >= 20 for q in a.peaks) for p in a.peaks)
    warned = any("not look like a tap" in w for w in a.warnings)
    return {"refused": False, "found": len(a.taps), "kept": len(used), "ref": ref, "lobes": lobes,
            "not_a_tap": warned, "clipped": sum(t.clipped for t in a.taps)}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--fetch-root", default=os.environ.get("TAPTUNE_REAL_CORPUS", "/work/realcorpus"))
    ap.add_argument("--no-lossy", action="store_true", help="skip the MP3/AAC/Opus copies")
    ap.add_argument("--lossy-dir", default=None, help="where the lossy copies go (default <fetch-root>/lossy)")
    args = ap.parse_args(argv)
    root = Path(args.fetch_root)
    lossy_dir = Path(args.lossy_dir) if args.lossy_dir else root / "lossy"
    score = {"taps": [0, 0], "extra": 0, "ref": [0, 0], "lobes": 0, "false_clip": 0, "clip": [0, 0],
             "non_tap": [0, 0]}
    for e in MANIFEST:
        path = root / e.folder / e.file
        print(f"{e.folder}/{e.file}  [{e.repo}: {e.path}, {e.licence}]\n  {e.what}")
        if not path.exists():
            print("  (missing: skipped)")
            continue
        copies = [("wav", path)]
        if not args.no_lossy and e.tap:
            lossy_dir.mkdir(parents=True, exist_ok=True)
            src = read_audio(path)
            for suffix, codec, rate in LOSSY:
                dst = lossy_dir / (Path(e.file).stem + suffix)
                if not dst.exists():
                    encode(src, dst, codec, rate)
                copies.append((suffix[1:], dst))
        for label, p in copies:
            r = describe(p, e, label if label != "wav" else Path(e.file).suffix[1:])
            if not e.tap:
                score["non_tap"][1] += 1
                score["non_tap"][0] += bool(r["refused"] or r["not_a_tap"])
                continue
            if label == "wav" and e.taps:
                # Real single taps must be kept; a real double strike may rightly be left out.
                singles = e.taps - e.doubles
                score["taps"][1] += singles
                if not r["refused"]:
                    score["taps"][0] += min(r["kept"], singles)
                    score["extra"] += max(0, r["kept"] - e.taps)
                    if e.clipped:
                        score["clip"][1] += 1
                        score["clip"][0] += r["clipped"] > 0
                    else:
                        score["false_clip"] += r["clipped"]
            if r["refused"]:
                score["ref"][1] += bool(e.reference_hz)
                continue
            score["lobes"] += r["lobes"]
            if e.reference_hz:
                score["ref"][1] += 1
                score["ref"][0] += r["ref"] is not None
        print()
    print(f"summary: real single taps kept {score['taps'][0]} of {score['taps'][1]} (originals); "
          f"more taps used than struck: {score['extra']}; "
          f"reference peak found in {score['ref'][0]} of {score['ref'][1]} files (originals and lossy copies); "
          f"clipped taps reported in originals that do not clip: {score['false_clip']}; "
          f"really clipped originals reported clipped: {score['clip'][0]} of {score['clip'][1]}; "
          f"peaks within 25 Hz of a 20 dB louder one: {score['lobes']}; "
          f"non-taps refused or warned: {score['non_tap'][0]} of {score['non_tap'][1]}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
