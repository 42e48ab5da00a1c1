"""Receptance coupling (Schmitz & Smith, *Machining Dynamics*): identities and an independent route.

The reference assembly of docs/assembly-format.md (HSK-A63: coupling plane 32 mm from the back)
with holder A's parameters, cut at the plane. The checks compare the RCSA formula on
the modal receptance blocks against direct sparse solves of the cut model with the
machine side added as stiffness at the coupling node.
"""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from taptune.io.assembly import assembly_from_toml
from taptune.io.machine import SpindleReceptance
from taptune.machine import couple, coupled_model, cut_assembly, receptance_blocks, toolpoint_frf
from taptune.machine.blocks import direct_receptance
from taptune.machine.lumped import lumped_from_layer
from taptune.model.fe import build_model
from taptune.model.params import HolderParams
from tests.conftest import REFERENCE_TOML
from tests.machine.cases import lumped_spindle

HOLDER_A = HolderParams(k_tt=1.90e9, k_rr=9.37e3, eta_tt=1.98e-3, eta_rr=8.20e-3, alpha=-10.0,
                        density_factor=7478 / 7800, modulus_factor=1.0)
FREQ = np.linspace(250.0, 9000.0, 60)


@pytest.fixture(scope="module")
def cut():
    """(assembly, cut model, modal blocks, direct blocks)."""
    asm = assembly_from_toml(REFERENCE_TOML, "ref.toml")
    fe = build_model(cut_assembly(asm))
    return asm, fe, receptance_blocks(fe, HOLDER_A, FREQ), receptance_blocks(fe, HOLDER_A, FREQ, method="direct")


def sparse_tip(fe, freq_hz, add=None, drop=()):
    """Tip w/f by scipy's sparse LU of K̃ − ω²M (+ add), with DOFs ``drop`` clamped; shape (n,)."""
    K, M = fe.matrices(HOLDER_A)
    keep = np.setdiff1d(np.arange(fe.n_dofs), drop)
    tip = int(np.flatnonzero(keep == fe.tip_dof)[0])
    out = []
    for n, f in enumerate(freq_hz):
        A = (K - (2 * np.pi * f) ** 2 * M).tolil()
        if add is not None:
            a = add[n] if add.ndim == 3 else add
            for i in range(2):
                for j in range(2):
                    A[i, j] += a[i, j]
        A = sp.csc_matrix(A.tocsc()[keep][:, keep])
        e = np.zeros(len(keep), dtype=complex)
        e[tip] = 1
        out.append(spla.splu(A).solve(e)[tip])
    return np.array(out)


def test_modal_and_direct_blocks_agree(cut):
    """The two routes of taptune.machine.blocks: all modes below 3 f_max + 2nd-order residual vs banded LU."""
    _, fe, b, direct = cut
    scale = np.abs(direct.h).max(axis=0)
    assert np.max(np.abs(b.h - direct.h) / scale) < 1e-7
    # Reciprocity: H12 = H21ᵀ.
    assert np.allclose(b.h12, np.swapaxes(b.h21, 1, 2), rtol=1e-9, atol=1e-9 * np.abs(b.h12).max())


# Pointwise relative tolerance per block route: the direct blocks are exact to round-off;
# the modal route's floor (eigenvector accuracy, residual) is ~3e-8 at antiresonances.
ROUTES = pytest.mark.parametrize("route, tol", [(3, 1e-8), (2, 1e-7)], ids=["direct", "modal"])


@ROUTES
def test_rigid_spindle_equals_the_model_clamped_at_the_coupling_node(cut, route, tol):
    """RCSA identity: H_S → 0 gives the clamped model (direct sparse solve, DOFs removed) to 1e-8."""
    fe, b = cut[1], cut[route]
    g = couple(b.h11, b.h12, b.h21, b.h22, np.zeros_like(b.h22))[:, 0, 0]
    ref = sparse_tip(fe, FREQ, drop=(0, 1))
    assert np.max(np.abs(g - ref) / np.abs(ref)) < tol


@ROUTES
def test_spring_spindle_equals_grounded_springs(cut, route, tol):
    """RCSA identity: H_S = diag(1/k, 1/kθ) gives grounded springs at the node (direct FE) to 1e-8."""
    fe, b = cut[1], cut[route]
    k, kt = 5.0e7, 2.0e5
    hs = np.broadcast_to(np.diag([1 / k, 1 / kt]).astype(complex), b.h22.shape)
    g = couple(b.h11, b.h12, b.h21, b.h22, hs)[:, 0, 0]
    ref = sparse_tip(fe, FREQ, add=np.diag([k, kt]))
    assert np.max(np.abs(g - ref) / np.abs(ref)) < tol


@ROUTES
def test_rcsa_formula_equals_a_direct_solve_with_the_spindle_dynamic_stiffness(cut, route, tol):
    """Two routes: G11 by RCSA vs the cut model with H_S⁻¹ added at the coupling node, 1e-8."""
    fe, b = cut[1], cut[route]
    hs = lumped_spindle(FREQ)
    g = couple(b.h11, b.h12, b.h21, b.h22, hs)[:, 0, 0]
    ref = sparse_tip(fe, FREQ, add=np.linalg.inv(hs))
    assert np.max(np.abs(g - ref) / np.abs(ref)) < tol
    banded = direct_receptance(fe, HOLDER_A, [fe.tip_dof], FREQ, np.linalg.inv(hs), [0, 1])[:, 0, 0]
    assert np.max(np.abs(banded - ref) / np.abs(ref)) < 1e-9


def test_flexible_joint_is_in_series_with_the_spindle(cut):
    """K_j enters as H22 + K_j⁻¹ + H_S; a very stiff joint is the rigid one."""
    b = cut[2]
    hs = lumped_spindle(FREQ)
    kj = np.diag([3e8 * (1 + 0.05j), 1e6 * (1 + 0.05j)])
    with_joint = couple(b.h11, b.h12, b.h21, b.h22, hs, joint=kj)
    series = couple(b.h11, b.h12, b.h21, b.h22, hs + np.linalg.inv(kj))
    assert np.allclose(with_joint, series, rtol=1e-12)
    stiff = couple(b.h11, b.h12, b.h21, b.h22, hs, joint=kj * 1e9)
    rigid = couple(b.h11, b.h12, b.h21, b.h22, hs)
    assert np.max(np.abs(stiff - rigid) / np.abs(rigid)) < 1e-6


def test_toolpoint_frf_contacts_and_json(cut):
    """The rigid contact is stiffer than the identified layer (higher, sharper first peak)."""
    asm = cut[0]
    f = np.arange(500.0, 9000.0, 5.0)
    spindle = SpindleReceptance(f, lumped_spindle(f), "lumped")
    out = {c: toolpoint_frf(asm, HOLDER_A, {"x": spindle, "y": None}, f, contact=c) for c in ("distributed", "rigid", "lumped")}
    peak = {c: f[np.argmax(np.abs(t.xx))] for c, t in out.items()}
    assert peak["rigid"] > peak["distributed"]
    assert np.array_equal(out["distributed"].xx, out["distributed"].yy)  # y = x when not given
    d = out["distributed"].to_dict()
    assert set(d) >= {"stickout", "frequency_hz", "x", "y", "modes"} and d["stickout"] == 53.5
    assert d["modes"][0]["direction"] in ("x", "y") and d["modes"][0]["hz"] == pytest.approx(out["distributed"].modes[0].hz, abs=1e-3)
    assert abs(out["distributed"].modes[0].hz / peak["distributed"] - 1) < 0.003


def test_lumped_joint_integrates_the_layer():
    """k_t = c_t L_c; k_θ adds the translational layer's moment about its stiffness centre."""
    p = HolderParams(k_tt=2e9, k_rr=1e4, eta_tt=1e-3, eta_rr=5e-3, alpha=0.0)
    j = lumped_from_layer(p, 0.04)
    assert j.k_t == pytest.approx(2e9 * 1e3 * 0.04)
    assert j.eta_t == pytest.approx(0.01)
    assert j.k_r == pytest.approx(1e4 * 1e3 * 0.04 + 2e12 * 0.04**3 / 12)


def test_lumped_model_keeps_only_the_front_face_springs(cut):
    asm = cut[0]
    fe, p = coupled_model(asm, HOLDER_A, contact="lumped")
    assert fe.T0.nnz == 4 and fe.R0.nnz == 4 and fe.T1.nnz == 0
    assert p.c_t.real == pytest.approx(lumped_from_layer(HOLDER_A, asm.contact_length).k_t)
