"""Free-free Timoshenko model of a tool in a holder (docs/physics.md §1, §3).

geometry → mesh → elements → contact → assembly (fe) → modes (eigen) → receptance
(modes). The public entry points are re-exported here; submodules are imported on first use of a name so
that ``import taptune.model.params`` stays light.
"""

from __future__ import annotations

import importlib

_EXPORTS = {
    "ModelOptions": "options",
    "FEModel": "fe",
    "build_model": "fe",
    "rigid_contact_model": "fe",
    "Modes": "eigen",
    "ModelError": "eigen",
    "solve_modes": "eigen",
    "tip_receptance": "modes",
    "mode_shapes": "modes",
    "ModelResult": "modes",
    "ModeDiagnostics": "modes",
    "mode_diagnostics": "modes",
    "analyse": "modes",
    "bending_bounds": "bounds",
    "HolderParams": "params",
    "NOMINAL": "params",
}

__all__ = sorted(_EXPORTS)


def __getattr__(name):
    if name in _EXPORTS:
        module = importlib.import_module(f"taptune.model.{_EXPORTS[name]}")
        return getattr(module, name)
    raise AttributeError(f"module 'taptune.model' has no attribute {name!r}")
