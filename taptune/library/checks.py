"""Check a library holder by one tap, and keep the check in its history.

``check_holder`` is the one call for the CLI (``taptune check``) and the app's Check
button. It takes a recording and an assembly (the caller reads those files), labels the
tap with the holder's own parameters, predicts the assembly from the library, compares
(:func:`taptune.identify.check.check_tap`) and appends a :class:`CheckRecord` to the
holder in one library transaction.
"""

from __future__ import annotations

import hashlib
from dataclasses import dataclass, replace
from pathlib import Path


from taptune.library.schema import CheckRecord, HolderEntry, sha256_file, utc_now
from taptune.library.store import HolderLibrary, default_library_path

#: A worn, dirty or badly seated collet: both contact stiffnesses at half their value.
WORN_FACTOR = 0.5


@dataclass(frozen=True)
class HolderCheck:
    """What :func:`check_holder` found: the verdict and everything it rests on."""

    holder: str
    result: object  # taptune.identify.check.CheckResult
    analysis: object  # taptune.signal.analysis.SpectrumAnalysis
    prediction: object  # taptune.identify.Prediction
    worn_hz: tuple[float, ...]
    record: CheckRecord
    saved: bool
    warnings: tuple[str, ...]

    @property
    def verdict(self) -> str:
        return self.result.verdict

    def to_dict(self) -> dict:
        """JSON of ``taptune check``: ``verdict`` first, per-mode comparison, reasons, provenance."""
        return {"verdict": self.verdict, "holder": self.holder, "file": self.analysis.file,
                "tool": self.record.tool, "stickout": round(self.record.stickout_mm, 4),
                **{k: v for k, v in self.result.to_dict().items() if k != "verdict"},
                "worn_hz": [round(f, 2) for f in self.worn_hz],
                "band": None if self.prediction.band is None else self.prediction.band.to_dict(),
                "bandwidth_hz": None if self.analysis.bandwidth_hz is None else round(self.analysis.bandwidth_hz, 1),
                "taps": self.analysis.n_taps,
                "saved": self.saved, "warnings": list(self.warnings)}


def worn_prediction_hz(entry: HolderEntry, assembly, factor: float = WORN_FACTOR) -> tuple[float, ...]:
    """Bending frequencies [Hz] of ``assembly`` with the holder's contact stiffnesses × ``factor``.

    The best parameters' prediction moved by the *smallest* wear shift, per mode, over the
    near-optimal parameter sets: a contact that one tap pins down poorly may be stiff
    enough that halving it hardly moves the modes, and "a worn holder would have shown"
    must hold for every set that explains the identification equally well.
    """
    import numpy as np

    from taptune.model import build_model, solve_modes

    # Only the frequencies: one model serves every set (a full prediction per set would
    # rebuild it and compute a band that is thrown away).
    fe = build_model(assembly, entry.options())

    def bending_hz(p):
        return np.asarray(solve_modes(fe, p, n_modes=3).frequency_hz[:3], dtype=float)

    sets = entry.prediction_sets()
    good = np.array([bending_hz(p) for p in sets])
    worn = np.array([bending_hz(replace(p, k_tt=p.k_tt * factor, k_rr=p.k_rr * factor)) for p in sets])
    shift = worn - good
    smallest = shift[np.argmin(np.abs(shift), axis=0), np.arange(shift.shape[1])]
    return tuple(map(float, good[0] + smallest))


def check_holder(recording, assembly, holder: str, library=None, save: bool = True, entry: HolderEntry | None = None
                 ) -> HolderCheck:
    """Check library holder ``holder`` with one tap ``recording`` of ``assembly``.

    Parameters
    ----------
    recording : Recording
        The new tap (any tool and stick-out the assembly describes).
    assembly : Assembly
        The holder as clamped on this tool, at this stick-out.
    holder : str
        Name of the holder in the library.
    library : str, path or HolderLibrary, optional
        The library (default: ``$TAPTUNE_LIBRARY`` or the user data folder).
    save : bool
        Append the check to the holder's history (locked, atomic).
    entry : HolderEntry, optional
        The holder as already read (saves a read); it must be ``holder``.

    Returns
    -------
    HolderCheck

    Raises
    ------
    UnknownHolderError, LibraryFormatError, InputError
        No such holder, a broken library, an unusable recording.
    """
    from taptune.identify.check import check_tap
    from taptune.identify.pipeline import analyse_for_assembly

    lib = library if isinstance(library, HolderLibrary) else HolderLibrary(default_library_path(library))
    entry = entry or lib.get(holder)
    options = entry.options()
    warnings = list(entry.warnings) + list(assembly.warnings)
    if assembly.holder.name != entry.name:
        warnings.append(f"{assembly.source}: its holder is '{assembly.holder.name}', checking against library "
                        f"holder '{entry.name}'")
    analysis = analyse_for_assembly(recording, assembly, params=entry.params, model_options=options)
    prediction = entry.predict(assembly)
    worn = worn_prediction_hz(entry, assembly)
    result = check_tap(analysis, prediction, worn_hz=worn)
    record = check_record(recording, assembly, result)
    if save:
        append_check(lib, entry.name, record)
    return HolderCheck(entry.name, result, analysis, prediction, tuple(worn), record, save,
                       tuple(dict.fromkeys(warnings + list(analysis.warnings))))


def check_record(recording, assembly, result) -> CheckRecord:
    """The history record of a check: file name and hash, tool, stick-out, verdict, per-mode numbers."""
    from taptune import __version__

    path = Path(recording.path) if recording.path else None
    if path is not None and path.is_file():
        digest, name = sha256_file(path), path.name
    else:  # a recording made in the app and not saved: hash the samples
        digest, name = hashlib.sha256(recording.samples.tobytes()).hexdigest(), recording.name
    modes = [{"mode": m.mode, "measured_hz": m.measured_hz, "predicted_hz": m.predicted_hz, "band_hz": m.band_hz}
             for m in result.modes]
    return CheckRecord(date=utc_now(), recording=name, sha256=digest, tool=assembly.tool.name,
                       stickout_mm=assembly.stickout * 1e3, verdict=result.verdict, modes=tuple(modes),
                       taptune_version=__version__)


def append_check(lib: HolderLibrary, name: str, record: CheckRecord) -> None:
    """Add ``record`` to holder ``name``'s checks in one transaction (nothing else changes)."""
    lib.update(name, lambda entry: replace(entry, checks=entry.checks + (record,)))
