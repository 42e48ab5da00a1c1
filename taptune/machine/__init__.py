"""The machine stage: the holder on a measured spindle, tool-point FRF, stability lobes.

Receptance coupling and inverse RCSA (Schmitz & Smith, *Machining Dynamics*), the lobes by
semi-discretization (Insperger & Stépán 2002/2004) or the zero-order approximation
(Altintas & Budak 1995); files and commands in docs/machine.md. This layer uses io, model and
identify; nothing below imports it.
Names are imported on first use, so ``import taptune.machine`` stays light.

Public API (signatures in each module's docstring; SI inside: m, Hz, N/m², m/N)::

    coupling_plane(holder, source="") -> float                        # plane.py, z_cp [m]
    cut_assembly(assembly) -> Assembly;  cut_holder(holder, source="") -> Holder
    receptance_blocks(fe, params, freq_hz, method="modal"|"direct") -> ReceptanceBlocks
        # blocks.py: .h11 (tip), .h12, .h21, .h22 (coupling node), each (n, 2, 2)
    couple(h11, h12, h21, h22, h_s, joint=None) -> G11 (n, 2, 2)     # coupling.py
    toolpoint_frf(assembly, params, spindle, freq_hz, model_options=None, joint=None,
                  contact="distributed"|"rigid"|"lumped", method="modal", lumped=None) -> ToolpointFRF
        # spindle = {"x": SpindleReceptance, "y": SpindleReceptance | None}
    spindle_from_dummy(dummy, point_a_m, point_b_m, freq_hz, g_aa, g_ab, g_bb, *, model_options=None,
                       smooth="auto", source="dummy", return_fit=False)
        -> (SpindleReceptance, warnings[, DummyFit])                   # dummy.py
    stability_lobes(freq_hz, phi_xx, phi_yy=None, *, teeth, ktc, krc, diameter, ae,
                    milling="up"|"down", rpm, refine=8, method="zoa"|"sdm"|"auto",
                    depth_cap=inf, modes=None) -> Lobes                # lobes.py
    sdm_lobes(modes_x, modes_y, *, teeth, ktc, krc, diameter, ae, milling, rpm, depth_cap=inf)  # sdm.py
    lobes_with_band(freq_hz, phi_xx, phi_yy, *, ..., method, confidence, band, depth_cap)
        -> (Lobes, LobeBand)                                           # band.py
    MATERIALS: dict[str, CuttingCoefficients]; cutting_coefficients(name)   # materials.py
    dominant_modes(freq_hz, frf, direction) -> list[FRFMode]          # peaks.py
    fit_frfs(freq_hz, frfs) -> RationalFit                            # vectfit.py
    ModalSet(freq_hz, damping_ratio, stiffness_n_m); modal_fit(freq_hz, frf) -> ModalFit  # simulate.py
    simulate_milling(modes_x, modes_y, *, teeth, ktc, krc, diameter, ae, milling, rpm, depth,
                     duration_s, fs, feed_per_tooth, kte=0, kre=0, rng=None) -> MillingRun
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
    "cutting_coefficients": "materials",
    "fit_frfs": "vectfit",
    "RationalFit": "vectfit",
    "sdm_lobes": "sdm",
    "lobes_with_band": "band",
    "LobeBand": "band",
    "ModalSet": "simulate",
    "ModalFit": "simulate",
    "modal_fit": "simulate",
    "MillingRun": "simulate",
    "simulate_milling": "simulate",
}

__all__ = sorted(_EXPORTS)


def __getattr__(name):
    if name in _EXPORTS:
        module = importlib.import_module(f"taptune.machine.{_EXPORTS[name]}")
        return getattr(module, name)
    raise AttributeError(f"module 'taptune.machine' has no attribute {name!r}")
