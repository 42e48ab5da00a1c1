"""Consistent matrices of the distributed tool–holder contact layer (docs/physics.md §1).

The layer's strain energy is ½∫ k_t(z) (w_t − w_h)² + k_r(z) (θ_t − θ_h)² dz with line
densities k(z) = c · (1 + a ξ(z)), ξ = 2 (z − z_c0)/L_c − 1, a = α/100. The parameters
enter affinely, so the layer is stored as four real, parameter-free matrices:

    K_c = c_t (T0 + a T1) + c_r (R0 + a R1)

with c_t, c_r the complex line stiffnesses per metre of contact. Each coincident element
pair (holder element and tool element over the same [z_a, z_b]) contributes 8×8 blocks
on [w1, θ1, w2, θ2] of the holder element, then of the tool element, integrated with
each body's own Timoshenko interpolation by 4-point Gauss quadrature (exact: the
integrand is a polynomial of degree 7 in z).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from taptune.model.elements import shape_functions

_GAUSS_X, _GAUSS_W = np.polynomial.legendre.leggauss(4)
# Gauss points and weights on [0, 1].
GAUSS_XI = 0.5 * (_GAUSS_X + 1.0)
GAUSS_W = 0.5 * _GAUSS_W


@dataclass(frozen=True)
class ContactBlocks:
    """Element-pair blocks of the contact layer, each of shape (n_c, 8, 8).

    ``t0``/``t1``: translational layer, uniform part and ξ-weighted part [m];
    ``r0``/``r1``: rotational layer [m]; the units of a block entry follow from the
    DOFs it joins (multiplying by c [N/m per m] gives N/m, N, N·m).
    """

    t0: np.ndarray
    t1: np.ndarray
    r0: np.ndarray
    r1: np.ndarray


def contact_blocks(z_a, length, phi_holder, phi_tool, zone) -> ContactBlocks:
    """Consistent contact blocks for coincident element pairs (docs/physics.md §1).

    Parameters
    ----------
    z_a : array_like, shape (n_c,)
        Start of each element pair [m].
    length : array_like, shape (n_c,)
        Element length [m] (the same for the holder and the tool element).
    phi_holder, phi_tool : array_like, shape (n_c,)
        Shear parameters of the holder and tool elements.
    zone : tuple of float
        (z_c0, L_h), the contact zone [m].

    Returns
    -------
    ContactBlocks
    """
    z_a = np.asarray(z_a, dtype=float)
    l = np.asarray(length, dtype=float)
    nw_h, nt_h = shape_functions(GAUSS_XI, l, phi_holder)
    nw_t, nt_t = shape_functions(GAUSS_XI, l, phi_tool)
    b_w = np.concatenate([-nw_h, nw_t], axis=-1)  # (n_c, q, 8): relative displacement
    b_t = np.concatenate([-nt_h, nt_t], axis=-1)  # relative rotation
    z = z_a[:, None] + l[:, None] * GAUSS_XI[None, :]
    xi = 2.0 * (z - zone[0]) / (zone[1] - zone[0]) - 1.0
    w0 = GAUSS_W[None, :] * l[:, None]  # dz weights, (n_c, q)
    w1 = w0 * xi

    def integrate(weights, b):
        return np.einsum("eq,eqi,eqj->eij", weights, b, b)

    return ContactBlocks(
        t0=integrate(w0, b_w), t1=integrate(w1, b_w), r0=integrate(w0, b_t), r1=integrate(w1, b_t)
    )
