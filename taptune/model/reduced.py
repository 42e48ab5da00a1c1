"""Fast reduced evaluator of the holder–tool model for the optimiser (docs/physics.md §4).

The optimiser needs f1–f3, ζ1 and the tool-tip receptance on a 201-point window for
thousands of parameter vectors p (docs/physics.md §2) per identification. The full model
(``build_model`` + ``solve_modes``) costs milliseconds per p; this module builds, once
per assembly, a small Galerkin model that reproduces it and answers in a fraction of
that.

Method (all parameter-free work is done once in :meth:`FastEvaluator.from_model`):

1. **Component basis** per body (holder, tool): free-free modes of the body (rigid pair
   included), attachment shapes (K_b − σM_b)⁻¹f for line loads of Legendre profile
   P0 … P23 over the contact zone (forces and moments: the only loads the contact layer
   can put on a body; 24 profiles resolve the boundary layers of a stiff contact at the
   zone ends, 16 left 0.3 % in |H| at the stiffest corners), and, for the tool, the
   static response to a tip force. The affine pieces are projected onto it (n ≈ 110).
2. **Compression** (proper orthogonal decomposition): the component model is solved at
   all 128 corners of the search space and at 192 Latin-hypercube points; per body, the
   left singular vectors of the snapshots (modes 1–6, real and imaginary parts, and the
   tip response) carry the basis, r ≈ 45–65 in all. The rigid-body motions are kept
   exactly. The converged Ritz blocks at the training points are stored as start blocks.
3. **Per candidate**: one complex LU of K̃(p) − σM(p) (σ = −(2π·200 Hz)², below every
   eigenvalue); block inverse iteration (6 vectors) with the rigid-body motions
   deflated, from the stored block of the nearest training point; a complex
   Rayleigh–Ritz step with the unconjugated transpose on the orthonormalised block; an
   error estimate of λ1–λ3 (rᵀ(K̃ − σM)⁻¹r) that adds iterations until they have
   converged (a dense solve of the reduced model after 8). The eigenvalues are genuinely
   complex (no first-order loss estimate: the contact loss factor 10·eta reaches 1).
   The receptance is the modal sum over the exact rigid-body pair and the Ritz modes
   plus the static residual of all other modes at σ.
4. **Per GA generation** (:meth:`FastEvaluator.evaluate_many`): the same iteration, test
   and tolerances on stacks of 24 candidates (stacked products, QR and Ritz
   eigenproblems; one LU each), 1.3–1.6× the evaluations per CPU-second of one call
   per candidate; a candidate still unconverged after ``max_iterations`` is finished by
   the single path.
"""

from __future__ import annotations

import functools
import itertools
from dataclasses import dataclass

import numpy as np
import scipy.linalg as sla
from numpy.polynomial import legendre
from scipy.linalg.lapack import zgeqrf, zgetrf, zgetrs, zungqr

from taptune.io.assembly import Assembly
from taptune.model.fe import FEModel, build_model
from taptune.model.modes import SIGMA
from taptune.model.options import ModelOptions
from taptune.model.params import ETA_REFERENCE_MM, P_LOWER, P_UPPER

# The inverse iteration shifts by the full model's SIGMA (below the rigid-body pair, so
# K̃ − σM is regular although the model is free-free).
TWO_PI = 2 * np.pi
# Affine pieces in the order of the coefficient vector of stiffness_coefficients.
_K_PIECES = ("K_tool", "K_holder", "T0", "T1", "R0", "R1")


@dataclass(frozen=True)
class ReductionOptions:
    """How the reduced model is built and solved (docs/physics.md §4; the defaults are measured
    to keep f1–f3 and ζ1 within the tolerances below).

    Parameters
    ----------
    body_modes : int
        Free-free modes per body in the component basis (the rigid pair included).
    legendre_terms : int
        Legendre profiles P0 … P(n−1) of the contact line loads (force and moment).
    n_lhs : int
        Latin-hypercube training points (the 128 corners are always added).
    seed : int
        Seed of the Latin hypercube (the build is deterministic).
    pod_tolerance : float
        Singular values below this fraction of the largest (per body) are dropped.
    block : int
        Elastic vectors iterated per candidate.
    tol : float
        Estimated relative error of the eigenvalues λ1–λ3 at which the iteration stops
        (f errs by half of it).
    tol_damping : float
        Estimated error of λ1 relative to Im λ1 (ζ1 errs by about that fraction).
    min_iterations, max_iterations : int
        Inverse iterations per candidate; beyond the maximum a dense eigen-solution of
        the reduced model is used (rare).
    """

    body_modes: int = 6
    legendre_terms: int = 24
    n_lhs: int = 192
    seed: int = 0
    pod_tolerance: float = 3e-6
    block: int = 6
    tol: float = 1e-6
    tol_damping: float = 1e-4
    min_iterations: int = 2
    max_iterations: int = 8


@dataclass(frozen=True)
class Evaluation:
    """The model at one parameter vector, as the optimiser needs it.

    Attributes
    ----------
    bending_hz : ndarray, shape (3,)
        Bending frequencies f1–f3 [Hz].
    damping_ratio : ndarray, shape (3,)
        ζ1–ζ3.
    tip_receptance : ndarray, complex, shape (m,)
        Tool-tip direct receptance H_tt on the requested frequencies [m/N], rigid-body
        terms included.
    iterations : int
        Inverse iterations spent (0: dense fallback).
    """

    bending_hz: np.ndarray
    damping_ratio: np.ndarray
    tip_receptance: np.ndarray
    iterations: int


@dataclass(frozen=True)
class BatchEvaluation:
    """:class:`Evaluation` for many parameter vectors, stacked along the first axis.

    Attributes
    ----------
    bending_hz, damping_ratio : ndarray, shape (n, 3)
    tip_receptance : ndarray, complex, shape (n, m)
    iterations : ndarray, int, shape (n,)
    """

    bending_hz: np.ndarray
    damping_ratio: np.ndarray
    tip_receptance: np.ndarray
    iterations: np.ndarray

    def __len__(self) -> int:
        return len(self.bending_hz)

    def __getitem__(self, i: int) -> Evaluation:
        return Evaluation(self.bending_hz[i], self.damping_ratio[i], self.tip_receptance[i], int(self.iterations[i]))


def stiffness_coefficients(p) -> list[complex]:
    """Coefficients of (K_tool, K_holder, T0, T1, R0, R1) in K̃(p), six complex numbers.

    p is the optimiser's vector of docs/physics.md §2 (log10 of the four intensities, alpha
    [%], density factor, modulus factor); the contact intensities per mm become line
    stiffnesses per metre (× 1e3), as in :attr:`HolderParams.c_t`. Plain Python
    arithmetic: this runs once per candidate, where numpy's per-call cost would dominate.
    """
    lg_kt, lg_kr, lg_et, lg_er, alpha, _, modulus = (float(v) for v in p[:7])
    c_t = 10.0**lg_kt * 1e3 * complex(1.0, 10.0**lg_et * ETA_REFERENCE_MM)
    c_r = 10.0**lg_kr * 1e3 * complex(1.0, 10.0**lg_er * ETA_REFERENCE_MM)
    a = alpha / 100.0
    return [1.0, modulus, c_t, c_t * a, c_r, c_r * a]


# --------------------------------------------------------------------------- component basis


def contact_zone(fe: FEModel) -> tuple[float, float]:
    """(z_c0, L_h): ends of the contact zone [m], from the model's contact node pairs."""
    z = fe.z_holder[fe.contact_nodes[:, 0]]
    return float(z.min()), float(z.max())


def contact_line_loads(fe: FEModel, n_terms: int) -> np.ndarray:
    """Consistent nodal loads of Legendre-profiled contact line loads, shape (n_dofs, 2·n_terms).

    A smooth tool displacement field (w = P_k(ξ), θ = dw/dz), or rotation field
    (θ = P_k(ξ)), pushed through the unit contact layer T0 (R0) gives the loads that a
    layer of Legendre-profiled line force (moment) puts on both bodies: equal and
    opposite, with each body's own interpolation. The columns span the contact loads
    of every parameter set up to the resolution of the profiles.
    """
    z0, z1 = contact_zone(fe)
    length = z1 - z0
    z = fe.z_tool
    xi = np.clip(2 * (z - z0) / length - 1, -1.0, 1.0)
    n_h = 2 * len(fe.z_holder)
    w_field = np.zeros((fe.n_dofs, n_terms))
    t_field = np.zeros((fe.n_dofs, n_terms))
    for k in range(n_terms):
        c = np.zeros(k + 1)
        c[k] = 1.0
        w_field[n_h::2, k] = legendre.legval(xi, c)
        w_field[n_h + 1 :: 2, k] = legendre.legval(xi, legendre.legder(c)) * 2 / length
        t_field[n_h + 1 :: 2, k] = legendre.legval(xi, c)
    return np.hstack([fe.T0 @ w_field, fe.R0 @ t_field])


def component_basis(fe: FEModel, options: ReductionOptions = ReductionOptions()) -> np.ndarray:
    """Free-interface component basis of the full model, shape (n_dofs, n).

    Per body: its lowest free-free modes and the shifted static responses to the contact
    line loads (and, for the tool, to a tip force). Block diagonal (holder columns, then
    tool columns), Euclidean-orthonormal.
    """
    n_h = 2 * len(fe.z_holder)
    loads = contact_line_loads(fe, options.legendre_terms)
    bodies = [(slice(0, n_h), fe.K_holder, fe.M_holder), (slice(n_h, fe.n_dofs), fe.K_tool, fe.M_tool)]
    columns = []
    for b, (dofs, K, M) in enumerate(bodies):
        # The real part: the body loss factor scales the whole matrix, shapes are real.
        k = K[dofs, dofs].toarray().real
        m = M[dofs, dofs].toarray()
        _, modes = sla.eigh(k, m, subset_by_index=[0, options.body_modes - 1])
        shifted = sla.cho_factor(k - SIGMA * m)
        rhs = loads[dofs]
        if b == 1:
            tip = np.zeros((k.shape[0], 1))
            tip[-2] = 1.0
            rhs = np.hstack([rhs, tip])
        shapes = np.hstack([modes, sla.cho_solve(shifted, rhs)])
        # Equal M-norms before the orthonormalisation, so no shape is lost to scaling.
        shapes /= np.sqrt(np.einsum("ij,ij->j", shapes, m @ shapes))
        u, s, _ = np.linalg.svd(shapes, full_matrices=False)
        columns.append((dofs, u[:, s > 1e-10 * s[0]]))
    basis = np.zeros((fe.n_dofs, sum(u.shape[1] for _, u in columns)))
    col = 0
    for dofs, u in columns:
        basis[dofs, col : col + u.shape[1]] = u
        col += u.shape[1]
    return basis


# --------------------------------------------------------------------------- reduced model


@dataclass(frozen=True, eq=False)
class _Projected:
    """The affine pieces on a basis V: K̃(p) = Σ c_i(p) K_i, M(p) = M_tool + df·M_holder.

    ``k_pieces`` (6, n, n) complex; ``rigid`` (n, 2) the rigid motions t, r in reduced
    coordinates; ``tip`` (n,) the tip DOF's row of V.
    """

    k_pieces: np.ndarray
    m_tool: np.ndarray
    m_holder: np.ndarray
    rigid: np.ndarray
    tip: np.ndarray

    @property
    def n(self) -> int:
        return self.tip.shape[0]

    @classmethod
    def from_model(cls, fe: FEModel, V: np.ndarray) -> "_Projected":
        def project(m):
            return V.T @ (m @ V)

        rigid, *_ = np.linalg.lstsq(V, np.stack(fe.rigid_vectors, axis=1), rcond=None)
        return cls(
            k_pieces=np.stack([project(getattr(fe, name)) for name in _K_PIECES]).astype(complex),
            m_tool=project(fe.M_tool),
            m_holder=project(fe.M_holder),
            rigid=rigid,
            tip=V[fe.tip_dof].copy(),
        )

    def compress(self, Q: np.ndarray, rigid: np.ndarray) -> "_Projected":
        """The same pieces on the sub-basis Q (n, r); ``rigid`` gives t, r in Q coordinates."""
        return _Projected(
            k_pieces=np.einsum("ai,kab,bj->kij", Q, self.k_pieces, Q, optimize=True),
            m_tool=Q.T @ self.m_tool @ Q,
            m_holder=Q.T @ self.m_holder @ Q,
            rigid=rigid,
            tip=Q.T @ self.tip,
        )


@dataclass(frozen=True)
class _Solution:
    """Internal result of one candidate: Ritz pairs and the receptance ingredients."""

    lam: np.ndarray  # (k,) complex Ritz values, ascending Re
    basis: np.ndarray  # (n, k) Y: the Ritz vectors are Y @ coeffs
    coeffs: np.ndarray  # (k, k) normalised so that φᵀMφ = 1
    tip_modal: np.ndarray  # (k,) φ_tip
    rigid_tip: float  # Σ_rigid ψ_tip² (M-orthonormal rigid-body pair)
    residual: complex  # static contribution of all other modes at σ
    static: np.ndarray  # (n,) (K̃ − σM)⁻¹ e_tip
    deflation: np.ndarray  # (n, 2) W with x − R Wᵀx the rigid-body deflation
    iterations: int

    @property
    def vectors(self) -> np.ndarray:
        """Ritz vectors φ, (n, k)."""
        return self.basis @ self.coeffs


class _Solver:
    """Per-candidate modal solution of a projected model (see the module docstring).

    Everything that does not depend on p is prepared here; :meth:`solve` is written for
    few numpy calls, because at this size their overhead, not arithmetic, is the cost.
    """

    def __init__(self, model: _Projected, options: ReductionOptions):
        self.model = model
        self.options = options
        n = model.n
        self.n = n
        self.k_flat = model.k_pieces.reshape(len(_K_PIECES), n * n)
        # K̃ − σM in one product: the pieces of K̃, then −σ·M_tool (coefficient 1, folded
        # into K_tool) and −σ·M_holder (coefficient = density factor).
        shifted = self.k_flat.copy()
        shifted[0] -= SIGMA * model.m_tool.ravel()
        self.a_flat = np.vstack([shifted, -SIGMA * model.m_holder.ravel()])
        # Complex copies: complex @ complex is faster in numpy than real @ complex.
        self.m_tool = model.m_tool.astype(complex)
        self.m_holder = model.m_holder.astype(complex)
        R = model.rigid
        self.rigid = R.astype(complex)
        # M(p) R and Rᵀ M(p) R are affine in the density factor too.
        self.mr_tool = model.m_tool @ R
        self.mr_holder = model.m_holder @ R
        self.g_tool = (R.T @ self.mr_tool).ravel().tolist()
        self.g_holder = (R.T @ self.mr_holder).ravel().tolist()
        self.tip = model.tip.astype(complex)
        self.tip_rigid = (model.tip @ R).tolist()

    def matrices(self, p):
        """(K̃(p), M(p)) of the projected model, both complex (n, n)."""
        K = (np.array(stiffness_coefficients(p)) @ self.k_flat).reshape(self.n, self.n)
        return K, self.m_tool + p[5] * self.m_holder

    def solve(self, p, start: np.ndarray) -> _Solution:
        """Modes of the candidate p by inverse iteration from the start block (n, b)."""
        opt = self.options
        n = self.n
        df = float(p[5])
        coef = stiffness_coefficients(p)
        coef.append(df)
        A = (np.array(coef) @ self.a_flat).reshape(n, n)
        M = self.m_tool + df * self.m_holder
        lu, piv, info = zgetrf(A)
        if info != 0:
            raise np.linalg.LinAlgError(f"K̃ − σM is singular for p = {np.asarray(p)}")
        # Rigid-body deflation X − R (RᵀMR)⁻¹ RᵀM X: inverse iteration at σ < 0 would
        # otherwise amplify any rigid component above every elastic mode. (RᵀMR)⁻¹ is 2×2.
        g00, g01, _, g11 = (t + df * h for t, h in zip(self.g_tool, self.g_holder))
        det = g00 * g11 - g01 * g01
        gram_inv = np.array([[g11, -g01], [-g01, g00]]) / det
        proj = (self.mr_tool + df * self.mr_holder) @ gram_inv
        R = self.rigid
        t0, t1 = self.tip_rigid
        rigid_tip = (g11 * t0 * t0 - 2 * g01 * t0 * t1 + g00 * t1 * t1) / det
        # The first iteration also solves for the static tip response (one LAPACK call).
        b = start.shape[1]
        y, _ = zgetrs(lu, piv, np.column_stack([M @ start, self.tip]))
        X, static = y[:, :b], y[:, b]
        iterations = 0
        while True:
            if iterations:
                X, _ = zgetrs(lu, piv, M @ X)
            X -= R @ (proj.T @ X)
            iterations += 1
            if iterations < opt.min_iterations:
                continue
            # Orthonormal columns keep the Ritz step well conditioned however far the
            # start block was (LAPACK directly: numpy's qr costs 4× more at this size).
            qr, tau, _, _ = zgeqrf(X)
            X, _, _ = zungqr(qr, tau)
            MX = M @ X
            mr = X.T @ MX
            # K̃X = (K̃ − σM)X + σMX
            KX = A @ X + SIGMA * MX
            lam, Z = _eig_small(X.T @ KX, mr)
            Z /= np.sqrt(np.einsum("ij,ij->j", Z, mr @ Z))
            # Error estimate of the Ritz values of modes 1–3: with the residual
            # r = K̃φ − λMφ (φᵀMφ = 1), λ_exact − λ ≈ −Σ_k (φ_kᵀr)² / (λ_k − λ) over the
            # modes outside the block, which rᵀ(K̃ − σM)⁻¹r approximates within a factor
            # of about 2 (λ_k ≫ λ there). Unlike a plain residual norm it stays honest
            # for close mode pairs and for the badly scaled reduced coordinates.
            res = KX @ Z[:, :3] - (MX @ Z[:, :3]) * lam[:3]
            correction, _ = zgetrs(lu, piv, res)
            err = np.abs(np.einsum("ij,ij->j", res, correction))
            if err[0] < opt.tol_damping * abs(lam[0].imag) and np.all(err < opt.tol * np.abs(lam[:3])):
                break
            if iterations >= opt.max_iterations:
                lam, X, Z = self._dense(A, M, proj)
                iterations = 0
                break
            X = X @ Z
        phi_tip = (self.tip @ X) @ Z
        residual = self.tip @ static - rigid_tip / (-SIGMA) - np.sum(phi_tip**2 / (lam - SIGMA))
        return _Solution(lam, X, Z, phi_tip, rigid_tip, residual, static, proj, iterations)

    def solve_many(self, P, starts: np.ndarray):
        """:meth:`solve` for every row of P (B, 7) at once, from the start blocks (B, n, b).

        The same iteration, Ritz step and convergence test, on stacks of candidates: a few
        numpy calls per iteration for the whole batch instead of a few per candidate. One
        stacked solve per iteration serves twice: Y = (K̃ − σM)⁻¹MX is the next inverse
        iteration and gives the error estimate's (K̃ − σM)⁻¹r = XZ + (σ − λ)YZ, since
        K̃ = (K̃ − σM) + σM. A candidate leaves the batch when it has converged.

        Returns
        -------
        lam : ndarray, complex, shape (B, b)
            Ritz values, ascending Re.
        tip_modal : ndarray, complex, shape (B, b)
            φ_tip of the Ritz vectors (φᵀMφ = 1).
        rigid_tip : ndarray, shape (B,)
        residual : ndarray, complex, shape (B,)
        iterations : ndarray, int, shape (B,)
            Inverse iterations spent; −1 where the iteration had not converged after
            ``max_iterations`` (the caller solves those with :meth:`solve`, which falls
            back to the dense solution).
        """
        opt = self.options
        P = np.asarray(P, dtype=float)
        count, n, b = len(P), self.n, starts.shape[2]
        A = (_coefficients_many(P) @ self.a_flat).reshape(count, n, n)
        df = P[:, 5]
        # M(p) is real: applied to a complex block viewed as real numbers, 3× faster.
        M = self.model.m_tool + df[:, None, None] * self.model.m_holder
        g00, g01, _, g11 = np.array(self.g_tool)[:, None] + np.array(self.g_holder)[:, None] * df
        det = g00 * g11 - g01 * g01
        gram_inv = np.stack([g11, -g01, -g01, g00], axis=-1).reshape(-1, 2, 2) / det[:, None, None]
        projT = (gram_inv @ (self.mr_tool.T + df[:, None, None] * self.mr_holder.T)).astype(complex)  # (B, 2, n)
        R = self.rigid
        t0, t1 = self.tip_rigid
        rigid_tip = (g11 * t0 * t0 - 2 * g01 * t0 * t1 + g00 * t1 * t1) / det
        # One LU per candidate (numpy's stacked solve would refactorise at every call).
        factors = []
        for a in A:
            lu, piv, info = zgetrf(a)
            if info != 0:
                raise np.linalg.LinAlgError("K̃ − σM is singular for a candidate of the batch")
            factors.append((lu, piv))
        tip = np.broadcast_to(self.tip[None, :, None], (count, n, 1))
        y = _lu_solve(factors, np.concatenate([_real_times(M, starts), tip], axis=2))
        X, static = np.ascontiguousarray(y[..., :b]), y[..., b]
        X -= R @ (projT @ X)
        for _ in range(1, opt.min_iterations):
            X = _lu_solve(factors, _real_times(M, X))
            X -= R @ (projT @ X)
        lam_out = np.zeros((count, b), dtype=complex)
        tip_out = np.zeros((count, b), dtype=complex)
        iters_out = np.full(count, -1)
        active = np.arange(count)
        iterations = opt.min_iterations
        while True:
            X, _ = np.linalg.qr(X)
            MX = _real_times(M, X)
            Y = _lu_solve(factors, MX)
            Xt = X.transpose(0, 2, 1)
            mr = Xt @ MX
            KX = A @ X + SIGMA * MX
            lam, Z = np.linalg.eig(np.linalg.solve(mr, Xt @ KX))
            order = np.argsort(lam.real, axis=1)
            lam = np.take_along_axis(lam, order, axis=1)
            Z = np.take_along_axis(Z, order[:, None, :], axis=2)
            Z /= np.sqrt(np.einsum("bij,bij->bj", Z, mr @ Z))[:, None, :]
            Z3, l3 = Z[..., :3], lam[:, None, :3]
            res = KX @ Z3 - (MX @ Z3) * l3
            correction = X @ Z3 + (Y @ Z3) * (SIGMA - l3)
            err = np.abs(np.einsum("bij,bij->bj", res, correction))
            done = (err[:, 0] < opt.tol_damping * np.abs(lam[:, 0].imag)) & np.all(
                err < opt.tol * np.abs(lam[:, :3]), axis=1
            )
            where = active[done]
            lam_out[where] = lam[done]
            tip_out[where] = ((self.tip @ X[done])[:, None, :] @ Z[done])[:, 0]
            iters_out[where] = iterations
            if iterations >= opt.max_iterations or done.all():
                break
            keep = ~done
            active = active[keep]
            A, M, projT = A[keep], M[keep], projT[keep]
            factors = [f for f, k in zip(factors, keep) if k]
            X = Y[keep] @ Z[keep]
            X -= R @ (projT @ X)
            iterations += 1
        residual = static @ self.tip - rigid_tip / (-SIGMA) - np.sum(tip_out**2 / (lam_out - SIGMA), axis=1)
        return lam_out, tip_out, rigid_tip, residual, iters_out

    def _dense(self, A, M, proj):
        """All elastic modes of the reduced model (slow path for a non-converging candidate)."""
        lam, vec = sla.eig(A, M)
        lam = lam + SIGMA
        order = np.argsort(lam.real)
        lam, vec = lam[order][2:], vec[:, order][:, 2:]
        vec -= self.rigid @ (proj.T @ vec)
        vec /= np.sqrt(np.einsum("ij,ij->j", vec, M @ vec))
        return lam, vec, np.eye(len(lam), dtype=complex)


def _modal_sum(lam: np.ndarray, a: np.ndarray, w2: np.ndarray) -> np.ndarray:
    """Σ_k a_k / (λ_k − ω²): ``(1 / (lam − w2)) @ a`` with lam and w2 broadcast to (…, m, k).

    1/d as conj(d)/|d|²: numpy's complex division (overflow-safe) costs three times more,
    and |d| is far from overflow here.
    """
    d = lam - w2
    np.conjugate(d, out=d)
    d *= 1.0 / (d.real**2 + d.imag**2)
    return d @ a


def _real_times(M: np.ndarray, X: np.ndarray) -> np.ndarray:
    """M @ X for real stacked M (B, n, n) and complex X (B, n, k), by real products."""
    return (M @ np.ascontiguousarray(X).view(float)).view(complex)


def _lu_solve(factors, rhs: np.ndarray) -> np.ndarray:
    """(K̃ − σM)⁻¹ rhs per candidate, from the LU factors of each: rhs (B, n, k)."""
    out = np.empty_like(rhs)
    for i, (lu, piv) in enumerate(factors):
        out[i], _ = zgetrs(lu, piv, rhs[i])
    return out


def _coefficients_many(P: np.ndarray) -> np.ndarray:
    """:func:`stiffness_coefficients` for every row of P (B, 7), then the density factor: (B, 7) complex."""
    c_t = 10.0 ** P[:, 0] * 1e3 * (1.0 + 1j * (10.0 ** P[:, 2] * ETA_REFERENCE_MM))
    c_r = 10.0 ** P[:, 1] * 1e3 * (1.0 + 1j * (10.0 ** P[:, 3] * ETA_REFERENCE_MM))
    a = P[:, 4] / 100.0
    return np.stack([np.ones(len(P)), P[:, 6], c_t, c_t * a, c_r, c_r * a, P[:, 5]], axis=1)


def _eig_small(A, B):
    """Eigenpairs of the small complex pencil (A, B), ascending Re λ."""
    alpha, beta, _, vr, _, info = sla.lapack.zggev(A, B, compute_vl=0, compute_vr=1)
    if info != 0:
        raise np.linalg.LinAlgError("the Rayleigh–Ritz eigenproblem failed")
    lam = alpha / beta
    order = np.argsort(lam.real)
    return lam[order], vr[:, order]


# --------------------------------------------------------------------------- training


def training_points(n_lhs: int, seed: int) -> np.ndarray:
    """Unit-cube training points: the 128 corners, then a seeded Latin hypercube, (128 + n_lhs, 7)."""
    corners = np.array(list(itertools.product((0.0, 1.0), repeat=7)))
    rng = np.random.default_rng(seed)
    strata = np.stack([rng.permutation(n_lhs) for _ in range(7)], axis=1)
    lhs = (strata + rng.random((n_lhs, 7))) / n_lhs
    return np.vstack([corners, lhs])


# Distances for the nearest training point weight the parameters by how much they move
# the mode shapes: the two stiffness intensities most, the factors least.
_SHAPE_WEIGHTS = np.array([1.0, 1.0, 0.5, 0.5, 0.3, 0.1, 0.1])


# Candidates solved together by FastEvaluator.evaluate_many: 24 candidates' LU factors
# (1.1 MB) stay in cache; on GA generations 12–48 measured alike, 8 slower.
_CHUNK = 24


class FastEvaluator:
    """Reduced model of one assembly for the optimiser (see the module docstring).

    Parameters
    ----------
    assembly : Assembly
        Validated geometry.
    options : ModelOptions
        Mesh options of the full model it reproduces.
    reduction : ReductionOptions
        Basis and solver settings.

    Examples
    --------
    >>> ev = FastEvaluator(assembly)                               # doctest: +SKIP
    >>> e = ev.evaluate(to_p(NOMINAL), 4800 + np.arange(-100, 101.0))  # doctest: +SKIP
    >>> e.bending_hz, e.damping_ratio, abs(e.tip_receptance).max()    # doctest: +SKIP
    """

    def __init__(
        self,
        assembly: Assembly,
        options: ModelOptions = ModelOptions(),
        reduction: ReductionOptions = ReductionOptions(),
    ):
        self._setup(build_model(assembly, options), reduction)

    @classmethod
    def from_model(cls, fe: FEModel, reduction: ReductionOptions = ReductionOptions()) -> "FastEvaluator":
        """Evaluator for an already built full model."""
        self = cls.__new__(cls)
        self._setup(fe, reduction)
        return self

    def _setup(self, fe: FEModel, reduction: ReductionOptions) -> None:
        self.fe = fe
        self.reduction = reduction
        V = component_basis(fe, reduction)
        component = _Projected.from_model(fe, V)
        train_u = training_points(reduction.n_lhs, reduction.seed)
        train_p = P_LOWER + train_u * (P_UPPER - P_LOWER)
        snapshots = _train(component, train_u, train_p, reduction)
        Q, rigid = _pod_basis(component, snapshots, len(fe.z_holder) * 2, V, reduction.pod_tolerance)
        # Start blocks in the compressed coordinates (Q is orthonormal). The nearest
        # training point minimises the weighted distance ½‖k − q‖² = ½‖k‖² − k·q + ½‖q‖²
        # with q = W (p − p_lo)/(p_hi − p_lo): affine in p, so one product per candidate.
        keys = train_u * _SHAPE_WEIGHTS
        to_key = _SHAPE_WEIGHTS / (P_UPPER - P_LOWER)
        self._finish(
            component.compress(Q, rigid),
            component.n,
            key_matrix=keys * to_key,
            key_offset=0.5 * np.einsum("ij,ij->i", keys, keys) + keys @ (to_key * P_LOWER),
            starts=np.einsum("ai,tab->tib", Q, snapshots.blocks, optimize=True),
        )

    def _finish(self, model: _Projected, component_size: int, key_matrix, key_offset, starts) -> None:
        self.model = model
        self.component_size = int(component_size)
        self._solver = _Solver(model, self.reduction)
        self._key_matrix, self._key_offset, self._starts = key_matrix, key_offset, starts

    def state(self) -> dict[str, np.ndarray]:
        """The arrays that, with its full model, make this evaluator again (:meth:`from_state`)."""
        m = self.model
        return {"k_pieces": m.k_pieces, "m_tool": m.m_tool, "m_holder": m.m_holder, "rigid": m.rigid,
                "tip": m.tip, "component_size": np.array(self.component_size), "key_matrix": self._key_matrix,
                "key_offset": self._key_offset, "starts": self._starts}

    @classmethod
    def from_state(cls, fe: FEModel, reduction: ReductionOptions, state: dict) -> "FastEvaluator":
        """The evaluator of :meth:`state`, identical to the one that gave it.

        Raises ValueError when the arrays do not fit together (a corrupt state).
        """
        model = _Projected(*(np.asarray(state[k]) for k in ("k_pieces", "m_tool", "m_holder", "rigid", "tip")))
        n, (t, n_s, b) = model.n, np.shape(state["starts"])
        if (model.k_pieces.shape != (len(_K_PIECES), n, n) or model.m_tool.shape != (n, n)
                or model.m_holder.shape != (n, n) or model.rigid.shape != (n, 2) or n_s != n
                or b != reduction.block or np.shape(state["key_matrix"]) != (t, 7)
                or np.shape(state["key_offset"]) != (t,)):
            raise ValueError("reduced-model arrays of inconsistent shapes")
        self = cls.__new__(cls)
        self.fe, self.reduction = fe, reduction
        self._finish(model, int(state["component_size"]), np.asarray(state["key_matrix"]),
                     np.asarray(state["key_offset"]), np.asarray(state["starts"]))
        return self

    @property
    def size(self) -> int:
        """Dimension of the reduced model."""
        return self.model.n

    def _nearest(self, p) -> int:
        """Index of the training point nearest p (weighted unit-cube distance)."""
        return int(np.argmin(self._key_offset - self._key_matrix @ p))

    def evaluate(self, p, window_hz) -> Evaluation:
        """f1–f3, ζ1–ζ3 and the tip receptance on ``window_hz`` at parameter vector p.

        Parameters
        ----------
        p : array_like, shape (7,)
            Parameter vector of docs/physics.md §2 (see :func:`taptune.model.params.to_p`).
        window_hz : array_like, shape (m,)
            Frequencies [Hz], > 0.

        Returns
        -------
        Evaluation
        """
        p = np.asarray(p, dtype=float)
        i = self._nearest(p)
        sol = self._solver.solve(p, self._starts[i])
        w2 = (TWO_PI * np.asarray(window_hz, dtype=float)) ** 2
        h = sol.rigid_tip / (-w2) + _modal_sum(sol.lam[None, :], sol.tip_modal**2, w2[:, None]) + sol.residual
        lam = sol.lam[:3]
        return Evaluation(
            bending_hz=np.sqrt(lam.real) / TWO_PI,
            damping_ratio=lam.imag / lam.real / 2,
            tip_receptance=h,
            iterations=sol.iterations,
        )

    def evaluate_many(self, P, window_hz) -> BatchEvaluation:
        """:meth:`evaluate` for every row of P (B, 7) on one frequency window.

        The candidates are solved together (:meth:`_Solver.solve_many`: stacked solves,
        QR and small eigenproblems); the few that have not converged after
        ``max_iterations``, or a batch with a singular K̃ − σM, are solved one at a time
        by :meth:`evaluate`. The results equal :meth:`evaluate`'s within the solver's
        tolerances.
        """
        P = np.atleast_2d(np.asarray(P, dtype=float))
        w2 = (TWO_PI * np.asarray(window_hz, dtype=float)) ** 2
        starts = self._starts[np.argmin(self._key_offset - P @ self._key_matrix.T, axis=1)]
        try:
            chunks = range(0, len(P), _CHUNK)
            parts = [self._solver.solve_many(P[k : k + _CHUNK], starts[k : k + _CHUNK]) for k in chunks]
        except np.linalg.LinAlgError:
            return self._evaluate_each(P, window_hz)
        lam, tip_modal, rigid_tip, residual, iterations = (np.concatenate(x) for x in zip(*parts))
        lam[iterations < 0] = 1.0  # placeholders of the candidates solved one at a time below
        h = (
            rigid_tip[:, None] / (-w2)
            + _modal_sum(lam[:, None, :], (tip_modal**2)[:, :, None], w2[None, :, None])[..., 0]
            + residual[:, None]
        )
        lam = lam[:, :3]
        bending = np.sqrt(lam.real) / TWO_PI
        damping = lam.imag / lam.real / 2
        for i in np.flatnonzero(iterations < 0):
            e = self.evaluate(P[i], window_hz)
            bending[i], damping[i], h[i], iterations[i] = e.bending_hz, e.damping_ratio, e.tip_receptance, e.iterations
        return BatchEvaluation(bending, damping, h, iterations)

    def _evaluate_each(self, P, window_hz) -> BatchEvaluation:
        """:meth:`evaluate_many` one candidate at a time."""
        out = [self.evaluate(p, window_hz) for p in P]
        return BatchEvaluation(
            bending_hz=np.array([e.bending_hz for e in out]),
            damping_ratio=np.array([e.damping_ratio for e in out]),
            tip_receptance=np.array([e.tip_receptance for e in out]),
            iterations=np.array([e.iterations for e in out]),
        )


@functools.lru_cache(maxsize=4)
def cached_evaluator(assembly: Assembly, options: ModelOptions = ModelOptions()) -> FastEvaluator:
    """The :class:`FastEvaluator` of an assembly, built once per process for the last few.

    Its build (0.3–0.45 s CPU, mostly the training solutions) is a third of an
    identification, and the user taps the same assembly again and again: in the app, and
    with one ``taptune identify`` per tap, where a fresh process finds it in the disk
    cache (:mod:`taptune.io.cache`; ≈ 20 ms with the full model it is keyed by). The
    evaluator is immutable, so sharing it between identifications and threads is safe.
    """
    from taptune.io.cache import load_arrays, save_arrays

    fe = build_model(assembly, options)
    reduction = ReductionOptions()
    key = _cache_key(fe, reduction)
    state = load_arrays("reduced", key)
    if state is not None:
        try:
            return FastEvaluator.from_state(fe, reduction, state)
        except (KeyError, ValueError, TypeError):
            pass  # a corrupt entry: rebuilt and saved over below
    evaluator = FastEvaluator.from_model(fe, reduction)
    save_arrays("reduced", key, evaluator.state())
    return evaluator


def _cache_key(fe: FEModel, reduction: ReductionOptions) -> str:
    """Hash of all a reduced model is computed from: the full model, the reduction
    options, the search space, the shift, this module's code and the numerical libraries
    (their random numbers and round-off)."""
    from pathlib import Path

    import scipy

    from taptune.io.cache import digest

    parts = [np.__version__, scipy.__version__, Path(__file__).read_bytes(), reduction, SIGMA, P_LOWER, P_UPPER,
             ETA_REFERENCE_MM, fe.options,
             fe.rigid_contact, fe.z_holder, fe.z_tool, fe.contact_nodes, fe.tip_dof, *fe.rigid_vectors]
    for name in (*_K_PIECES, "M_tool", "M_holder"):
        m = getattr(fe, name).tocsr()
        parts += [m.shape, m.data, m.indices, m.indptr]
    return digest(*parts)


@dataclass(frozen=True)
class _Snapshots:
    """Training solutions in component coordinates: ``blocks`` (t, n, block) Ritz
    vectors of modes 1 … block; ``static`` (t, n) the elastic tip response at σ."""

    blocks: np.ndarray
    static: np.ndarray


def _train(model: _Projected, train_u, train_p, options: ReductionOptions) -> _Snapshots:
    """Solve the component model at every training point.

    Points are visited outwards from the centre of the search space, each starting from
    the nearest point already solved, so every inverse iteration starts close.
    """
    solver = _Solver(model, options)
    centre = P_LOWER + 0.5 * (P_UPPER - P_LOWER)
    K, M = solver.matrices(centre)
    _, modes = sla.eigh(K.real, M.real, subset_by_index=[2, 1 + options.block])
    keys = train_u * _SHAPE_WEIGHTS
    order = np.argsort(np.linalg.norm(keys - 0.5 * _SHAPE_WEIGHTS, axis=1))
    n, b, t = model.n, options.block, len(train_p)
    blocks = np.zeros((t, n, b), dtype=complex)
    static = np.zeros((t, n), dtype=complex)
    done = np.zeros(t, dtype=bool)
    for i in order:
        if done.any():
            solved = np.flatnonzero(done)
            nearest = solved[np.argmin(np.linalg.norm(keys[solved] - keys[i], axis=1))]
            start = blocks[nearest]
        else:
            start = modes
        sol = solver.solve(train_p[i], start)
        blocks[i] = sol.vectors[:, :b]
        static[i] = sol.static - solver.rigid @ (sol.deflation.T @ sol.static)
        done[i] = True
    return _Snapshots(blocks, static)


def _pod_basis(model: _Projected, snaps: _Snapshots, n_holder_dofs: int, V, tolerance: float):
    """Per-body POD of the training solutions plus the exact rigid motions.

    Returns Q (n, r), orthonormal, and the rigid motions t, r in Q coordinates (r, 2).
    """
    # Component coordinates of each body: the first columns of V belong to the holder.
    n_hcols = int(np.count_nonzero(np.any(V[:n_holder_dofs] != 0, axis=0)))
    data = np.concatenate([snaps.blocks.transpose(1, 0, 2).reshape(model.n, -1), snaps.static.T], axis=1)
    data = np.concatenate([data.real, data.imag], axis=1)
    data /= np.maximum(np.linalg.norm(data, axis=0), 1e-300)
    columns = []
    for rows in (slice(0, n_hcols), slice(n_hcols, model.n)):
        part = data[rows]
        rig = model.rigid[rows]
        rig_q, _ = np.linalg.qr(rig)
        # The rigid motions are kept exactly; POD describes what is left.
        part = part - rig_q @ (rig_q.T @ part)
        u, s, _ = np.linalg.svd(part, full_matrices=False)
        keep = u[:, s > tolerance * s[0]]
        block = np.zeros((model.n, rig_q.shape[1] + keep.shape[1]))
        block[rows] = np.hstack([rig_q, keep])
        columns.append(block)
    Q = np.hstack(columns)
    return Q, Q.T @ model.rigid
