"""Receptance blocks of the cut holder model at the tool tip and the coupling node (docs/machine.md).

Point 1 is the tool tip, point 2 the coupling node (z = 0 of the cut model). Each block
``H_ij`` has shape (n, 2, 2): ``[[w_i/f_j, w_i/m_j], [θ_i/f_j, θ_i/m_j]]`` [m/N, 1/N;
1/N, rad/(N·m)].

Two routes, which agree to ~1e-7 (tests/machine/test_blocks.py):

* ``"modal"`` (default): the exact rigid-body pair, every elastic mode below
  ``MODE_CUTOFF`` × the highest requested frequency (shift-invert Arnoldi on the banded
  factorisation of K̃ − σM) and the residual of all higher modes to second order in
  ω² about σ. One eigen-solution serves any number of frequencies: ≈ 0.1 CPU-s for a
  380-DOF model, then microseconds per frequency.
* ``"direct"``: one banded LU of K̃ − ω²M per frequency (the reference), exact but ≈ 50×
  slower on 5,000 frequencies (benchmarks/bench_machine.py).

Signatures::

    point_receptance(fe, params, dofs, freq_hz, method="modal") -> ndarray (n, m, m)
    receptance_blocks(fe, params, freq_hz, method="modal") -> ReceptanceBlocks
    direct_receptance(fe, params, dofs, freq_hz, extra_stiffness=None, extra_dofs=None) -> ndarray (n, m, m)
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from taptune.errors import InputError
from taptune.model.fe import FEModel
from taptune.model.eigen import TWO_PI, BandedLU, rigid_body_modes
from taptune.model.eigen import elastic_solution as _elastic  # renamed on main (was modes._elastic)
from taptune.model.params import HolderParams

#: Elastic modes up to this multiple of the highest requested frequency enter the modal
#: sum exactly; the rest enter through the second-order residual (error ∝ (f/f_cut)⁶).
MODE_CUTOFF = 3.0
METHODS = ("modal", "direct")


@dataclass(frozen=True)
class ReceptanceBlocks:
    """H11, H12, H21, H22 of a free-free substructure on a frequency grid.

    Attributes
    ----------
    freq_hz : ndarray, shape (n,)
        Frequencies [Hz].
    h : ndarray, complex, shape (n, 4, 4)
        Receptance between [w1, θ1, w2, θ2] (point 1 = tool tip, point 2 = coupling node).
    """

    freq_hz: np.ndarray = field(repr=False)
    h: np.ndarray = field(repr=False)

    @property
    def h11(self) -> np.ndarray:
        return self.h[:, :2, :2]

    @property
    def h12(self) -> np.ndarray:
        return self.h[:, :2, 2:]

    @property
    def h21(self) -> np.ndarray:
        return self.h[:, 2:, :2]

    @property
    def h22(self) -> np.ndarray:
        return self.h[:, 2:, 2:]


def _omega2(freq_hz) -> np.ndarray:
    f = np.atleast_1d(np.asarray(freq_hz, dtype=float))
    if f.size == 0 or np.any(~np.isfinite(f)) or np.any(f <= 0):
        raise InputError("the frequency grid must hold finite frequencies > 0 Hz (a free-free receptance is "
                         "undefined at 0 Hz)")
    return (TWO_PI * f) ** 2


def _modes_below(fe: FEModel, params: HolderParams, f_cut_hz: float):
    """(eigen, λ, φ, M) with every elastic mode below ``f_cut_hz`` (doubling the count asked)."""
    n_el = fe.n_dofs - 2
    k = 16
    while True:
        k = min(k, n_el)
        eig, lam, vec, M = _elastic(fe, params, None if k >= n_el - 2 else k)
        if len(lam) >= n_el - 2 or np.sqrt(lam[-1].real) / TWO_PI >= f_cut_hz:
            return eig, lam, vec, M
        k *= 2


def point_receptance(fe: FEModel, params: HolderParams, dofs, freq_hz, method: str = "modal",
                     mode_cutoff: float = MODE_CUTOFF) -> np.ndarray:
    """Receptance matrix between the given DOFs of the free-free model, shape (n, m, m).

    Parameters
    ----------
    fe : FEModel
    params : HolderParams
    dofs : sequence of int
        Global DOFs (w and θ of the points of interest).
    freq_hz : array_like, shape (n,)
        Frequencies [Hz], > 0.
    method : {"modal", "direct"}
        See the module docstring.
    mode_cutoff : float
        Modal route: modes below ``mode_cutoff`` × max(freq_hz) are summed exactly.
    """
    dofs = np.asarray(dofs, dtype=int)
    w2 = _omega2(freq_hz)
    if method == "direct":
        return direct_receptance(fe, params, dofs, freq_hz)
    if method != "modal":
        raise ValueError(f"unknown receptance method {method!r}; use one of {METHODS}")
    eig, lam, vec, M = _modes_below(fe, params, mode_cutoff * np.sqrt(w2.max()) / TWO_PI)
    psi = rigid_body_modes(fe, M)
    # Rigid pair: −ψψᵀ/ω²; elastic modes: φφᵀ/(λ − ω²) (unconjugated, docs/physics.md §3).
    pr, pe = psi[dofs], vec[dofs]
    h = -np.einsum("iq,jq->ij", pr, pr)[None] / w2[:, None, None]
    h = h + np.einsum("ir,jr,fr->fij", pe, pe, 1.0 / (lam[None, :] - w2[:, None]), optimize=True)
    if len(lam) < fe.n_dofs - 2:
        r0, r1, r2 = _residual(eig, np.concatenate([psi, vec], axis=1), M, dofs)
        d = (w2 - eig.sigma)[:, None, None]
        h = h + r0[None] + d * r1[None] + d * d * r2[None]
    return h


def _residual(eig, basis, M, dofs):
    """Omitted modes Σ φφᵀ/(λ−σ)^(k+1), k = 0, 1, 2, at ``dofs`` (each (m, m)).

    A unit load with the kept modes removed (unconjugated M-projection) gives
    x = Σ_omitted φ φ_j/(λ − σ) straight from the factorised K̃ − σM, without the
    cancellation against the large rigid-body terms at σ; further solves with M x
    raise the power of 1/(λ − σ).
    """
    n = basis.shape[0]
    e = np.zeros((n, len(dofs)), dtype=complex)
    e[dofs, np.arange(len(dofs))] = 1.0
    e -= (M @ basis) @ basis[dofs].T
    x = eig.lu.solve(e)
    mx = M @ x
    y = eig.lu.solve(mx)
    return x[dofs], x.T @ mx, y.T @ mx


def direct_receptance(fe: FEModel, params: HolderParams, dofs, freq_hz, extra_stiffness=None,
                      extra_dofs=None) -> np.ndarray:
    """Receptances by one banded LU of K̃ − ω²M (+ extra stiffness) per frequency, shape (n, m, m).

    Parameters
    ----------
    fe, params, dofs, freq_hz
        As in :func:`point_receptance`.
    extra_stiffness : ndarray, complex, shape (n, k, k) or (k, k), optional
        A (frequency-dependent) stiffness added at ``extra_dofs`` [N/m, N, N·m], e.g. the
        spindle's dynamic stiffness H_S⁻¹ at the coupling node.
    extra_dofs : sequence of int, optional
        DOFs of ``extra_stiffness`` (they must be coupled in the model's pattern, as the
        w and θ of one node are).
    """
    dofs = np.asarray(dofs, dtype=int)
    w2 = _omega2(freq_hz)
    kv, mv = fe.stiffness_values(params), fe.mass_values(params)
    rhs = np.zeros((fe.n_dofs, len(dofs)), dtype=complex)
    rhs[dofs, np.arange(len(dofs))] = 1.0
    add = None
    if extra_stiffness is not None:
        extra = np.asarray(extra_stiffness, dtype=complex)
        extra = np.broadcast_to(extra, (len(w2),) + extra.shape[-2:])
        pos = _pattern_positions(fe, np.asarray(extra_dofs, dtype=int))
    out = np.empty((len(w2), len(dofs), len(dofs)), dtype=complex)
    for n, w in enumerate(w2):
        k = kv
        if extra_stiffness is not None:
            add = np.zeros_like(kv)
            np.add.at(add, pos.ravel(), extra[n].ravel())
            k = kv + add
        out[n] = BandedLU(fe, k, mv, w).solve(rhs)[dofs]
    return out


def _pattern_positions(fe: FEModel, dofs) -> np.ndarray:
    """Index of entry (dofs[a], dofs[b]) in ``fe.pattern``'s values, shape (k, k)."""
    p = fe.pattern
    keys = p.rows.astype(np.int64) * p.n + p.cols
    want = dofs[:, None].astype(np.int64) * p.n + dofs[None, :]
    pos = np.searchsorted(keys, want)
    if np.any(pos >= len(keys)) or np.any(keys[np.minimum(pos, len(keys) - 1)] != want):
        raise ValueError("extra stiffness on DOFs that the model does not couple")
    return pos


def receptance_blocks(fe: FEModel, params: HolderParams, freq_hz, method: str = "modal") -> ReceptanceBlocks:
    """H11 (tool tip), H12, H21, H22 (coupling node = holder node 0) of a cut model.

    Parameters
    ----------
    fe : FEModel
        Model of the cut assembly (:func:`taptune.machine.plane.cut_assembly`): its first
        holder node lies on the coupling plane.
    params : HolderParams
    freq_hz : array_like, shape (n,)
        Frequencies [Hz], > 0.
    method : {"modal", "direct"}
    """
    dofs = [fe.tip_dof, fe.tip_dof + 1, 0, 1]
    f = np.atleast_1d(np.asarray(freq_hz, dtype=float))
    return ReceptanceBlocks(freq_hz=f, h=point_receptance(fe, params, dofs, f, method))
