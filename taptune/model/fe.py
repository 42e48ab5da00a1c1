"""The assembled free-free finite-element model (docs/physics.md §1).

:func:`build_model` turns an assembly into an :class:`FEModel` holding the
parameter-free affine pieces

    K = K_tool + modulus_factor·K_holder + c_t (T0 + a T1) + c_r (R0 + a R1)
    M = M_tool + density_factor·M_holder,      a = alpha / 100,

so that any holder parameter set costs two sparse additions (:meth:`FEModel.matrices`).
Global DOF order: holder nodes in increasing z, then tool nodes, [w, θ]
per node; the tool-tip w DOF is the second-to-last.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from functools import cached_property, lru_cache

import numpy as np
import scipy.sparse as sp

from taptune.io.assembly import Assembly
from taptune.model.contact import contact_blocks
from taptune.model.eigen import solve_modes
from taptune.model.mesh import Mesh, build_mesh
from taptune.model.options import ModelOptions
from taptune.model.params import P_LOWER, P_UPPER, HolderParams


def scatter(blocks, dofs, n_dofs) -> sp.csr_matrix:
    """Sum element blocks into a global sparse matrix.

    Parameters
    ----------
    blocks : ndarray, shape (n, k, k)
        Element matrices (real or complex).
    dofs : ndarray, shape (n, k), int
        Global DOF of each block row/column.
    n_dofs : int
        Size of the global matrix.
    """
    rows = np.repeat(dofs[:, :, None], dofs.shape[1], axis=2)
    cols = np.repeat(dofs[:, None, :], dofs.shape[1], axis=1)
    m = sp.coo_matrix((blocks.ravel(), (rows.ravel(), cols.ravel())), shape=(n_dofs, n_dofs))
    return m.tocsr()


def element_dofs(n_elements: int, first_node: int) -> np.ndarray:
    """DOFs [w1, θ1, w2, θ2] of a chain of elements whose first node is ``first_node``, (n, 4)."""
    start = 2 * (first_node + np.arange(n_elements))
    return start[:, None] + np.arange(4)[None, :]


def rigid_body_vectors(z_nodes) -> tuple[np.ndarray, np.ndarray]:
    """Rigid translation t (w = 1, θ = 0) and rotation r (w = z [m], θ = 1), shape (n_dofs,)."""
    z = np.asarray(z_nodes, dtype=float)
    t = np.zeros(2 * len(z))
    r = np.zeros(2 * len(z))
    t[0::2] = 1.0
    r[0::2] = z
    r[1::2] = 1.0
    return t, r


PIECES = ("K_tool", "K_holder", "M_tool", "M_holder", "T0", "T1", "R0", "R1")


@dataclass(frozen=True, eq=False)
class SparsePattern:
    """The union sparsity pattern of all model pieces, with each piece's values on it.

    With every piece on one pattern, K̃(p) and M(p) are a few vector operations on
    ``nnz`` values instead of sparse-matrix additions.

    Attributes
    ----------
    indptr, indices : ndarray, int
        CSR structure (sorted column indices), n × n.
    rows, cols : ndarray, int, shape (nnz,)
        Row and column of every stored entry.
    values : dict of str to ndarray, shape (nnz,)
        Values of each piece (``PIECES``) on the pattern (0 where the piece has none).
    """

    n: int
    indptr: np.ndarray
    indices: np.ndarray
    rows: np.ndarray
    cols: np.ndarray
    values: dict

    def csr(self, data) -> sp.csr_matrix:
        """A CSR matrix with this pattern and the given values, (n, n)."""
        return sp.csr_matrix((data, self.indices, self.indptr), shape=(self.n, self.n))


def common_pattern(pieces: dict, n: int) -> SparsePattern:
    """Union pattern of sparse matrices and their values aligned on it."""
    union = sum(abs(m).tocsr() for m in pieces.values()).tocsr()
    union.sort_indices()
    rows = np.repeat(np.arange(n), np.diff(union.indptr))
    cols = union.indices.astype(np.int64)
    keys = rows.astype(np.int64) * n + cols
    values = {}
    for name, m in pieces.items():
        c = m.tocoo()
        pos = np.searchsorted(keys, c.row.astype(np.int64) * n + c.col)
        v = np.zeros(len(keys), dtype=c.data.dtype)
        np.add.at(v, pos, c.data)
        values[name] = v
    return SparsePattern(n, union.indptr.copy(), union.indices.copy(), rows, cols, values)


def block_pattern(groups, n: int) -> SparsePattern:
    """:func:`common_pattern` of the pieces :func:`scatter` would make, straight from their element blocks.

    One sort of all (row, column) keys gives the union pattern; each piece's values are
    summed onto it by ``bincount`` (at most two blocks meet on an entry, so the sums are
    those of :func:`scatter` to the last bit). Entries that are zero in every piece are
    left out, as the union of :func:`common_pattern` leaves them out. A model is built
    for every moved assembly of a prediction's band: this saves ≈ 2 ms of its ≈ 6 ms.

    Parameters
    ----------
    groups : sequence of (ndarray (m, k) of int, dict of str to ndarray (m, k, k))
        Global DOFs of m elements and the pieces' element blocks on them.
    n : int
        Number of DOFs.
    """
    keys = [(dofs[:, :, None].astype(np.int64) * n + dofs[:, None, :]).ravel() for dofs, _ in groups]
    union, where = np.unique(np.concatenate(keys), return_inverse=True)
    size, values, start = len(union), {}, 0
    for key, (_, pieces) in zip(keys, groups):
        pos = where[start:start + key.size]
        start += key.size
        for name, blocks in pieces.items():
            b = blocks.ravel()
            if np.iscomplexobj(b):
                v = np.empty(size, dtype=complex)
                v.real, v.imag = np.bincount(pos, b.real, size), np.bincount(pos, b.imag, size)
            else:
                v = np.bincount(pos, b, size)
            values[name] = v
    used = np.zeros(size, dtype=bool)
    for v in values.values():
        used |= v != 0
    union = union[used]
    rows, cols = union // n, union % n
    indptr = np.concatenate([[0], np.cumsum(np.bincount(rows, minlength=n))]).astype(np.int32)
    return SparsePattern(n, indptr, cols.astype(np.int32), rows, cols, {k: v[used] for k, v in values.items()})


@dataclass(frozen=True, eq=False)
class BandLayout:
    """DOFs ordered by z give a narrow band (7 where only the contact couples the bodies).

    Attributes
    ----------
    perm : ndarray, int, shape (n,)
        Banded position → global DOF.
    inverse : ndarray, int, shape (n,)
        Global DOF → banded position.
    bandwidth : int
        Number of sub- (= super-) diagonals.
    ab_rows, ab_cols : ndarray, int, shape (nnz,)
        Where each pattern entry goes in LAPACK ``gbtrf`` band storage
        (2·bandwidth + bandwidth + 1 rows).
    """

    perm: np.ndarray
    inverse: np.ndarray
    bandwidth: int
    ab_rows: np.ndarray
    ab_cols: np.ndarray


def band_layout(z_nodes, pattern: SparsePattern) -> BandLayout:
    """Order DOFs by node z (holder before tool at equal z, w before θ) and map the pattern."""
    n = pattern.n
    z = np.repeat(np.asarray(z_nodes, dtype=float), 2)
    perm = np.lexsort((np.arange(n), z))
    inverse = np.empty(n, dtype=int)
    inverse[perm] = np.arange(n)
    i, j = inverse[pattern.rows], inverse[pattern.cols]
    bw = int(np.max(np.abs(i - j)))
    return BandLayout(perm, inverse, bw, 2 * bw + i - j, j)


@dataclass(frozen=True, eq=False)
class FEModel:
    """Parameter-free pieces of the free-free holder–tool model (SI, global DOF order).

    Attributes
    ----------
    K_tool, K_holder : scipy.sparse.csr_matrix, complex, (n_dofs, n_dofs)
        Body stiffness including the material loss factor (1 + i η_mat); K_holder at
        nominal holder modulus.
    M_tool, M_holder : scipy.sparse.csr_matrix, real
        Body mass; M_holder at nominal holder density.
    T0, T1, R0, R1 : scipy.sparse.csr_matrix, real
        Contact layer per unit line stiffness (docs/physics.md §1); T1, R1 carry ξ(z).
    z_holder, z_tool : ndarray
        Node positions of each body [m] (for the rigid-contact variant, the tool nodes
        not tied to the holder).
    n_elements : int
        Beam elements of both bodies.
    contact_nodes : ndarray, shape (n_c + 1, 2), int
        Global node indices (holder, tool) of the coincident contact node pairs; for the
        rigid-contact variant, (holder node, holder node) of the tied nodes.
    options : ModelOptions
        How the model was meshed.
    rigid_contact : bool
        True for the variant with tool and holder DOFs tied in the contact zone.
    """

    K_tool: sp.csr_matrix
    K_holder: sp.csr_matrix
    M_tool: sp.csr_matrix
    M_holder: sp.csr_matrix
    T0: sp.csr_matrix
    T1: sp.csr_matrix
    R0: sp.csr_matrix
    R1: sp.csr_matrix
    z_holder: np.ndarray
    z_tool: np.ndarray
    n_elements: int
    contact_nodes: np.ndarray
    options: ModelOptions = field(default_factory=ModelOptions)
    rigid_contact: bool = False

    @property
    def z_nodes(self) -> np.ndarray:
        """Node positions in global order (holder, then tool) [m]."""
        return np.concatenate([self.z_holder, self.z_tool])

    @property
    def n_dofs(self) -> int:
        return 2 * (len(self.z_holder) + len(self.z_tool))

    @property
    def tip_dof(self) -> int:
        """Global index of the tool-tip translational DOF (second-to-last)."""
        return self.n_dofs - 2

    @property
    def rigid_vectors(self) -> tuple[np.ndarray, np.ndarray]:
        """(t, r): rigid translation and rotation, shape (n_dofs,) each (docs/physics.md §1)."""
        return rigid_body_vectors(self.z_nodes)

    @property
    def t(self) -> np.ndarray:
        return self.rigid_vectors[0]

    @property
    def r(self) -> np.ndarray:
        return self.rigid_vectors[1]

    @cached_property
    def pattern(self) -> SparsePattern:
        """All pieces on one sparsity pattern (computed once)."""
        return common_pattern({name: getattr(self, name) for name in PIECES}, self.n_dofs)

    @cached_property
    def band(self) -> BandLayout:
        """z-ordered banded layout of the pattern (computed once)."""
        return band_layout(self.z_nodes, self.pattern)

    def stiffness_values(self, params: HolderParams) -> np.ndarray:
        """Values of K̃ on :attr:`pattern`, complex, shape (nnz,)."""
        v = self.pattern.values
        a = params.alpha / 100.0
        return (
            v["K_tool"]
            + params.modulus_factor * v["K_holder"]
            + params.c_t * (v["T0"] + a * v["T1"])
            + params.c_r * (v["R0"] + a * v["R1"])
        )

    def mass_values(self, params: HolderParams) -> np.ndarray:
        """Values of M on :attr:`pattern`, real, shape (nnz,)."""
        v = self.pattern.values
        return v["M_tool"] + params.density_factor * v["M_holder"]

    def stiffness(self, params: HolderParams) -> sp.csr_matrix:
        """Complex global stiffness K̃ for a parameter set, (n_dofs, n_dofs)."""
        return self.pattern.csr(self.stiffness_values(params))

    def mass(self, params: HolderParams) -> sp.csr_matrix:
        """Real global mass M for a parameter set, (n_dofs, n_dofs)."""
        return self.pattern.csr(self.mass_values(params))

    def matrices(self, params: HolderParams) -> tuple[sp.csr_matrix, sp.csr_matrix]:
        """(K̃, M) for a parameter set."""
        return self.stiffness(params), self.mass(params)

    def contact_stiffness(self, params: HolderParams) -> sp.csr_matrix:
        """Complex contact-layer stiffness K̃_c alone (for strain-energy diagnostics)."""
        a = params.alpha / 100.0
        return (params.c_t * (self.T0 + a * self.T1) + params.c_r * (self.R0 + a * self.R1)).tocsr()


def build_model(assembly: Assembly, options: ModelOptions = ModelOptions(), f_max_hz: float | None = None) -> FEModel:
    """Mesh an assembly and assemble the parameter-free model pieces (docs/physics.md §1).

    Parameters
    ----------
    assembly : Assembly
        Validated geometry in SI.
    options : ModelOptions
        Mesh and element variants.
    f_max_hz : float, optional
        The frequency the mesh resolves [Hz] (:func:`mesh_frequency_hz`), when the caller
        knows it: a slightly moved assembly (a tolerance) is meshed as its base was, and
        the first pass is saved.

    Returns
    -------
    FEModel

    Notes
    -----
    Two passes: the first mesh gives the highest third bending frequency reachable in
    the search space (tied contact, stiffest and lightest holder); the final mesh also
    resolves the bending wavelength at that frequency (``elements_per_wavelength``).
    The first pass never splits elements, so ``mesh_scale = 0.5`` halves exactly the
    elements of the default mesh.
    """
    if options.elements_per_wavelength > 0:
        f_max = mesh_frequency_hz(assembly, options) if f_max_hz is None else f_max_hz
        return assemble(build_mesh(assembly, options, f_max), options)
    base = replace(options, mesh_scale=max(1.0, options.mesh_scale))
    fe = assemble(build_mesh(assembly, base), base)
    return fe if options == base else assemble(build_mesh(assembly, options), options)


@lru_cache(maxsize=64)
def mesh_frequency_hz(assembly: Assembly, options: ModelOptions = ModelOptions()) -> float | None:
    """The frequency :func:`build_model`'s final mesh resolves [Hz] (None: it resolves none).

    Remembered per (assembly, options), both frozen values: one identification builds the
    same assembly's model for the label guidance, the fast model and the band, and each
    first pass is a mesh, an assembly and an eigen-solution (≈ 7 ms).
    """
    if options.elements_per_wavelength <= 0:
        return None
    base = replace(options, mesh_scale=max(1.0, options.mesh_scale))
    return highest_bending_hz(assemble(build_mesh(assembly, base), base))


def stiffest_holder() -> HolderParams:
    """Holder factors of the stiffest, lightest holder of the search space (docs/physics.md §2).

    The contact values are the stiffest too; with tied contact they do not matter.
    """
    return HolderParams(
        k_tt=10.0 ** P_UPPER[0], k_rr=10.0 ** P_UPPER[1], eta_tt=0.0, eta_rr=0.0,
        alpha=0.0, density_factor=float(P_LOWER[5]), modulus_factor=float(P_UPPER[6]),
    )


def highest_bending_hz(fe: "FEModel", mode: int = 3) -> float:
    """Upper bound of bending mode ``mode`` over the search space [Hz] (docs/physics.md §3)."""
    return float(solve_modes(rigid_contact_model(fe), stiffest_holder(), mode).frequency_hz[mode - 1])


def assemble(mesh: Mesh, options: ModelOptions = ModelOptions()) -> FEModel:
    """Global matrices of a meshed assembly (see :func:`build_model`)."""
    h, t = mesh.holder, mesh.tool
    n_h_nodes, n_t_nodes = len(h.z), len(t.z)
    n = 2 * (n_h_nodes + n_t_nodes)
    dofs_h = element_dofs(h.n_elements, 0)
    dofs_t = element_dofs(t.n_elements, n_h_nodes)

    he, te = mesh.contact_elements[:, 0], mesh.contact_elements[:, 1]
    blocks = contact_blocks(h.z[he], h.length[he], h.phi()[he], t.phi()[te], mesh.z_zone)
    dofs_c = np.concatenate([dofs_h[he], dofs_t[te]], axis=1)
    contact_nodes = mesh.contact_nodes + np.array([0, n_h_nodes])
    pattern = block_pattern([
        (dofs_t, {"K_tool": t.K(), "M_tool": t.M(options.mass)}),
        (dofs_h, {"K_holder": h.K(), "M_holder": h.M(options.mass)}),
        (dofs_c, {"T0": blocks.t0, "T1": blocks.t1, "R0": blocks.r0, "R1": blocks.r1}),
    ], n)
    fe = FEModel(
        **{name: pattern.csr(pattern.values[name]) for name in PIECES},
        z_holder=h.z,
        z_tool=t.z,
        n_elements=h.n_elements + t.n_elements,
        contact_nodes=contact_nodes,
        options=options,
    )
    fe.__dict__["pattern"] = pattern  # the cached property, known already
    return fe


def tie_matrix(fe: FEModel) -> sp.csr_matrix:
    """0/1 matrix P mapping the DOFs of the rigid-contact variant to those of ``fe``.

    Every tool node in the contact zone is tied to its coincident holder node; the other
    nodes keep their own DOFs, in the same order (holder, then the untied tool nodes).
    Shape (fe.n_dofs, n_reduced).
    """
    n_nodes = len(fe.z_holder) + len(fe.z_tool)
    tied_tool = set(int(j) for j in fe.contact_nodes[:, 1])
    target = np.empty(n_nodes, dtype=int)
    nxt = 0
    for node in range(n_nodes):
        if node not in tied_tool:
            target[node] = nxt
            nxt += 1
    for hn, tn in fe.contact_nodes:
        target[tn] = target[hn]
    rows = np.arange(2 * n_nodes)
    cols = (2 * target[:, None] + np.arange(2)[None, :]).ravel()
    return sp.csr_matrix((np.ones(2 * n_nodes), (rows, cols)), shape=(2 * n_nodes, 2 * nxt))


def rigid_contact_model(fe: FEModel) -> FEModel:
    """The variant with tool and holder DOFs tied in the contact zone (docs/physics.md §3; the rigid-contact limit of the reference assembly).

    The contact matrices are zero in it (a tied layer is not strained); holder factors
    still apply through :meth:`FEModel.matrices`, the contact parameters do nothing.
    """
    if fe.rigid_contact:
        return fe
    p = tie_matrix(fe)
    pt = p.T.tocsr()

    def reduce(m):
        return (pt @ m @ p).tocsr()

    n = p.shape[1]
    zero = sp.csr_matrix((n, n))
    tied = np.zeros(len(fe.z_tool), dtype=bool)
    tied[fe.contact_nodes[:, 1] - len(fe.z_holder)] = True
    holder_nodes = fe.contact_nodes[:, 0]
    return FEModel(
        K_tool=reduce(fe.K_tool),
        K_holder=reduce(fe.K_holder),
        M_tool=reduce(fe.M_tool),
        M_holder=reduce(fe.M_holder),
        T0=zero,
        T1=zero,
        R0=zero,
        R1=zero,
        z_holder=fe.z_holder,
        z_tool=fe.z_tool[~tied],
        n_elements=fe.n_elements,
        contact_nodes=np.stack([holder_nodes, holder_nodes], axis=1),
        options=fe.options,
        rigid_contact=True,
    )
