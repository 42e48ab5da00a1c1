"""Store an identification in the holder library (used by identify, batch and the GUI)."""

from __future__ import annotations

from taptune.errors import InputError
from taptune.io.assembly import Tolerances
from taptune.library.schema import HolderEntry, ProvenanceRecord
from taptune.library.store import HolderLibrary, default_library_path

#: A fitted model that misses a measured bending frequency by more than this [–] does not
#: describe the recording: stored, it would replace the holder's good parameters. Fits of
#: holders the model describes miss by < 0.1 %; of the realism corpus's holders outside
#: the model family, 99 % by < 2.3 % (the worst, 7.1 %, a mislabelled peak).
MAX_SAVED_MISFIT = 0.05


class FitTooPoor(InputError):
    """The identification does not describe its recording well enough to be stored."""


def poor_fit(result, recordings, assemblies) -> str | None:
    """Why ``result`` is not fit to store (its worst miss of a measured mode), or None."""
    from taptune.identify.core import fit_misfit

    pairs = list(zip(recordings, assemblies, result.bending_measured_hz, result.bending_model_hz))
    if max(fit_misfit(measured, model) for _, _, measured, model in pairs) <= MAX_SAVED_MISFIT:
        return None
    # Which recording and mode: for the message.
    miss, n, m, f, wav, toml = max((abs(f / m - 1), n, m, f, rec.path, asm.source)
                                   for rec, asm, measured, model in pairs
                                   for n, (m, f) in enumerate(zip(measured, model), 1)
                                   if m is not None and f is not None)
    return (f"{wav}: the fitted model misses bending mode {n} ({m:.0f} Hz measured, {f:.0f} Hz fitted) by "
            f"{100 * miss:.1f} %: {toml or 'the assembly'} does not describe this recording (another holder or tool, "
            f"wrong dimensions) or a peak is mislabelled; not stored in the library")


def entry_from_identification(result, recordings, assemblies, model_options=None) -> HolderEntry:
    """A library entry for the holder of ``assemblies`` with the identified parameters.

    One provenance record per recording (file name and hash, tool, stick-out and its
    stated tolerance, objective).
    """
    from taptune.model import ModelOptions

    options = model_options or ModelOptions()
    records = []
    for rec, asm, measured, model in zip(recordings, assemblies, result.bending_measured_hz, result.bending_model_hz):
        records.append(
            ProvenanceRecord.from_recording(
                rec.path,
                asm.tool,
                asm.stickout * 1e3,
                objective=result.objective,
                seed=result.seed,
                evaluations=result.evaluations,
                # Position = mode number; None where a mode was not measured.
                bending_measured_hz=list(measured),
                bending_model_hz=list(model),
                # Only a stated non-default one: a library stays readable by the
                # taptunes from before it was kept until someone states one.
                stickout_tolerance_mm=None if asm.tolerances.stickout == Tolerances().stickout
                else asm.tolerances.stickout * 1e3,
            )
        )
    return HolderEntry.create(
        assemblies[0].holder,
        result.params,
        param_sets=result.param_sets,
        model_options=options.to_dict(),
        identifications=records,
    )


def save_identification(library_path, result, recordings, assemblies, model_options=None, force: bool = False) -> str:
    """Put the identified holder into the library (atomic, locked); returns its name.

    Raises :class:`FitTooPoor` instead when the fit misses a measured mode by more than
    :data:`MAX_SAVED_MISFIT` (:func:`poor_fit`), unless ``force``.
    """
    if not force and (reason := poor_fit(result, recordings, assemblies)):
        raise FitTooPoor(reason)
    entry = entry_from_identification(result, recordings, assemblies, model_options)
    HolderLibrary(default_library_path(library_path)).put(entry)
    return entry.name
