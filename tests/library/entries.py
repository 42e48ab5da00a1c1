"""Library entries for the tests, built from the reference assembly (the example of docs/assembly-format.md).

A plain module (not a conftest) so that the worker processes of the concurrency tests
can import it too.
"""

from __future__ import annotations

import tomllib
from dataclasses import replace

from taptune.io.assembly import parse_assembly
from taptune.library.schema import HolderEntry, ProvenanceRecord, tool_to_dict
from taptune.model.params import NOMINAL

from tests.conftest import REFERENCE_TOML

REFERENCE = parse_assembly(tomllib.loads(REFERENCE_TOML), "reference.toml")


def make_record(i: int = 0, stickout_mm: float = 53.5, recording: str | None = None) -> ProvenanceRecord:
    """A provenance record for the reference tool; ``i`` makes it distinct."""
    return ProvenanceRecord(
        recording=recording or f"tap{i}.wav",
        sha256=f"{i:064x}",
        tool=tool_to_dict(REFERENCE.tool),
        stickout_mm=stickout_mm,
        date=f"2026-11-22T12:{i // 60 % 60:02d}:{i % 60:02d}Z",
        objective=0.01 * (i + 1),
        seed=i,
        evaluations=1000 + i,
        bending_measured_hz=(3050.0 + i, 8120.5, 12990.25),
        bending_model_hz=(3049.5 + i, 8121.0, 12988.0),
        taptune_version="0.1.0",
    )


def make_entry(name: str = "ER32 collet chuck HSK-A63 x 100", scale: float = 1.0, records: int = 1, first: int = 0) -> HolderEntry:
    """The reference holder under ``name`` with k_tt scaled by ``scale`` and ``records`` provenance records."""
    best = replace(NOMINAL, k_tt=NOMINAL.k_tt * scale, alpha=-6.5)
    sets = (
        replace(best, k_tt=best.k_tt * 1.1, eta_tt=2e-3),
        replace(best, k_tt=best.k_tt * 0.95, eta_tt=9e-3, alpha=-12.0),
    )
    return HolderEntry.create(
        REFERENCE.holder,
        best,
        param_sets=sets,
        model_options={"h_max_mm": 2.0, "shear": "hutchinson", "mass": "consistent"},
        identifications=[make_record(first + i) for i in range(records)],
        name=name,
    )
