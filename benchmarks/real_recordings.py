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
    tap : False for a recording that is no tap at all (machinery): it must be refused or warned.
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


GT = "dwsdolce/guitar_tap"
XY = "floe-audio/Xylophone"
MT = "purduelamm/mt_cutting_dataset"
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
)

#: Lossy copies: suffix, PyAV codec, bit rate [bit/s] (a phone's or an app's usual settings).
LOSSY = ((".mp3", "libmp3lame", 192_000), (".m4a", "aac", 128_000), (".opus", "libopus", 96_000))


def encode(src, dst: Path, codec: str, bit_rate: int) -> Path:
    """A lossy copy of recording ``src`` (mono mix of its first channel) at ``dst`` with PyAV."""
    import av

    x = np.asarray(src.samples[:, 0], np.float32)
    rate = src.sample_rate if codec != "libopus" else 48000
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
    score = {"taps": [0, 0], "ref": [0, 0], "lobes": 0, "false_clip": 0, "non_tap": [0, 0]}
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
            if r["refused"]:
                score["ref"][1] += bool(e.reference_hz)
                continue
            if label == "wav" and e.taps:
                score["taps"][0] += min(r["kept"], e.taps)
                score["taps"][1] += e.taps
                score["false_clip"] += r["clipped"]
            score["lobes"] += r["lobes"]
            if e.reference_hz:
                score["ref"][1] += 1
                score["ref"][0] += r["ref"] is not None
        print()
    print(f"summary: real taps kept {score['taps'][0]} of {score['taps'][1]} (originals); "
          f"reference peak found in {score['ref'][0]} of {score['ref'][1]} files (originals and lossy copies); "
          f"clipped taps reported in originals none of which clip: {score['false_clip']}; "
          f"peaks within 25 Hz of a 20 dB louder one: {score['lobes']}; "
          f"non-taps refused or warned: {score['non_tap'][0]} of {score['non_tap'][1]}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
