"""Audio files: read any WAV/FLAC soundfile understands into a checked :class:`Recording`.

Every file we cannot use ends in :class:`~taptune.errors.InputError` with a one-line
message naming the file and the problem (missing, empty, truncated, not audio, no
samples, NaN/Inf samples, a rate below the minimum). Problems that leave the data usable
(clipping, noise, a single tap) are the signal layer's business: they become warnings.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from taptune.errors import InputError

# Below this rate not even the first bending mode of a stiff assembly is safely inside
# the band (Nyquist 4 kHz); the analysis warns separately when the expected third mode
# exceeds 0.9 x Nyquist (MODEL.md §8.3).
MIN_SAMPLE_RATE = 8000


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
        soundfile subtype (``"PCM_16"``, ``"PCM_24"``, ``"FLOAT"`` …); it tells the
        analysis what full scale means for clipping.
    """

    samples: np.ndarray
    sample_rate: int
    path: str = ""
    subtype: str = "FLOAT"

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
    def name(self) -> str:
        """The file name for messages (``"<recording>"`` when there is no file)."""
        return self.path or "<recording>"


def make_recording(samples, sample_rate, path="", subtype="FLOAT") -> Recording:
    """Check samples from any source and wrap them in a :class:`Recording`.

    Parameters
    ----------
    samples : array_like, shape (n,) or (n, channels)
        Samples, nominally in [-1, 1].
    sample_rate : int
        Rate [Hz]; at least :data:`MIN_SAMPLE_RATE`.
    path, subtype : str
        Provenance, see :class:`Recording`.

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
            f"(need at least {MIN_SAMPLE_RATE} Hz, 44100 Hz or more recommended)"
        )
    x.setflags(write=False)
    return Recording(samples=x, sample_rate=rate, path=str(path), subtype=str(subtype))


def read_audio(path) -> Recording:
    """Read a WAV/FLAC/any libsndfile format into a :class:`Recording`.

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
        Missing, a folder, empty, truncated, not audio, no samples, NaN/Inf samples,
        or a sample rate too low for the frequencies of interest.
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
    try:
        with sf.SoundFile(str(p)) as f:
            subtype = f.subtype
            rate = f.samplerate
            data = f.read(dtype="float64", always_2d=True)
    except (sf.LibsndfileError, RuntimeError, ValueError, TypeError, EOFError) as err:
        detail = " ".join(str(err).split()) or type(err).__name__
        raise InputError(f"{name}: not a readable audio file ({detail})") from None
    except OSError as err:
        raise InputError(f"{name}: cannot read ({err.strerror or err})") from None
    return make_recording(data, rate, path=name, subtype=subtype)


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
