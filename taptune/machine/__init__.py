"""The machine stage: the holder on a measured spindle, tool-point FRF, stability lobes.

MODEL.md §10 (receptance coupling, inverse RCSA) and §11 (zero-order lobes); files and
commands in MACHINE.md. This layer uses io, model and identify; nothing below imports it.
Names are imported on first use, so ``import taptune.machine`` stays light.

Public API (signatures in each module's docstring)::

    coupling_plane(holder, source="") -> float                        # plane.py, z_cp [m]
    cut_assembly(assembly) -> Assembly;  cut_holder(holder) -> Holder
    receptance_blocks(fe, params, freq_hz, method="modal") -> ReceptanceBlocks   # blocks.py
    couple(h11, h12, h21, h22, h_s, joint=None) -> G11                # coupling.py
    toolpoint_frf(assembly, params, spindle, freq_hz, model_options=None, joint=None,
                  contact="distributed", method="modal", lumped=None) -> ToolpointFRF
    spindle_from_dummy(dummy, point_a_m, point_b_m, freq_hz, g_aa, g_ab, g_bb, ...)
        -> (SpindleReceptance, warnings)                              # dummy.py
    stability_lobes(freq_hz, phi_xx, phi_yy, *, teeth, ktc, krc, diameter, ae, milling, rpm)
        -> Lobes                                                      # lobes.py
    MATERIALS: dict of name -> CuttingCoefficients                    # materials.py
"""

from __future__ import annotations

import importlib

_EXPORTS = {
    "INTERFACE_SHANK_MM": "plane",
    "coupling_plane": "plane",
    "cut_assembly": "plane",
    "cut_holder": "plane",
    "ReceptanceBlocks": "blocks",
    "receptance_blocks": "blocks",
    "point_receptance": "blocks",
    "direct_receptance": "blocks",
    "couple": "coupling",
    "coupled_model": "coupling",
    "toolpoint_frf": "coupling",
    "ToolpointFRF": "coupling",
    "LumpedJoint": "lumped",
    "lumped_from_layer": "lumped",
    "FRFMode": "peaks",
    "dominant_modes": "peaks",
    "spindle_from_dummy": "dummy",
    "DummyFit": "dummy",
    "stability_lobes": "lobes",
    "Lobes": "lobes",
    "MATERIALS": "materials",
    "CuttingCoefficients": "materials",
}

__all__ = sorted(_EXPORTS)


def __getattr__(name):
    if name in _EXPORTS:
        module = importlib.import_module(f"taptune.machine.{_EXPORTS[name]}")
        return getattr(module, name)
    raise AttributeError(f"module 'taptune.machine' has no attribute {name!r}")
