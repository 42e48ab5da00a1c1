"""Complex modes and receptances of the free-free model (MODEL.md §7).

Eigenvalues are λ_r = ω_r² (1 + i η_r); f_r = sqrt(Re λ_r)/2π, ζ_r = η_r/2. Vectors are
normalised with the unconjugated transpose, φᵀ M φ = 1, so that the modes of the complex
symmetric K̃ are orthogonal even with non-proportional damping.

The lowest modes come from a shift-invert Arnoldi solve (ARPACK) around
σ = −(2π·200 Hz)² (below every eigenvalue, so K̃ − σM is non-singular even though the
model is free-free), on a banded LU of K̃ − σM with the DOFs ordered by z. Receptances
use the exact rigid-body vectors, the computed elastic modes and the residual of all
higher modes to first order in ω² about σ, which that factorisation gives for free.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.linalg as sla
import scipy.sparse.linalg as spla
from scipy.linalg.lapack import zgbtrf, zgbtrs

from taptune.errors import TaptuneError
from taptune.model.fe import FEModel, build_model
from taptune.model.options import ModelOptions
from taptune.model.params import NOMINAL, HolderParams

# Shift of the shift-invert solve [rad²/s²]: below the rigid-body pair, so K̃ − σM is regular.
SIGMA = -((2 * np.pi * 200.0) ** 2)
TWO_PI = 2 * np.pi


class ModelError(TaptuneError):
    """The model cannot be solved as a connected free-free body (e.g. no contact)."""


@dataclass(frozen=True)
class Modes:
    """Elastic modes of the free-free model, in ascending frequency.

    Attributes
    ----------
    frequency_hz : ndarray, shape (n,)
        f_r = sqrt(Re λ_r) / 2π [Hz].
    damping_ratio : ndarray, shape (n,)
        ζ_r = η_r / 2.
    loss_factor : ndarray, shape (n,)
        η_r = Im λ_r / Re λ_r.
    eigenvalues : ndarray, complex, shape (n,)
        λ_r [rad²/s²].
    vectors : ndarray, complex, shape (n_dofs, n)
        Mode shapes with φᵀ M φ = 1 (unconjugated).
    rigid_hz : ndarray, shape (2,)
        Frequencies of the two numerical rigid-body modes [Hz] (ideally ≈ 0).
    """

    frequency_hz: np.ndarray
    damping_ratio: np.ndarray
    loss_factor: np.ndarray
    eigenvalues: np.ndarray
    vectors: np.ndarray
    rigid_hz: np.ndarray


def _frequency_hz(lam) -> np.ndarray:
    return np.sqrt(np.abs(np.real(lam))) / TWO_PI


def normalise(vectors, M) -> np.ndarray:
    """Scale columns so that φᵀ M φ = 1 with the plain (unconjugated) transpose."""
    scale = np.sqrt(np.einsum("ir,ir->r", vectors, M @ vectors))
    return vectors / scale[None, :]


def rigid_body_modes(fe: FEModel, M) -> np.ndarray:
    """Exact rigid-body modes (t, r) M-orthonormalised by Gram–Schmidt, shape (n_dofs, 2)."""
    t, r = fe.rigid_vectors
    t = t / np.sqrt(t @ (M @ t))
    r = r - (t @ (M @ r)) * t
    r = r / np.sqrt(r @ (M @ r))
    return np.stack([t, r], axis=1)


def check_rigid_pair(lam_sorted) -> None:
    """MODEL.md §7.2: exactly two (near-)zero eigenvalues, else the model is disconnected."""
    f = _frequency_hz(lam_sorted)
    if len(f) < 3:
        raise ModelError("the model has fewer than three modes; it cannot be a holder with a tool")
    limit = max(1.0, 1e-3 * f[2])
    if f[0] > limit or f[1] > limit:
        raise ModelError(
            f"the free-free model has no rigid-body pair (lowest modes {f[0]:.3g}, {f[1]:.3g} Hz): "
            "the matrices are broken"
        )
    if f[2] <= limit:
        raise ModelError(
            f"the model has more than two rigid-body modes ({f[2]:.3g} Hz is near zero): "
            "tool and holder are not connected (contact stiffness zero?)"
        )


class BandedLU:
    """LU factorisation of K̃ − s·M in the model's z-ordered band (LAPACK ``zgbtrf``).

    Parameters
    ----------
    fe : FEModel
        Supplies the pattern and its banded layout.
    k_values, m_values : ndarray, shape (nnz,)
        K̃ and M on ``fe.pattern``.
    shift : float
        s [rad²/s²].
    """

    def __init__(self, fe: FEModel, k_values, m_values, shift: float):
        band = fe.band
        self.perm = band.perm
        self.bandwidth = band.bandwidth
        ab = np.zeros((3 * self.bandwidth + 1, fe.n_dofs), dtype=complex)
        ab[band.ab_rows, band.ab_cols] = k_values - shift * m_values
        self.lu, self.piv, info = zgbtrf(ab, self.bandwidth, self.bandwidth, overwrite_ab=1)
        if info != 0:
            raise ModelError(f"K̃ − ω²M is singular at ω² = {shift:.6g} rad²/s²")

    def solve(self, rhs) -> np.ndarray:
        """x = (K̃ − sM)⁻¹ rhs for rhs of shape (n,) or (n, m), in global DOF order."""
        rhs = np.asarray(rhs, dtype=complex)
        x, info = zgbtrs(self.lu, self.bandwidth, self.bandwidth, rhs[self.perm], self.piv)
        out = np.empty_like(x)
        out[self.perm] = x
        return out


@dataclass(frozen=True)
class _Eigen:
    """Lowest eigenpairs (sorted by Re λ, rigid pair included) and the factorised K̃ − σM."""

    lam: np.ndarray
    vec: np.ndarray
    lu: object
    sigma: float


def _eigen(fe: FEModel, params: HolderParams, k: int, sigma: float = SIGMA) -> _Eigen:
    """The k eigenpairs nearest σ, sorted by Re λ, with the factorisation of K̃ − σM.

    Implicitly restarted Arnoldi (ARPACK) in shift-invert mode on the banded LU: cheaper
    here than block subspace iteration, whose last wanted mode converges slowly.
    """
    kv, mv = fe.stiffness_values(params), fe.mass_values(params)
    K, M = fe.pattern.csr(kv), fe.pattern.csr(mv)
    lu = BandedLU(fe, kv, mv, sigma)
    n = fe.n_dofs
    if k >= n - 1:
        lam, vec = sla.eig(K.toarray(), M.toarray())
    else:
        op = spla.LinearOperator((n, n), matvec=lu.solve, dtype=complex)
        # A fixed start vector: ARPACK's default is random, and results must be repeatable.
        v0 = np.random.default_rng(0).standard_normal(n).astype(complex)
        try:
            lam, vec = spla.eigs(
                K, k=k, M=M, sigma=sigma, OPinv=op, v0=v0, ncv=min(n - 1, max(2 * k + 1, 20)), tol=1e-12
            )
        except spla.ArpackNoConvergence:
            # Rare (clustered eigenvalues): the dense solve is slow but always answers.
            lam, vec = sla.eig(K.toarray(), M.toarray())
            nearest = np.argsort(np.abs(lam - sigma))[:k]
            lam, vec = lam[nearest], vec[:, nearest]
    # The unconjugated Rayleigh quotient is stationary for a complex symmetric pencil: it
    # makes λ (and so tiny modal loss factors) accurate to the square of the vector error.
    lam = np.einsum("ir,ir->r", vec, K @ vec) / np.einsum("ir,ir->r", vec, M @ vec)
    order = np.argsort(lam.real)
    return _Eigen(lam[order], vec[:, order], lu, sigma)


def _elastic(fe: FEModel, params: HolderParams, n_modes: int | None):
    """Solve, check the rigid pair, return (eigen, elastic λ, elastic normalised φ, M)."""
    # The rigid-body pair plus the wanted modes; the first elastic one shows whether a
    # third near-zero mode exists (§7.2).
    k = fe.n_dofs if n_modes is None else min(fe.n_dofs, n_modes + 2)
    eig = _eigen(fe, params, k)
    check_rigid_pair(eig.lam)
    keep = slice(2, None if n_modes is None else 2 + n_modes)
    M = fe.mass(params)
    return eig, eig.lam[keep], normalise(eig.vec[:, keep], M), M


def solve_modes(fe: FEModel, params: HolderParams, n_modes: int = 5) -> Modes:
    """The lowest elastic modes of the free-free model (MODEL.md §7.1–7.2).

    Parameters
    ----------
    fe : FEModel
        Model pieces from :func:`~taptune.model.fe.build_model`.
    params : HolderParams
        Holder parameters.
    n_modes : int
        Number of elastic modes (the rigid-body pair is not counted).

    Returns
    -------
    Modes

    Raises
    ------
    ModelError
        When the model does not have exactly two rigid-body modes (disconnected).
    """
    eig, lam, vec, _ = _elastic(fe, params, n_modes)
    eta = lam.imag / lam.real
    return Modes(
        frequency_hz=_frequency_hz(lam),
        damping_ratio=eta / 2,
        loss_factor=eta,
        eigenvalues=lam,
        vectors=vec,
        rigid_hz=_frequency_hz(eig.lam[:2]),
    )


def _omega2(freq_hz) -> np.ndarray:
    f = np.atleast_1d(np.asarray(freq_hz, dtype=float))
    if np.any(f <= 0):
        raise ValueError("receptances of a free-free model are undefined at 0 Hz: use frequencies > 0")
    return (TWO_PI * f) ** 2


def modal_receptance(lam, phi_i, phi_j, rigid_i, rigid_j, freq_hz, residual=(0.0, 0.0), sigma=SIGMA) -> np.ndarray:
    """Receptance by modal superposition (MODEL.md §7.3) [m/N for w/f].

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
    """Receptance H_ij by solving (K̃ − ω² M) x = e_j per frequency (MODEL.md §7.4), shape (m,)."""
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
    """Tool-tip direct receptance H_tt(f) [m/N] (MODEL.md §7.3–7.4).

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
    eig, lam, vec, M = _elastic(fe, params, n_modes)
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
    """Translational mode shapes of each body for plotting (MODEL.md §12).

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
    """Per-mode indicators of MODEL.md §7.6, shape (n,) each.

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
    """Tip participation and contact strain-energy share of each mode (MODEL.md §7.6)."""
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
        Diagnostics of MODEL.md §7.6 per mode.
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
        Holder parameters; the nominal set of MODEL.md §8.1 when omitted.
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
