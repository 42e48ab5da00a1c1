"""Receptance coupling of the cut holder model to a measured spindle (Schmitz & Smith, *Machining Dynamics*).

Rigid joint at the coupling plane:

    G11 = H11 − H12 (H22 + H_S)⁻¹ H21

and with a flexible joint of complex stiffness K_j (2×2): H22 + K_j⁻¹ + H_S in place of
H22 + H_S. The tool-point FRF for stability is G11[w, f] per bending direction.

Signatures::

    couple(h11, h12, h21, h22, h_s, joint=None) -> ndarray (n, 2, 2)
    toolpoint_frf(assembly, params, spindle, freq_hz, model_options=None, joint=None,
                  contact="distributed", method="modal", lumped=None) -> ToolpointFRF
    coupled_model(assembly, params, model_options=None, contact="distributed", lumped=None)
        -> (FEModel, HolderParams)                # the cut model actually coupled

``spindle`` is ``{"x": SpindleReceptance, "y": SpindleReceptance or None}`` (y = x when
absent or None). ``contact`` selects the tool–holder joint of the holder model
(`--contact`, docs/machine.md): ``"distributed"`` (the identified layer), ``"rigid"`` (tool and holder
DOFs tied over the contact zone) or ``"lumped"`` (one translational and one rotational
spring k(1 + iη) at the front face; see :mod:`taptune.machine.lumped`).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from taptune.errors import InputError
from taptune.io.assembly import Assembly
from taptune.io.machine import SpindleReceptance
from taptune.machine.blocks import receptance_blocks
from taptune.machine.lumped import LumpedJoint, lumped_contact_model
from taptune.machine.peaks import dominant_modes
from taptune.machine.plane import coupling_plane, cut_assembly
from taptune.model.fe import FEModel, build_model, rigid_contact_model
from taptune.model.options import ModelOptions
from taptune.model.params import HolderParams

MM = 1e-3
CONTACTS = ("distributed", "rigid", "lumped")


def couple(h11, h12, h21, h22, h_s, joint=None) -> np.ndarray:
    """Coupled receptance at point 1, G11 = H11 − H12 (H22 [+ K_j⁻¹] + H_S)⁻¹ H21, shape (n, 2, 2).

    Parameters
    ----------
    h11, h12, h21, h22 : ndarray, complex, shape (n, 2, 2)
        Free-free receptance blocks of the holder side (point 2 = coupling node).
    h_s : ndarray, complex, shape (n, 2, 2)
        Spindle receptance at the coupling plane.
    joint : ndarray, complex, shape (2, 2) or (n, 2, 2), optional
        Joint stiffness K_j [N/m, N; N, N·m/rad] (e.g. diag(k(1+iη), k_θ(1+iη))); rigid
        when omitted.
    """
    a = np.asarray(h22) + np.asarray(h_s)
    if joint is not None:
        a = a + np.linalg.inv(np.broadcast_to(np.asarray(joint, dtype=complex), a.shape))
    return np.asarray(h11) - np.asarray(h12) @ np.linalg.solve(a, np.asarray(h21))


@dataclass(frozen=True)
class ToolpointFRF:
    """The tool-point FRF on the machine for one stick-out.

    Attributes
    ----------
    freq_hz : ndarray, shape (n,)
        Frequencies [Hz].
    xx, yy : ndarray, complex, shape (n,)
        G11[w, f] in the x and y bending directions [m/N].
    modes : tuple of FRFMode
        Dominant peaks of |G| (frequency, damping ratio, direction), strongest first.
    stickout : float
        Tool stick-out [m].
    coupling_plane : float
        z of the coupling plane in the holder's coordinates [m].
    contact : str
        Tool–holder joint of the holder model ("distributed", "rigid", "lumped").
    """

    freq_hz: np.ndarray = field(repr=False)
    xx: np.ndarray = field(repr=False)
    yy: np.ndarray = field(repr=False)
    modes: tuple = ()
    stickout: float = 0.0
    coupling_plane: float = 0.0
    contact: str = "distributed"

    def to_dict(self) -> dict:
        """One entry of docs/machine.md's ``predictions`` list (mm, Hz, m/N)."""
        return {
            "stickout": round(self.stickout / MM, 6),
            "coupling_plane_mm": round(self.coupling_plane / MM, 6),
            "contact": self.contact,
            "frequency_hz": [float(f) for f in self.freq_hz],
            "x": {"re": self.xx.real.tolist(), "im": self.xx.imag.tolist()},
            "y": {"re": self.yy.real.tolist(), "im": self.yy.imag.tolist()},
            "modes": [m.to_dict() for m in self.modes],
        }


def coupled_model(assembly: Assembly, params: HolderParams, model_options: ModelOptions | None = None,
                  contact: str = "distributed", lumped: LumpedJoint | None = None) -> tuple[FEModel, HolderParams]:
    """The free-free model of the holder cut at the coupling plane, with the chosen contact.

    Returns the model and the parameters to evaluate it with (the lumped variant carries
    its springs in the parameters, see :func:`taptune.machine.lumped.lumped_contact_model`).
    """
    if contact not in CONTACTS:
        raise InputError(f"{assembly.source}: unknown contact model {contact!r} (use one of {', '.join(CONTACTS)})")
    fe = build_model(cut_assembly(assembly), model_options or ModelOptions())
    if contact == "rigid":
        return rigid_contact_model(fe), params
    if contact == "lumped":
        return lumped_contact_model(fe, params, lumped)
    return fe, params


def _spindle_pair(spindle) -> tuple[SpindleReceptance, SpindleReceptance]:
    if isinstance(spindle, SpindleReceptance):
        return spindle, spindle
    x = spindle.get("x")
    if not isinstance(x, SpindleReceptance):
        raise InputError("machine: the spindle needs an x-direction receptance")
    y = spindle.get("y") or x
    if not isinstance(y, SpindleReceptance):
        raise InputError("machine: the y-direction spindle must be a receptance (or absent: y = x)")
    return x, y


def toolpoint_frf(assembly: Assembly, params: HolderParams, spindle, freq_hz, model_options: ModelOptions | None = None,
                  joint=None, contact: str = "distributed", method: str = "modal",
                  lumped: LumpedJoint | None = None) -> ToolpointFRF:
    """Tool-point FRF of an assembly on a machine (receptance coupling, docs/machine.md).

    Parameters
    ----------
    assembly : Assembly
        Holder, tool and stick-out; the holder's ``gauge_length`` or interface fixes the
        coupling plane (docs/machine.md).
    params : HolderParams
        Identified (or library) holder parameters.
    spindle : dict or SpindleReceptance
        ``{"x": SpindleReceptance, "y": SpindleReceptance or None}``; y = x when absent.
    freq_hz : array_like, shape (n,)
        Frequencies [Hz], > 0, inside the spindle files' band.
    model_options : ModelOptions, optional
    joint : array_like, complex, shape (2, 2), optional
        Flexible holder–spindle joint K_j; rigid when omitted.
    contact : {"distributed", "rigid", "lumped"}
        Tool–holder joint model (`--contact`, docs/machine.md).
    method : {"modal", "direct"}
        Route for the holder's receptance blocks (:mod:`taptune.machine.blocks`).
    lumped : LumpedJoint, optional
        Springs of the lumped contact; by default the identified layer integrated over
        the contact zone.

    Returns
    -------
    ToolpointFRF
    """
    f = np.atleast_1d(np.asarray(freq_hz, dtype=float))
    sx, sy = _spindle_pair(spindle)
    hs_x = sx.at(f)
    hs_y = hs_x if sy is sx else sy.at(f)  # y = x: interpolate the spindle file once
    fe, p = coupled_model(assembly, params, model_options, contact, lumped)
    b = receptance_blocks(fe, p, f, method)
    gx = couple(b.h11, b.h12, b.h21, b.h22, hs_x, joint)[:, 0, 0]
    gy = gx if sy is sx else couple(b.h11, b.h12, b.h21, b.h22, hs_y, joint)[:, 0, 0]
    modes = dominant_modes(f, gx, "x") + dominant_modes(f, gy, "y")
    modes = tuple(sorted(modes, key=lambda m: -m.magnitude))
    return ToolpointFRF(freq_hz=f, xx=gx, yy=gy, modes=modes, stickout=assembly.stickout,
                        coupling_plane=coupling_plane(assembly.holder, assembly.source), contact=contact)
