"""Physical bounds of the bending frequencies over the search space (docs/physics.md §3).

They help label measured peaks: a peak outside [lower, upper] of mode n cannot be bending
mode n of this assembly for any admissible holder. Eigenvalues grow monotonically with
stiffness and fall with mass, so

* upper: tool and holder tied in the contact zone (infinitely stiff contact), holder
  modulus factor at its maximum (1.10) and density factor at its minimum (0.95);
* lower: the softest contact of the search space (k_tt = 1e4 N/m per mm, k_rr = 1e2
  N·m/rad per mm), modulus factor 0.90, density factor 1.05. Damping and the slope α
  move it slightly, so the lowest over the loss/slope corners is taken and padded.
"""

from __future__ import annotations

import itertools

import numpy as np

from taptune.io.assembly import Assembly
from taptune.model.fe import build_model, rigid_contact_model, stiffest_holder
from taptune.model.modes import solve_modes
from taptune.model.options import ModelOptions
from taptune.model.params import P_LOWER, P_UPPER, HolderParams

# Relative padding of the approximate lower bound.
LOWER_PAD = 0.01
N_BENDING = 3


def soft_corner_params() -> list[HolderParams]:
    """The softest contact with every combination of loss intensities and slope bounds."""
    out = []
    for eta_tt, eta_rr, alpha in itertools.product((P_LOWER[2], P_UPPER[2]), (P_LOWER[3], P_UPPER[3]), (P_LOWER[4], P_UPPER[4])):
        out.append(
            HolderParams(
                k_tt=10.0 ** P_LOWER[0], k_rr=10.0 ** P_LOWER[1], eta_tt=10.0**eta_tt, eta_rr=10.0**eta_rr,
                alpha=float(alpha), density_factor=P_UPPER[5], modulus_factor=P_LOWER[6],
            )
        )
    return out


def bending_bounds(assembly: Assembly, options: ModelOptions = ModelOptions(), fe=None) -> np.ndarray:
    """Lowest and highest reachable frequency of bending modes 1–3 [Hz] (docs/physics.md §3).

    Parameters
    ----------
    assembly : Assembly
        Validated geometry.
    options : ModelOptions
        Mesh options.
    fe : FEModel, optional
        A model already built for ``assembly`` and ``options`` (saves the build).

    Returns
    -------
    ndarray, shape (3, 2)
        Row n: (lower, upper) for bending mode n + 1 [Hz].
    """
    fe = build_model(assembly, options) if fe is None else fe
    upper = solve_modes(rigid_contact_model(fe), stiffest_holder(), N_BENDING).frequency_hz
    lower = np.min([solve_modes(fe, p, N_BENDING).frequency_hz for p in soft_corner_params()], axis=0)
    return np.stack([lower * (1 - LOWER_PAD), upper], axis=1)
