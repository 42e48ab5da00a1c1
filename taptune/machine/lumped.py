"""The traditional lumped tool–holder joint, for comparison (`--contact`, docs/machine.md).

Tool and holder are joined only at the front-face node by one translational and one
rotational spring-damper k(1 + iη); the tool's inserted part hangs free in the bore.
By default the springs are the identified distributed layer integrated over the contact
zone, so both models hold the same joint and differ only in where it acts:

    k_t = c_t L_c                                  (the slope averages out)
    k_θ = c_r L_c + c_t L_c³ (3 − a²) / 36         (rotation about the layer's stiffness
                                                    centre, ξ̄ = a/3; a = α/100)

with c_t, c_r the complex line stiffnesses of :class:`~taptune.model.params.HolderParams`;
η = Im k / Re k. Published lumped values (e.g. for ER32 collets or shrink fits) can be
given instead through :class:`LumpedJoint`.

Signatures::

    LumpedJoint(k_t, k_r, eta_t=0.0, eta_r=0.0)                # N/m, N·m/rad, –, –
    lumped_from_layer(params, contact_length) -> LumpedJoint
    lumped_contact_model(fe, params, lumped=None) -> (FEModel, HolderParams)
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
import scipy.sparse as sp

from taptune.model.fe import FEModel
from taptune.model.params import ETA_REFERENCE_MM, HolderParams


@dataclass(frozen=True)
class LumpedJoint:
    """Front-face springs: k_t [N/m], k_r [N·m/rad] and their loss factors η."""

    k_t: float
    k_r: float
    eta_t: float = 0.0
    eta_r: float = 0.0

    def to_dict(self) -> dict:
        return {"k_t": self.k_t, "k_r": self.k_r, "eta_t": self.eta_t, "eta_r": self.eta_r}


def lumped_from_layer(params: HolderParams, contact_length: float) -> LumpedJoint:
    """The distributed layer integrated over a contact zone of length L_c [m] (module docstring)."""
    L, a = contact_length, params.alpha / 100.0
    k_t = params.c_t * L
    k_r = params.c_r * L + params.c_t * L**3 * (3 - a * a) / 36.0
    return LumpedJoint(k_t=k_t.real, k_r=k_r.real, eta_t=k_t.imag / k_t.real, eta_r=k_r.imag / k_r.real)


def lumped_contact_model(fe: FEModel, params: HolderParams, lumped: LumpedJoint | None = None):
    """The model ``fe`` with its contact layer replaced by front-face springs.

    The springs take the place of the layer's pieces (T0: translational, R0: rotational,
    each a unit spring between the coincident holder and tool front-face nodes), and the
    returned parameters carry their complex stiffness in c_t, c_r, so every solver of
    the model layer applies unchanged.

    Returns
    -------
    (FEModel, HolderParams)
    """
    if fe.rigid_contact:
        raise ValueError("the lumped joint replaces a distributed contact, not a tied one")
    zone = fe.z_nodes[fe.contact_nodes[:, 0]]
    joint = lumped or lumped_from_layer(params, float(zone.max() - zone.min()))
    h_node, t_node = fe.contact_nodes[np.argmax(zone)]
    n = fe.n_dofs

    def spring(offset):
        i, j = 2 * h_node + offset, 2 * t_node + offset
        return sp.csr_matrix(([1.0, -1.0, -1.0, 1.0], ([i, i, j, j], [i, j, i, j])), shape=(n, n))

    zero = sp.csr_matrix((n, n))
    model = replace(fe, T0=spring(0), T1=zero, R0=spring(1), R1=zero)
    # c = k·1e3·(1 + i·eta·10 mm) in HolderParams: invert that to carry k(1 + iη).
    p = replace(params, k_tt=joint.k_t / 1e3, k_rr=joint.k_r / 1e3, eta_tt=joint.eta_t / ETA_REFERENCE_MM,
                eta_rr=joint.eta_r / ETA_REFERENCE_MM, alpha=0.0)
    return model, p
