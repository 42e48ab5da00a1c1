"""Audio files: WAV, FLAC, MP3, Ogg and phone recordings (M4A/AAC, MP4/MOV video) into a checked :class:`Recording`.

libsndfile (through soundfile) reads WAV, FLAC, MP3 and Ogg Vorbis/Opus exactly and fast;
it cannot read AAC, the codec of most phone recorders and of phone video. Those go
through PyAV (``av``, FFmpeg's decoders bundled in its wheels, imported lazily), which is
also the fallback for any file libsndfile does not recognise.

Every file we cannot use ends in :class:`~taptune.errors.InputError` with a one-line
message naming the file and the problem (missing, empty, truncated, not audio, no
samples, NaN/Inf samples, a rate below the minimum). Problems that leave the data usable
(clipping, noise, a single tap) are the signal layer's business: they become warnings.
"""

from __future__ import annotations

import os
import struct
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from taptune.errors import InputError

# Below this rate not even the first bending mode of a stiff assembly is safely inside
# the band (Nyquist 4 kHz); the analysis warns separately when the expected third mode
# exceeds 0.9 x Nyquist (docs/tap-test.md).
MIN_SAMPLE_RATE = 8000
#: The rate a tap analysis needs (docs/tap-test.md: 44.1 kHz or more): the bending
#: modes ring at 3–20 kHz, so below it the spectrum (ending at half the rate) misses some.
RECOMMENDED_SAMPLE_RATE = 44100
#: Longest recording read [s]: a tap test needs a few seconds per tap, and the analysis
#: holds 20–25 times the file's samples in memory (10 min at 96 kHz stereo: 4 GB).
MAX_SECONDS = 300.0

#: Files that go straight to PyAV: AAC in MPEG-4/QuickTime/3GPP containers (phone voice
#: memos and video), raw ADTS AAC, WebM/Matroska audio.
AV_SUFFIXES = (".m4a", ".aac", ".mp4", ".mov", ".3gp", ".3g2", ".m4v", ".webm", ".mkv", ".mka")
#: Every suffix read_audio is meant for (soundfile's common ones, then PyAV's).
AUDIO_SUFFIXES = (".wav", ".flac", ".mp3", ".ogg", ".oga", ".opus") + AV_SUFFIXES

# Lossy codecs by the names soundfile and FFmpeg give them: their encoders low-pass.
_LOSSY = {"MPEG_LAYER_III": "mp3", "MPEG_LAYER_II": "mp2", "MPEG_LAYER_I": "mp1",
          "VORBIS": "vorbis", "OPUS": "opus"}
_LOSSY_AV = ("aac", "mp3", "mp2", "opus", "vorbis", "amr_nb", "amr_wb", "ac3", "eac3")
# FFmpeg sample formats (packed or planar "p") -> scale to [-1, 1] and the soundfile-style subtype.
_AV_FORMATS = {"u8": (None, "PCM_U8"), "s16": (2.0**15, "PCM_16"), "s32": (2.0**31, "PCM_32"),
               "s64": (2.0**63, "PCM_64"), "flt": (1.0, "FLOAT"), "dbl": (1.0, "DOUBLE")}


@dataclass(frozen=True)
class Recording:
    """A recording as read from a file.

    Attributes
    ----------
    samples : ndarray, shape (n, channels), float64
        Samples scaled to [-1, 1] (integer formats map full scale to ±1).
    sample_rate : int
        Sampling rate [Hz].
    path : str
        Where it came from ("" for synthesised recordings).
    subtype : str
        soundfile subtype (``"PCM_16"``, ``"PCM_24"``, ``"FLOAT"``, ``"MPEG_LAYER_III"``,
        ``"OPUS"`` …) or, for files PyAV decoded, FFmpeg's codec name (``"aac"``) or the
        PCM subtype it maps to; it tells the analysis what full scale means for clipping.
    warnings : tuple of str
        What reading found wrong but usable (a WAV cut short), each naming the file; the
        analysis puts them first in its own warnings.
    """

    samples: np.ndarray
    sample_rate: int
    path: str = ""
    subtype: str = "FLOAT"
    warnings: tuple[str, ...] = field(default=(), compare=False)

    @property
    def channels(self) -> int:
        """Number of channels."""
        return int(self.samples.shape[1])

    @property
    def n_samples(self) -> int:
        """Number of frames."""
        return int(self.samples.shape[0])

    @property
    def duration_s(self) -> float:
        """Length [s]."""
        return self.n_samples / float(self.sample_rate)

    @property
    def codec(self) -> str:
        """Short codec name: ``"aac"``, ``"mp3"``, ``"opus"``, ``"vorbis"``, else the subtype."""
        return _LOSSY.get(self.subtype.upper(), self.subtype)

    @property
    def lossy(self) -> bool:
        """Whether a perceptual codec made the samples (its encoder low-passes, see signal.bandwidth)."""
        return self.subtype.upper() in _LOSSY or self.subtype in _LOSSY_AV

    @property
    def name(self) -> str:
        """The file name for messages (``"<recording>"`` when there is no file)."""
        return self.path or "<recording>"


def make_recording(samples, sample_rate, path="", subtype="FLOAT", warnings=()) -> Recording:
    """Check samples from any source and wrap them in a :class:`Recording`.

    Parameters
    ----------
    samples : array_like, shape (n,) or (n, channels)
        Samples, nominally in [-1, 1].
    sample_rate : int
        Rate [Hz]; at least :data:`MIN_SAMPLE_RATE`.
    path, subtype : str
        Provenance, see :class:`Recording`.
    warnings : sequence of str
        What reading found wrong but usable, see :class:`Recording`.

    Raises
    ------
    InputError
        No samples, NaN/Inf samples, too many channels or a rate below the minimum.
    """
    name = path or "<recording>"
    x = np.asarray(samples, dtype=np.float64)
    if x.ndim == 1:
        x = x[:, None]
    if x.ndim != 2 or x.shape[1] < 1:
        raise InputError(f"{name}: samples must be an (n, channels) array, got shape {x.shape}")
    if x.shape[1] > 8:
        raise InputError(f"{name}: {x.shape[1]} channels; expected mono or stereo")
    if x.shape[0] == 0:
        raise InputError(f"{name}: the file holds no audio samples")
    if not np.all(np.isfinite(x)):
        bad = int(np.count_nonzero(~np.isfinite(x)))
        raise InputError(f"{name}: {bad} samples are NaN or infinite; the file is corrupt")
    try:
        rate = int(sample_rate)
    except (TypeError, ValueError):
        raise InputError(f"{name}: invalid sample rate {sample_rate!r}") from None
    if rate < MIN_SAMPLE_RATE:
        raise InputError(
            f"{name}: sample rate {rate} Hz is too low for bending modes "
            f"(need at least {MIN_SAMPLE_RATE} Hz, {RECOMMENDED_SAMPLE_RATE} Hz or more recommended)"
        )
    x.setflags(write=False)
    return Recording(samples=x, sample_rate=rate, path=str(path), subtype=str(subtype), warnings=tuple(warnings))


def read_audio(path) -> Recording:
    """Read a tap recording: WAV, FLAC, MP3, Ogg Vorbis/Opus, M4A/AAC or the audio of a video.

    soundfile (libsndfile) reads its formats exactly; ``.m4a``, ``.aac``, ``.mp4``,
    ``.mov``, ``.3gp``, ``.webm`` … (:data:`AV_SUFFIXES`), and any file libsndfile does
    not recognise, are decoded with PyAV. Samples keep the file's own rate and channels.

    Parameters
    ----------
    path : str or Path
        The file.

    Returns
    -------
    Recording
        Samples (n, channels) float64 in [-1, 1].

    Raises
    ------
    InputError
        Missing, a folder, empty, truncated, not audio, no audio stream, no samples,
        NaN/Inf samples, or a sample rate too low for the frequencies of interest.
    """
    import soundfile as sf

    p = Path(path)
    name = str(path)
    if not p.exists():
        raise InputError(f"{name}: no such file")
    if p.is_dir():
        raise InputError(f"{name}: is a folder, not an audio file")
    try:
        size = p.stat().st_size
    except OSError as err:
        raise InputError(f"{name}: cannot read ({err.strerror or err})") from None
    if size == 0:
        raise InputError(f"{name}: the file is empty")
    if not os.access(p, os.R_OK):  # libsndfile would only say "System error"
        raise InputError(f"{name}: cannot read (permission denied)")
    if p.suffix.lower() in AV_SUFFIXES:
        data, rate, subtype = _read_av(p, name)
        return make_recording(data, rate, path=name, subtype=subtype)
    try:
        with sf.SoundFile(str(p)) as f:
            subtype = f.subtype
            rate = f.samplerate
            if rate > 0 and f.frames > MAX_SECONDS * rate:
                raise InputError(_too_long(name, f.frames / rate))
            data = f.read(dtype="float64", always_2d=True)
    except (sf.LibsndfileError, RuntimeError, ValueError, TypeError, EOFError) as err:
        detail = " ".join(str(err).split()) or type(err).__name__
        message = f"{name}: not a readable audio file ({detail})"
        if "not recognised" not in detail.lower() and "malformed" not in detail.lower():
            raise InputError(message) from None
        # A phone file with a misleading suffix, or one libsndfile misjudges (it calls some
        # valid short Ogg Opus files "malformed"): FFmpeg may read it; if not, libsndfile's
        # message is the one to show.
        try:
            data, rate, subtype = _read_av(p, name)
        except InputError:
            raise InputError(message) from None
    except OSError as err:
        raise InputError(f"{name}: cannot read ({err.strerror or err})") from None
    return make_recording(data, rate, path=name, subtype=subtype, warnings=_cut_short(p, name, data.shape[0], rate))


def _cut_short(p: Path, name: str, frames: int, rate: int) -> tuple[str, ...]:
    """A warning when a WAV file holds less audio than its header announces (else none).

    libsndfile reads what is there without a word, so a copy or a recording that was
    interrupted would pass for a complete, shorter one.
    """
    found = wav_data_sizes(p)
    if found is None:
        return ()
    declared, present, block_align, header_rate = found
    if declared <= present:
        return ()
    announced = declared // block_align
    # Samples too: a cut of a few bytes leaves both durations the same to the millisecond.
    return (f"{name}: the file is cut short (an interrupted copy or recording?): its header announces "
            f"{announced} samples ({announced / header_rate:.3f} s) but it holds only {frames} "
            f"({frames / rate:.3f} s); the analysis uses what is there",)


def wav_data_sizes(path) -> tuple[int, int, int, int] | None:
    """What a WAV header says about its audio and what the file holds.

    Returns
    -------
    (declared, present, block_align, sample_rate) or None
        The data chunk's size as its header (or the RF64 ``ds64`` chunk) gives it and the
        bytes of it in the file [bytes], the bytes per frame and the rate [Hz]; None for
        a file that is no RIFF/RIFX/RF64 WAVE, whose chunks cannot be walked to ``data``,
        or whose writer left the size open (0 or 0xFFFFFFFF: recorders that stream).
    """
    try:
        with open(path, "rb") as f:
            size = f.seek(0, 2)
            f.seek(0)
            head = f.read(12)
            if len(head) < 12 or head[8:12] != b"WAVE" or head[:4] not in (b"RIFF", b"RIFX", b"RF64"):
                return None
            order = ">" if head[:4] == b"RIFX" else "<"
            pos, block_align, rate, ds64_data = 12, None, None, None
            for _ in range(64):  # a WAV has a handful of chunks before its data
                f.seek(pos)
                chunk = f.read(8)
                if len(chunk) < 8:
                    return None
                cid, csize = chunk[:4], struct.unpack(order + "I", chunk[4:])[0]
                if cid == b"ds64":
                    body = f.read(16)
                    if len(body) == 16:
                        ds64_data = struct.unpack("<Q", body[8:16])[0]
                elif cid == b"fmt ":
                    body = f.read(16)
                    if len(body) < 16:
                        return None
                    _, _, rate, _, block_align = struct.unpack(order + "HHIIH", body[:14])
                elif cid == b"data":
                    if head[:4] == b"RF64" and csize == 0xFFFFFFFF:
                        csize = ds64_data
                    if not csize or csize == 0xFFFFFFFF or not block_align or not rate:
                        return None
                    return int(csize), max(size - pos - 8, 0), int(block_align), int(rate)
                pos += 8 + csize + (csize & 1)  # chunks are padded to an even size
    except (OSError, struct.error):
        return None
    return None


def _too_long(name: str, seconds: float) -> str:
    return (f"{name}: {seconds / 60:.1f} min long; taptune reads tap recordings of up to {MAX_SECONDS / 60:g} min "
            f"(a few seconds per tap): cut the file to the taps")


def _read_av(p: Path, name: str):
    """Decode the first audio stream of ``p`` with PyAV: (samples (n, ch) float64, rate, subtype)."""
    try:
        import av
    except ImportError:
        raise InputError(f"{name}: reading {p.suffix or 'this'} files needs PyAV (pip install av)") from None
    try:
        with av.open(str(p), mode="r") as container:
            if not container.streams.audio:
                what = "a video without sound" if container.streams.video else "no audio stream"
                raise InputError(f"{name}: {what}; nothing to analyse")
            stream = container.streams.audio[0]
            if stream.codec_context is None:  # FFmpeg has no decoder for what the header names
                raise InputError(f"{name}: not a readable audio file (unknown audio codec; the file may be corrupt)")
            # FFmpeg names its floating-point MP3 decoder "mp3float"; the codec is MP3.
            codec = {"mp3float": "mp3"}.get(stream.codec_context.name, stream.codec_context.name)
            chunks, rate, fmt, frames = [], None, None, 0
            for frame in container.decode(stream):
                chunks.append(_frame_samples(frame))
                rate = rate or frame.sample_rate
                fmt = fmt or frame.format.name.rstrip("p")
                frames += chunks[-1].shape[0]
                if frames > MAX_SECONDS * rate:  # decoding the rest could exhaust the memory
                    duration = float(container.duration or 0) / 1e6 or frames / rate
                    raise InputError(_too_long(name, max(duration, frames / rate)))
    except InputError:
        raise
    except (av.error.FFmpegError, ValueError, OSError, EOFError) as err:
        # FFmpeg's own words ("Invalid data found when processing input"), without its errno.
        detail = " ".join(str(getattr(err, "strerror", None) or err).split()) or type(err).__name__
        raise InputError(f"{name}: not a readable audio file ({detail})") from None
    if not chunks or not sum(c.shape[0] for c in chunks):
        raise InputError(f"{name}: the file holds no audio samples")
    if len({c.shape[1] for c in chunks}) > 1:
        raise InputError(f"{name}: the number of channels changes within the file")
    data = np.concatenate(chunks, axis=0)
    pcm = codec.startswith("pcm_")
    return data, int(rate or stream.rate), (_AV_FORMATS.get(fmt, (None, codec))[1] if pcm else codec)


def _frame_samples(frame) -> np.ndarray:
    """One decoded PyAV frame as (n, channels) float64 in [-1, 1]."""
    x = frame.to_ndarray()
    channels = frame.layout.nb_channels
    fmt = frame.format
    # Planar formats come as (channels, n), packed ones as (1, n * channels).
    x = x.T if fmt.is_planar else x.reshape(-1, channels)
    scale = _AV_FORMATS.get(fmt.name.rstrip("p"), (1.0, ""))[0]
    if scale is None:  # unsigned 8 bit, centred on 128
        return (x.astype(np.float64) - 128.0) / 128.0
    return x.astype(np.float64) / scale


def write_audio(path, samples, sample_rate: int, subtype: str = "PCM_24") -> None:
    """Write samples (n,) or (n, channels) in [-1, 1] to a WAV/FLAC file.

    The format follows the file extension (soundfile's rules); ``subtype`` is e.g.
    ``"PCM_16"``, ``"PCM_24"``, ``"PCM_32"``, ``"FLOAT"``.
    """
    import soundfile as sf

    x = np.asarray(samples, dtype=np.float64)
    try:
        sf.write(str(path), x, int(sample_rate), subtype=subtype)
    except (sf.LibsndfileError, RuntimeError, ValueError, TypeError) as err:
        raise InputError(f"{path}: cannot write audio ({' '.join(str(err).split())})") from None
