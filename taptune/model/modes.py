"""Receptances, mode shapes and diagnostics of the free-free model (docs/physics.md §3).

The modes themselves come from :mod:`taptune.model.eigen`. Receptances use the exact
rigid-body vectors, the computed elastic modes and the residual of all higher modes to
first order in ω² about σ, which the eigen-solution's factorisation of K̃ − σM gives for
free. :func:`analyse` is the one call that builds, solves and diagnoses an assembly.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse.linalg as spla

# ModelError, Modes and solve_modes are also imported from here by callers.
from taptune.model.eigen import (  # noqa: F401
    SIGMA,
    TWO_PI,
    BandedLU,
    ModelError,
    Modes,
    elastic_solution,
    rigid_body_modes,
    solve_modes,
)
from taptune.model.fe import FEModel, build_model
from taptune.model.options import ModelOptions
from taptune.model.params import NOMINAL, HolderParams


def _omega2(freq_hz) -> np.ndarray:
    f = np.atleast_1d(np.asarray(freq_hz, dtype=float))
    if np.any(f <= 0):
        raise ValueError("receptances of a free-free model are undefined at 0 Hz: use frequencies > 0")
    return (TWO_PI * f) ** 2


def modal_receptance(lam, phi_i, phi_j, rigid_i, rigid_j, freq_hz, residual=(0.0, 0.0), sigma=SIGMA) -> np.ndarray:
    """Receptance by modal superposition (docs/physics.md §3) [m/N for w/f].

    Parameters
    ----------
    lam : ndarray, complex, shape (n,)
        Elastic eigenvalues [rad²/s²].
    phi_i, phi_j : ndarray, shape (n,)
        Mass-normalised elastic mode shapes at the response and load DOF.
    rigid_i, rigid_j : ndarray, shape (2,)
        M-orthonormal rigid-body vectors at the same DOFs.
    freq_hz : array_like, shape (m,)
        Frequencies [Hz], > 0.
    residual : tuple of complex
        (R0, R1): contribution of the modes not included, to first order in ω² about σ:
        R0 + (ω² − σ) R1.
    sigma : float
        Expansion point of the residual [rad²/s²].
    """
    w2 = _omega2(freq_hz)
    h = np.sum(rigid_i * rigid_j) / (-w2)
    h = h + (phi_i * phi_j)[None, :] @ (1.0 / (lam[:, None] - w2[None, :]))
    return h.ravel() + residual[0] + (w2 - sigma) * residual[1]


def direct_receptance(K, M, i: int, j: int, freq_hz) -> np.ndarray:
    """Receptance H_ij by solving (K̃ − ω² M) x = e_j per frequency (docs/physics.md §3), shape (m,)."""
    w2 = _omega2(freq_hz)
    e = np.zeros(K.shape[0], dtype=complex)
    e[j] = 1.0
    K = K.tocsc().astype(complex)
    M = M.tocsc()
    out = np.empty(len(w2), dtype=complex)
    for n, w in enumerate(w2):
        out[n] = spla.splu((K - w * M).tocsc()).solve(e)[i]
    return out


def tip_receptance(fe: FEModel, params: HolderParams, freq_hz, method: str = "modal", n_modes: int | None = 12):
    """Tool-tip direct receptance H_tt(f) [m/N] (docs/physics.md §3).

    Parameters
    ----------
    fe : FEModel
    params : HolderParams
    freq_hz : array_like, shape (m,)
        Frequencies [Hz], > 0.
    method : {"modal", "direct"}
        ``"modal"``: exact rigid-body terms, the ``n_modes`` lowest elastic modes and the
        residual of all other modes at σ to first order in ω² (``n_modes=None``: every elastic mode, by
        a dense solve, no residual needed). ``"direct"``: one sparse LU per frequency.
    n_modes : int or None
        Elastic modes in the modal sum.

    Returns
    -------
    ndarray, complex, shape (m,)
    """
    tip = fe.tip_dof
    if method == "direct":
        kv, mv = fe.stiffness_values(params), fe.mass_values(params)
        e = np.zeros(fe.n_dofs, dtype=complex)
        e[tip] = 1.0
        return np.array([BandedLU(fe, kv, mv, w2).solve(e)[tip] for w2 in _omega2(freq_hz)])
    if method != "modal":
        raise ValueError(f"unknown receptance method {method!r}")
    eig, lam, vec, M = elastic_solution(fe, params, n_modes)
    rigid = rigid_body_modes(fe, M)[tip]
    phi = vec[tip]
    residual = (0.0, 0.0)
    if n_modes is not None:
        # The omitted modes, to first order in ω² about σ. Solving with a load from which
        # the rigid-body and retained modes are removed (unconjugated M-projection) gives
        # x = Σ_omitted φ φ_tip / (λ − σ) directly, so R0 = x_tip and R1 = xᵀ M x, without
        # the cancellation against the huge rigid-body terms at σ.
        psi = rigid_body_modes(fe, M)
        basis = np.concatenate([psi, vec], axis=1)
        e = -(M @ basis) @ basis[tip]
        e[tip] += 1.0
        x = eig.lu.solve(e.astype(complex))
        residual = (x[tip], x @ (M @ x))
    return modal_receptance(lam, phi, phi, rigid, rigid, freq_hz, residual, eig.sigma)


def mode_shapes(fe: FEModel, modes: Modes):
    """Translational mode shapes of each body for plotting.

    Returns
    -------
    z_holder : ndarray, shape (n_h,)
        Holder node positions [m].
    w_holder : ndarray, complex, shape (n_h, n_modes)
        Holder w of each mass-normalised mode.
    z_tool : ndarray, shape (n_t,)
    w_tool : ndarray, complex, shape (n_t, n_modes)
        The same for the tool (for the rigid-contact variant: its untied nodes).
    """
    n_h = len(fe.z_holder)
    w = modes.vectors[0::2]
    return fe.z_holder, w[:n_h], fe.z_tool, w[n_h:]


# --------------------------------------------------------------------------- diagnostics


@dataclass(frozen=True)
class ModeDiagnostics:
    """Per-mode indicators of docs/physics.md §3, shape (n,) each.

    ``tip_participation``: |φ_tip|² relative to the largest among the first three modes;
    ``contact_energy_share``: contact-layer share of the mode's strain energy
    (Re φᵀ K̃_c φ / Re φᵀ K̃ φ, with the physical (conjugated) energy).
    """

    tip_participation: np.ndarray
    contact_energy_share: np.ndarray

    def warnings(self, n_check: int = 3) -> list[str]:
        """Warnings for modes 1 … n_check that a tip tap hardly excites or that rock the tool."""
        out = []
        for r in range(min(n_check, len(self.tip_participation))):
            if self.tip_participation[r] < 0.01:
                out.append(
                    f"bending mode {r + 1} has a tool-tip participation of "
                    f"{100 * self.tip_participation[r]:.2g} % of the strongest: a tip tap will hardly show it"
                )
            if self.contact_energy_share[r] > 0.5:
                out.append(
                    f"bending mode {r + 1} stores {100 * self.contact_energy_share[r]:.0f} % of its strain energy "
                    "in the contact: the tool rocks in the holder (very soft contact)"
                )
        return out


def mode_diagnostics(fe: FEModel, params: HolderParams, modes: Modes) -> ModeDiagnostics:
    """Tip participation and contact strain-energy share of each mode (docs/physics.md §3)."""
    phi = modes.vectors
    tip = np.abs(phi[fe.tip_dof]) ** 2
    ref = np.max(tip[:3]) if len(tip) else 1.0
    K = fe.stiffness(params)
    Kc = fe.contact_stiffness(params)
    total = np.real(np.einsum("ir,ir->r", phi.conj(), K @ phi))
    contact = np.real(np.einsum("ir,ir->r", phi.conj(), Kc @ phi))
    return ModeDiagnostics(tip_participation=tip / ref, contact_energy_share=contact / total)


# --------------------------------------------------------------------------- convenience


@dataclass(frozen=True)
class ModelResult:
    """What ``taptune model`` shows: bending modes of one assembly with one parameter set.

    Attributes
    ----------
    bending_hz, damping_ratio : tuple of float
        Elastic (bending) modes in ascending frequency [Hz], damping ratios ζ.
    dofs, elements : int
        Size of the model.
    params : HolderParams
    tip_participation, contact_energy_share : tuple of float
        Diagnostics of docs/physics.md §3 per mode.
    warnings : tuple of str
        Assembly warnings and mode diagnostics.
    options : dict
        ModelOptions used (provenance).
    """

    bending_hz: tuple
    damping_ratio: tuple
    dofs: int
    elements: int
    params: HolderParams
    tip_participation: tuple = ()
    contact_energy_share: tuple = ()
    warnings: tuple = ()
    options: dict | None = None

    def to_dict(self) -> dict:
        """JSON-able result; Hz to 0.01 Hz, damping ratios to 5 significant digits."""
        return {
            "bending_hz": [round(float(f), 2) for f in self.bending_hz],
            "damping_ratio": [float(f"{z:.5g}") for z in self.damping_ratio],
            "dofs": int(self.dofs),
            "elements": int(self.elements),
            "params": self.params.to_dict(),
            "tip_participation": [float(f"{v:.4g}") for v in self.tip_participation],
            "contact_energy_share": [float(f"{v:.4g}") for v in self.contact_energy_share],
            "model_options": dict(self.options or {}),
            "warnings": list(self.warnings),
        }


def analyse(assembly, params: HolderParams | None = None, options=None, n_modes: int = 5, fe=None) -> ModelResult:
    """Bending frequencies and damping of an assembly (build, solve, diagnose).

    Parameters
    ----------
    assembly : Assembly
        Validated geometry.
    params : HolderParams, optional
        Holder parameters; the nominal set of docs/physics.md §2 when omitted.
    options : ModelOptions, optional
    n_modes : int
        Elastic modes to report.
    fe : FEModel, optional
        The model of ``assembly`` with ``options``, when the caller has built it already.
    """
    params = NOMINAL if params is None else params
    options = ModelOptions() if options is None else options
    fe = build_model(assembly, options) if fe is None else fe
    modes = solve_modes(fe, params, n_modes)
    diag = mode_diagnostics(fe, params, modes)
    return ModelResult(
        bending_hz=tuple(map(float, modes.frequency_hz)),
        damping_ratio=tuple(map(float, modes.damping_ratio)),
        dofs=fe.n_dofs,
        elements=fe.n_elements,
        params=params,
        tip_participation=tuple(map(float, diag.tip_participation)),
        contact_energy_share=tuple(map(float, diag.contact_energy_share)),
        warnings=tuple(assembly.warnings) + tuple(diag.warnings()),
        options=options.to_dict(),
    )
