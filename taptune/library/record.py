"""Store an identification in the holder library (used by identify, batch and the GUI)."""

from __future__ import annotations

from taptune.io.assembly import Tolerances
from taptune.library.schema import HolderEntry, ProvenanceRecord
from taptune.library.store import HolderLibrary, default_library_path


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


def save_identification(library_path, result, recordings, assemblies, model_options=None) -> str:
    """Put the identified holder into the library (atomic, locked); returns its name."""
    entry = entry_from_identification(result, recordings, assemblies, model_options)
    HolderLibrary(default_library_path(library_path)).put(entry)
    return entry.name
