"""A truth model outside taptune's model family: what a real holder does that the model cannot.

Physically the same free-free Timoshenko beams as docs/physics.md §1–§3 (taptune's own mesh and
elements on the TRUE geometry, every element halved so the truth is mesh-converged
beyond the product), but with what the product's model leaves out:

* a contact intensity profile g(z) along the grip that is not linear: a soft front edge
  (the intensity ramps up over the first 15–30 % of the grip), a crowned bore (stiffer in
  the middle) or a relief gap, on top of the product's linear slope α. The contact
  matrices are built for the arbitrary profile by Gauss quadrature (12 points per
  element) over the Friedman & Kosmatka (1993) element interpolation, with the same complex
  stiffness form k(1 + i·10·eta) as the product;
* a lumped mass with rotary inertia the assembly file leaves out (a collet-chuck nut, a
  coolant tube or clamping unit in the HSK bore), spread over the holder nodes it covers;
* an asymmetric holder: the two bending planes differ in contact or section stiffness by
  a fraction ``asymmetry`` (close doublets). A tap at angle θ to the stiff plane excites
  both; the microphone hears cos²θ·H_x + sin²θ·H_y.

The profile is a property of the holder bore: its shape is a function of the distance
from the holder's front face over the holder's clamp length (normalised to mean 1 there),
while α follows the product's convention (docs/physics.md §1: it spans the actual contact zone).
With ``Profile("linear")``, no mass and no asymmetry the truth IS the product model (to
the 0.05 % of its mesh convergence): tests/realism checks that.

Public: :class:`Profile`, :class:`ExtraMass`, :class:`TruthHolder`, :func:`truth_model`,
:func:`truth_modes`, :func:`truth_receptance`, :class:`TruthModes`.
"""

from __future__ import annotations

import functools
from dataclasses import asdict, dataclass, replace

import numpy as np
import scipy.sparse as sp

from taptune.io.assembly import Assembly
from taptune.model.elements import shape_functions
from taptune.model.fe import FEModel, assemble, element_dofs, highest_bending_hz, scatter
from taptune.model.mesh import build_mesh
from taptune.model.modes import solve_modes, tip_receptance
from taptune.model.options import ModelOptions
from taptune.model.params import HolderParams

MM = 1e-3
PROFILE_KINDS = ("linear", "soft_front", "crowned", "gap")
# Quadrature points per contact element: the profiles have kinks and smooth steps, so
# more than the 4 that make the linear layer exact.
N_GAUSS = 12
# Width of the smooth edges of a gap [mm] (a relief groove has chamfered edges).
GAP_EDGE_MM = 0.5
# Halving every product element gives a truth converged well beyond the product's 0.05 %.
TRUTH_OPTIONS = ModelOptions(mesh_scale=0.5)


@dataclass(frozen=True)
class Profile:
    """Shape of the contact intensity along the grip (beyond the product's linear slope).

    Attributes
    ----------
    kind : {"linear", "soft_front", "crowned", "gap"}
    depth : float
        soft_front: intensity at the front face relative to the bulk (0–1);
        crowned: relative drop from the middle to both ends of the grip (0–1);
        gap: residual intensity inside the gap (0–1).
    length_mm : float
        soft_front: length of the ramp from the front face [mm]; gap: gap width [mm].
    position_mm : float
        gap: distance of the gap centre from the front face [mm].
    """

    kind: str = "linear"
    depth: float = 1.0
    length_mm: float = 0.0
    position_mm: float = 0.0

    def __post_init__(self):
        if self.kind not in PROFILE_KINDS:
            raise ValueError(f"unknown profile kind {self.kind!r}")

    def raw_shape(self, d_mm, clamp_mm: float) -> np.ndarray:
        """Un-normalised intensity at distance ``d_mm`` from the front face [mm] → [–]."""
        d = np.asarray(d_mm, dtype=float)
        if self.kind == "linear":
            return np.ones_like(d)
        if self.kind == "soft_front":
            t = np.clip(d / self.length_mm, 0.0, 1.0)
            smooth = t * t * (3 - 2 * t)  # C1 ramp, no kink at its end
            return self.depth + (1 - self.depth) * smooth
        if self.kind == "crowned":
            u = 2 * d / clamp_mm - 1
            return 1.0 - self.depth * u * u
        # gap: two smooth steps (tanh edges)
        half = 0.5 * self.length_mm
        inside = 0.5 * (np.tanh((d - (self.position_mm - half)) / GAP_EDGE_MM * 2)
                        - np.tanh((d - (self.position_mm + half)) / GAP_EDGE_MM * 2))
        return 1.0 - (1.0 - self.depth) * inside

    def shape(self, d_mm, clamp_mm: float) -> np.ndarray:
        """Intensity at distance ``d_mm`` from the front face, mean 1 over the clamp length [–]."""
        grid = np.linspace(0.0, clamp_mm, 4001)
        mean = np.trapezoid(self.raw_shape(grid, clamp_mm), grid) / clamp_mm
        return self.raw_shape(d_mm, clamp_mm) / mean

    def to_dict(self) -> dict:
        return asdict(self)


@dataclass(frozen=True)
class ExtraMass:
    """A ring of mass the assembly file leaves out, on the holder [SI].

    Attributes
    ----------
    mass : float
        [kg].
    z_from_front : float
        Distance of its centre from the holder front face, towards the spindle [m].
    length : float
        Axial length it covers [m].
    radius2 : float
        Mean of r_o² + r_i² of the ring [m²]: its rotary inertia about a diameter is
        m·radius2/4 plus what its axial spread gives.
    """

    mass: float = 0.0
    z_from_front: float = 0.0
    length: float = 0.0
    radius2: float = 0.0

    def to_dict(self) -> dict:
        return asdict(self)


@dataclass(frozen=True)
class TruthHolder:
    """Everything about a real holder that its assembly file does not say.

    Attributes
    ----------
    params : HolderParams
        Intensities at the zone middle (before the profile), loss, α and the two holder
        factors (docs/physics.md §2 units).
    profile : Profile
    extra_mass : ExtraMass
    asymmetry : float
        Relative stiffness difference between the two bending planes (0 = axisymmetric).
    asymmetry_kind : {"contact", "section"}
        Which stiffness differs: the contact layer or the holder's bending section.
    tap_angle_deg : float
        Angle between the tap and the stiff plane.
    """

    params: HolderParams
    profile: Profile = Profile()
    extra_mass: ExtraMass = ExtraMass()
    asymmetry: float = 0.0
    asymmetry_kind: str = "contact"
    tap_angle_deg: float = 0.0

    def plane(self, which: int) -> "TruthHolder":
        """The planar holder of bending plane 0 (stiff, x) or 1 (y, softer by ``asymmetry``)."""
        if which == 0 or self.asymmetry == 0:
            return replace(self, asymmetry=0.0)
        f = 1.0 - self.asymmetry
        p = self.params
        if self.asymmetry_kind == "contact":
            p = replace(p, k_tt=p.k_tt * f, k_rr=p.k_rr * f)
        else:
            p = replace(p, modulus_factor=p.modulus_factor * f)
        return replace(self, params=p, asymmetry=0.0)

    def plane_weights(self) -> tuple[float, float]:
        """(cos²θ, sin²θ): how much of each plane's receptance the tap and microphone see."""
        t = np.radians(self.tap_angle_deg)
        return float(np.cos(t) ** 2), float(np.sin(t) ** 2)

    def worn(self, factor: float) -> "TruthHolder":
        """The same holder with both contact stiffness intensities × ``factor`` (a worn grip)."""
        p = self.params
        return replace(self, params=replace(p, k_tt=p.k_tt * factor, k_rr=p.k_rr * factor))

    def to_dict(self) -> dict:
        return {
            "params": self.params.to_dict(),
            "profile": self.profile.to_dict(),
            "extra_mass": self.extra_mass.to_dict(),
            "asymmetry": self.asymmetry,
            "asymmetry_kind": self.asymmetry_kind,
            "tap_angle_deg": self.tap_angle_deg,
        }


def profile_contact(fe: FEModel, mesh, assembly: Assembly, holder: TruthHolder):
    """Translational and rotational contact matrices for the profile, per unit line stiffness.

    K_c = c_t·T + c_r·R with T = ∫ s(ξ)·g(d) B_wᵀB_w dz, R likewise with B_θ, where
    s = 1 + α/100·ξ over the actual zone (docs/physics.md §1) and g the holder's profile.

    Returns
    -------
    T, R : scipy.sparse.csr_matrix, real, (n_dofs, n_dofs)
    """
    h, t = mesh.holder, mesh.tool
    he, te = mesh.contact_elements[:, 0], mesh.contact_elements[:, 1]
    x, w = np.polynomial.legendre.leggauss(N_GAUSS)
    xi_q, w_q = 0.5 * (x + 1.0), 0.5 * w
    l = h.length[he]
    nw_h, nt_h = shape_functions(xi_q, l, h.phi()[he])
    nw_t, nt_t = shape_functions(xi_q, l, t.phi()[te])
    b_w = np.concatenate([-nw_h, nw_t], axis=-1)
    b_t = np.concatenate([-nt_h, nt_t], axis=-1)
    z = h.z[he][:, None] + l[:, None] * xi_q[None, :]
    z0, zl = mesh.z_zone
    xi = 2.0 * (z - z0) / (zl - z0) - 1.0
    g = (1.0 + holder.params.alpha / 100.0 * xi) * holder.profile.shape((zl - z) / MM, assembly.holder.clamp_length / MM)
    weights = w_q[None, :] * l[:, None] * g
    n_h_nodes = len(h.z)
    dofs = np.concatenate([element_dofs(h.n_elements, 0)[he], element_dofs(t.n_elements, n_h_nodes)[te]], axis=1)
    T = scatter(np.einsum("eq,eqi,eqj->eij", weights, b_w, b_w), dofs, fe.n_dofs)
    R = scatter(np.einsum("eq,eqi,eqj->eij", weights, b_t, b_t), dofs, fe.n_dofs)
    return T, R


def extra_mass_matrix(fe: FEModel, assembly: Assembly, extra: ExtraMass) -> sp.csr_matrix:
    """Lumped mass matrix of a ring spread over the holder nodes it covers (tributary lengths)."""
    n = fe.n_dofs
    if extra.mass <= 0:
        return sp.csr_matrix((n, n))
    z = fe.z_holder
    zc = assembly.holder.length - extra.z_from_front
    half = max(0.5 * extra.length, 1e-9)
    lo, hi = zc - half, zc + half
    # Tributary length of every holder node inside [lo, hi].
    mid = np.concatenate([[-np.inf], 0.5 * (z[:-1] + z[1:]), [np.inf]])
    share = np.clip(np.minimum(mid[1:], hi) - np.maximum(mid[:-1], lo), 0.0, None)
    if share.sum() <= 0:
        share[np.argmin(np.abs(z - zc))] = 1.0
    share = share / share.sum()
    diag = np.zeros(n)
    diag[0:2 * len(z):2] = extra.mass * share
    diag[1:2 * len(z):2] = extra.mass * extra.radius2 / 4.0 * share
    return sp.diags(diag).tocsr()


@functools.lru_cache(maxsize=16)
def truth_model(assembly: Assembly, holder: TruthHolder, options: ModelOptions = TRUTH_OPTIONS):
    """(FEModel, HolderParams) of ONE bending plane of the true holder.

    The returned model is taptune's FEModel container with the linear contact pieces
    replaced by the profiled ones (T1 = R1 = 0, α moved into the profile) and the extra
    mass added to the body mass, so the product's (verified) eigen- and direct solvers
    apply to it unchanged. Pass the returned params (α = 0) with it.
    """
    if holder.asymmetry:
        raise ValueError("truth_model solves one plane: pass holder.plane(0) or holder.plane(1)")
    mesh = build_mesh(assembly, options, _f_max(assembly))
    fe = assemble(mesh, options)
    T, R = profile_contact(fe, mesh, assembly, holder)
    zero = sp.csr_matrix((fe.n_dofs, fe.n_dofs))
    fe = replace(fe, T0=T, T1=zero, R0=R, R1=zero, M_tool=(fe.M_tool + extra_mass_matrix(fe, assembly, holder.extra_mass)).tocsr())
    return fe, replace(holder.params, alpha=0.0)


def _f_max(assembly: Assembly) -> float:
    """The highest reachable third bending frequency, for which the product meshes (build_model)."""
    base = ModelOptions()
    return highest_bending_hz(assemble(build_mesh(assembly, base), base))


@dataclass(frozen=True)
class TruthModes:
    """Bending modes 1–n of both planes of a true holder at one geometry.

    ``bending_hz`` is the centre of each doublet (the mean of the two planes): an
    axisymmetric model can at best predict that; ``split_hz`` is plane x minus plane y.
    """

    bending_hz: tuple
    damping_ratio: tuple
    plane_hz: tuple  # ((f1x, f2x, …), (f1y, f2y, …))
    split_hz: tuple

    def to_dict(self) -> dict:
        return {
            "bending_hz": [round(f, 3) for f in self.bending_hz],
            "damping_ratio": [round(z, 7) for z in self.damping_ratio],
            "plane_hz": [[round(f, 3) for f in p] for p in self.plane_hz],
            "split_hz": [round(s, 3) for s in self.split_hz],
        }


def truth_modes(assembly: Assembly, holder: TruthHolder, n_modes: int = 3) -> TruthModes:
    """Bending frequencies [Hz] and damping ratios of the true holder (eigen-solution)."""
    planes = [holder.plane(0), holder.plane(1)] if holder.asymmetry else [holder]
    f, z = [], []
    for plane in planes:
        fe, params = truth_model(assembly, plane)
        m = solve_modes(fe, params, n_modes)
        f.append(np.asarray(m.frequency_hz[:n_modes]))
        z.append(np.asarray(m.damping_ratio[:n_modes]))
    if len(f) == 1:
        f, z = f * 2, z * 2
    centre = 0.5 * (f[0] + f[1])
    return TruthModes(
        bending_hz=tuple(map(float, centre)),
        damping_ratio=tuple(map(float, 0.5 * (z[0] + z[1]))),
        plane_hz=(tuple(map(float, f[0])), tuple(map(float, f[1]))),
        split_hz=tuple(map(float, f[0] - f[1])),
    )


def truth_receptance(assembly: Assembly, holder: TruthHolder, freq_hz, method: str = "modal",
                     f_cap_hz: float = 26000.0) -> np.ndarray:
    """Tip receptance the tap and microphone hear, cos²θ·H_x + sin²θ·H_y [m/N].

    Parameters
    ----------
    freq_hz : ndarray, shape (m,)
        Frequencies [Hz] (0 allowed: set to 0, the rigid-body line is undefined there).
    method : {"modal", "direct"}
        ``"direct"`` solves (K̃ − ω²M) x = e_tip per frequency (the
        reference; ≈ 0.25 ms per frequency, 6 CPU-s for a 1-Hz grid to 24 kHz);
        ``"modal"`` sums the 20 lowest modes plus the first-order residual of the rest
        (docs/physics.md §3; tests/realism checks it against the direct solve), for the recordings.
    f_cap_hz : float
        Above this (beyond every microphone and the tap's force spectrum) the receptance
        is tapered to zero over 1 kHz instead of solved.
    """
    f = np.asarray(freq_hz, dtype=float)
    out = np.zeros(f.shape, dtype=complex)
    solve = (f > 0) & (f <= f_cap_hz)
    ramp = np.clip((f_cap_hz - f[solve]) / 1000.0, 0.0, 1.0)
    taper = 0.5 - 0.5 * np.cos(np.pi * ramp)
    planes = [holder.plane(0), holder.plane(1)] if holder.asymmetry else [holder]
    weights = holder.plane_weights() if holder.asymmetry else (1.0,)
    for plane, wgt in zip(planes, weights):
        if wgt == 0:
            continue
        fe, params = truth_model(assembly, plane)
        kw = {"n_modes": 20} if method == "modal" else {}
        out[solve] += wgt * tip_receptance(fe, params, f[solve], method=method, **kw) * taper
    return out
