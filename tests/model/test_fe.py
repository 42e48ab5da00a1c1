"""Mesh rules and properties of the assembled free-free system (docs/physics.md §1)."""

import numpy as np
import pytest

from taptune.model.fe import build_model, mesh_frequency_hz, rigid_contact_model
from taptune.model.mesh import build_mesh
from taptune.model.options import ModelOptions
from taptune.model.params import HolderParams

HOLDER_A = HolderParams(1.90e9, 9.37e3, 1.98e-3, 8.20e-3, -10.0, 7478 / 7800, 1.0)


def test_mesh_has_nodes_at_every_breakpoint_and_coincident_contact_nodes(reference_assembly):
    """Mesh breakpoints: nodes at 0, segment boundaries, z_c0, the front face, the tool's back end and tip;
    holder and tool nodes coincide in the contact zone."""
    mesh = build_mesh(reference_assembly)
    zh, zt = mesh.holder.z, mesh.tool.z
    for z in (0.0, 0.032, 0.042, 0.060, 0.100):
        assert np.min(np.abs(zh - z)) < 1e-12
    for z in (0.060, 0.100, 0.1215, 0.1535):
        assert np.min(np.abs(zt - z)) < 1e-12
    hn, tn = mesh.contact_nodes.T
    assert np.array_equal(zh[hn], zt[tn])
    assert zh[hn][0] == pytest.approx(0.060) and zh[hn][-1] == pytest.approx(0.100)


def test_mesh_is_graded_to_short_elements_at_both_zone_ends(reference_assembly):
    """The graded mesh (docs/physics.md §1): the shortest elements sit at both ends of the contact zone: min(0.25 mm, 0.07 × the
    shortest boundary layer, ≈2.0 mm for a Ø16 carbide shank under the stiffest layer), ≤ 1 mm
    inside the zone, ≤ 2 mm elsewhere."""
    from taptune.model.mesh import boundary_layer_length

    layer = boundary_layer_length(reference_assembly)
    assert layer == pytest.approx(2.0e-3, rel=0.05)
    h_min = min(0.25e-3, 0.07 * layer)
    mesh = build_mesh(reference_assembly)
    zh, l = mesh.holder.z, mesh.holder.length
    mid = 0.5 * (zh[:-1] + zh[1:])
    for end in (0.060, 0.100):
        k = np.argmin(np.abs(mid - (end - 1e-5 if end == 0.1 else end + 1e-5)))
        assert l[k] == pytest.approx(h_min, rel=1e-6)
    assert l.min() == pytest.approx(h_min, rel=1e-6)
    in_zone = (mid > 0.060) & (mid < 0.100)
    assert l[in_zone].max() <= 1.0e-3 + 1e-12
    assert l.max() <= 2e-3 + 1e-12 and mesh.tool.length.max() <= 2e-3 + 1e-12


def test_mesh_scale_one_half_splits_every_element_in_two(reference_assembly):
    """The convergence check (docs/physics.md §1) halves exactly the elements of the default model."""
    base = build_model(reference_assembly)
    half = build_model(reference_assembly, ModelOptions(mesh_scale=0.5))
    assert np.array_equal(half.z_holder[::2], base.z_holder) and np.array_equal(half.z_tool[::2], base.z_tool)
    assert half.n_elements == 2 * base.n_elements
    assert len(half.contact_nodes) == 2 * len(base.contact_nodes) - 1


def test_element_properties_come_from_the_segment_at_the_element_midpoint(reference_assembly):
    """docs/assembly-format.md, [tool]: flutes are a Ø12.8 cylinder (0.8 × Ø16) over the last 32 mm."""
    mesh = build_mesh(reference_assembly)
    t = mesh.tool
    mid = 0.5 * (t.z[:-1] + t.z[1:])
    assert np.all(t.od[mid > 0.1535 - 0.032] == pytest.approx(0.0128))
    assert np.all(t.od[mid < 0.1535 - 0.032] == pytest.approx(0.016))
    h = mesh.holder
    hmid = 0.5 * (h.z[:-1] + h.z[1:])
    assert np.all(h.od[(hmid > 0.032) & (hmid < 0.042)] == pytest.approx(0.063))
    assert np.all(h.id[hmid > 0.042] == pytest.approx(0.016))


def test_global_matrices_are_symmetric_and_strain_free_under_rigid_motion(reference_assembly):
    """Assembled free-free system: K̃, M symmetric (K̃ complex symmetric, not Hermitian); K̃ t = 0, K̃ r = 0; tᵀMt = total mass."""
    fe = build_model(reference_assembly)
    K, M = fe.matrices(HOLDER_A)
    assert abs(K - K.T).max() <= 1e-12 * abs(K).max()
    assert abs(M - M.T).max() <= 1e-14 * abs(M).max()
    t, r = fe.rigid_vectors
    scale = abs(K).max()
    assert np.abs(K @ t).max() < 1e-9 * scale and np.abs(K @ r).max() < 1e-9 * scale
    # Reference assembly: total mass 1.54559 kg with holder A's density 7478 kg/m³ (holder 1.34393 kg at
    # 7800 kg/m³ by hand, tool 0.2571 kg); the density factor scales only the holder.
    assert t @ (M @ t) == pytest.approx(1.54559, rel=1e-5)
    assert t @ (fe.M_holder @ t) == pytest.approx(1.34393, rel=1e-5)
    assert t @ (fe.M_tool @ t) == pytest.approx(0.25713, rel=1e-4)


def test_parameters_enter_affinely(reference_assembly):
    """K = K_tool + m·K_holder + c_t(T0 + aT1) + c_r(R0 + aR1): doubling c_t adds c_t(T0 + aT1)."""
    fe = build_model(reference_assembly)
    p2 = HolderParams(**{**HOLDER_A.to_dict(), "k_tt": 2 * HOLDER_A.k_tt})
    diff = fe.stiffness(p2) - fe.stiffness(HOLDER_A)
    expected = HOLDER_A.c_t * (fe.T0 + HOLDER_A.alpha / 100 * fe.T1)
    assert abs(diff - expected).max() <= 1e-9 * abs(expected).max()


def test_contact_layer_totals_k_tt_times_contact_length_and_the_slope_averages_out(reference_assembly):
    """The contact layer (docs/physics.md §1): a unit relative translation strains the layer over L_c (uᵀT0u = 0.040 m, uᵀT1u = 0);
    a relative rigid rotation about the zone middle gives ∫(z − z_m)² dz = L_c³/12 and a
    unit relative rotation over L_c, with zero ξ-weighted parts by symmetry."""
    fe = build_model(reference_assembly)
    n_h = len(fe.z_holder)
    u = np.zeros(fe.n_dofs)
    u[2 * n_h::2] = 1.0  # tool translates, holder still
    assert u @ (fe.T0 @ u) == pytest.approx(0.040, rel=1e-12)
    assert abs(u @ (fe.T1 @ u)) < 1e-14
    assert u @ (fe.R0 @ u) == pytest.approx(0.0, abs=1e-14)
    # A rigid rotation of the tool about z = 0.08 (zone middle): relative w = z − 0.08, θ = 1.
    w = np.zeros(fe.n_dofs)
    w[2 * n_h::2] = fe.z_tool - 0.08
    w[2 * n_h + 1::2] = 1.0
    # ∫ (z − z_m)² dz over 40 mm = L³/12; ∫ ξ (z − z_m)² dz = 0 by symmetry.
    assert w @ (fe.T0 @ w) == pytest.approx(0.040**3 / 12, rel=1e-9)
    assert abs(w @ (fe.T1 @ w)) < 1e-14
    assert w @ (fe.R0 @ w) == pytest.approx(0.040, rel=1e-12)
    assert abs(w @ (fe.R1 @ w)) < 1e-14


def test_dof_bookkeeping_and_tip_dof(reference_assembly):
    """DOF order: holder nodes then tool nodes, [w, θ] per node, tip w = second-to-last DOF."""
    fe = build_model(reference_assembly)
    assert fe.n_dofs == 2 * (len(fe.z_holder) + len(fe.z_tool))
    assert fe.tip_dof == fe.n_dofs - 2
    assert fe.z_nodes[fe.tip_dof // 2] == pytest.approx(0.1535)
    assert fe.n_elements == len(fe.z_holder) + len(fe.z_tool) - 2
    assert fe.K_tool.dtype == complex and fe.T0.dtype == float
    # Default mesh of the reference assembly: a few hundred DOFs (docs/physics.md §1).
    assert 200 <= fe.n_dofs <= 500


def test_rigid_contact_variant_ties_the_tool_to_the_holder_in_the_zone(reference_assembly):
    """Rigid contact: tool DOFs in the zone become the holder's; still two rigid-body modes."""
    fe = build_model(reference_assembly)
    fr = rigid_contact_model(fe)
    n_tied = len(fe.contact_nodes)
    assert fr.n_dofs == fe.n_dofs - 2 * n_tied
    K, M = fr.matrices(HOLDER_A)
    t, r = fr.rigid_vectors
    assert np.abs(K @ t).max() < 1e-9 * abs(K).max() and np.abs(K @ r).max() < 1e-9 * abs(K).max()
    assert t @ (fr.mass(HOLDER_A) @ t) == pytest.approx(1.54559, rel=1e-5)
    assert fr.z_nodes[fr.tip_dof // 2] == pytest.approx(0.1535)


def test_options_round_trip_through_a_dict():
    o = ModelOptions(h_max_mm=1.0, shear="cowper", mass="core", mesh_scale=0.5)
    assert ModelOptions.from_dict(o.to_dict()) == o
    with pytest.raises(ValueError):
        ModelOptions(shear="euler")


def test_bending_wavelength_tends_to_euler_bernoulli_at_low_frequency_and_is_shorter_above():
    """λ = 2π (EI/ρAω²)^¼ for slender waves; shear and rotary inertia shorten it at high frequency."""
    from taptune.io.assembly import STEEL, Segment
    from taptune.model.mesh import bending_wavelength

    seg = [Segment(0.01, 0.05, 0.016)]
    A = np.pi * (0.05**2 - 0.016**2) / 4
    I = np.pi * (0.05**4 - 0.016**4) / 64
    for f, tol in ((1.0, 1e-4), (20000.0, None)):
        eb = 2 * np.pi * (210e9 * I / (7800.0 * A * (2 * np.pi * f) ** 2)) ** 0.25
        lam = bending_wavelength(seg, STEEL, f)[0]
        if tol:
            assert lam == pytest.approx(eb, rel=tol)
        else:
            assert lam < 0.9 * eb


def test_stubby_sections_get_elements_shorter_than_a_fortieth_of_the_wavelength(reference_assembly):
    """The default mesh resolves the bending wave at the highest reachable f3 (elements_per_wavelength = 40)."""
    from taptune.model.fe import highest_bending_hz
    from taptune.model.mesh import bending_wavelength

    fe = build_model(reference_assembly)
    f3 = highest_bending_hz(fe)
    assert 20000 < f3 < 25000  # the rigid-contact f3 (23005.9 Hz) times ≈ sqrt(1.10/0.95)
    mesh = build_mesh(reference_assembly, ModelOptions(), f3)
    h = mesh.holder
    lam = bending_wavelength(reference_assembly.holder.segments, reference_assembly.holder.material, f3)
    bounds = np.cumsum([0.0] + [s.length for s in reference_assembly.holder.segments])
    seg = np.searchsorted(bounds, 0.5 * (h.z[:-1] + h.z[1:])) - 1
    assert np.all(h.length <= lam[seg] / 40 + 1e-12)
    assert np.allclose(fe.z_holder, h.z)


def test_explicit_tool_segments_give_the_same_model_as_shank_and_flute_keys(reference_toml, tmp_path):
    """docs/assembly-format.md: segments [61.5 × Ø16, 32 × Ø12.8] are the reference tool written out."""
    from taptune.io.assembly import load_assembly
    from taptune.model.modes import solve_modes

    text = reference_toml.read_text().replace(
        "shank_diameter = 16.0\nflute_length = 32.0\nflute_diameter = 16.0\n",
        "segments = [ { length = 61.5, od = 16.0 }, { length = 32.0, od = 12.8 } ]\n",
    )
    path = tmp_path / "segments.toml"
    path.write_text(text)
    a = solve_modes(build_model(load_assembly(reference_toml)), HOLDER_A, 3).frequency_hz
    b = solve_modes(build_model(load_assembly(path)), HOLDER_A, 3).frequency_hz
    assert np.allclose(a, b, rtol=1e-9)


def test_a_model_meshed_for_its_own_frequency_is_the_model(reference_assembly):
    """build_model's second pass alone, given the frequency its first pass finds, builds
    the same matrices (what the band's tolerance moves rely on)."""

    full = build_model(reference_assembly)
    again = build_model(reference_assembly, f_max_hz=mesh_frequency_hz(reference_assembly))
    for name in ("K_tool", "K_holder", "M_tool", "M_holder", "T0", "T1", "R0", "R1"):
        assert (getattr(full, name) != getattr(again, name)).nnz == 0, name
    np.testing.assert_array_equal(full.z_tool, again.z_tool)
    assert mesh_frequency_hz(reference_assembly, ModelOptions(elements_per_wavelength=0)) is None


def test_the_pattern_from_element_blocks_is_the_pattern_of_the_scattered_pieces(reference_assembly):
    """assemble sums the element blocks straight onto the union pattern (block_pattern):
    the same pattern and the same values, to the last bit, as scattering every piece into
    its own sparse matrix and taking their union (common_pattern)."""
    from taptune.model.contact import contact_blocks
    from taptune.model.fe import PIECES, common_pattern, element_dofs, scatter

    fe = build_model(reference_assembly)
    mesh = build_mesh(reference_assembly, fe.options, mesh_frequency_hz(reference_assembly))
    h, t, n = mesh.holder, mesh.tool, fe.n_dofs
    dofs_h, dofs_t = element_dofs(h.n_elements, 0), element_dofs(t.n_elements, len(h.z))
    he, te = mesh.contact_elements[:, 0], mesh.contact_elements[:, 1]
    c = contact_blocks(h.z[he], h.length[he], h.phi()[he], t.phi()[te], mesh.z_zone)
    dofs_c = np.concatenate([dofs_h[he], dofs_t[te]], axis=1)
    blocks = {"K_tool": (t.K(), dofs_t), "K_holder": (h.K(), dofs_h), "M_tool": (t.M(fe.options.mass), dofs_t),
              "M_holder": (h.M(fe.options.mass), dofs_h), "T0": (c.t0, dofs_c), "T1": (c.t1, dofs_c),
              "R0": (c.r0, dofs_c), "R1": (c.r1, dofs_c)}
    scattered = common_pattern({name: scatter(b, d, n) for name, (b, d) in blocks.items()}, n)
    np.testing.assert_array_equal(fe.pattern.indptr, scattered.indptr)
    np.testing.assert_array_equal(fe.pattern.indices, scattered.indices)
    for name in PIECES:
        np.testing.assert_array_equal(fe.pattern.values[name], scattered.values[name])
        assert (getattr(fe, name) != scatter(*blocks[name], n)).nnz == 0, name
