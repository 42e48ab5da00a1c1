"""The realism corpus's truth model: the product model when nothing differs, physics when it does."""

from dataclasses import replace

import numpy as np
import pytest

from benchmarks.realism.truth import (ExtraMass, Profile, TruthHolder, profile_contact, truth_model, truth_modes,
                                      truth_receptance)
from taptune.io.assembly import load_assembly
from taptune.model import build_model, solve_modes
from taptune.model.fe import assemble
from taptune.model.mesh import build_mesh
from taptune.model.options import ModelOptions
from taptune.model.params import HolderParams
from tests.conftest import REPO

# Published holder A (CIRP J. Manuf. Sci. Technol. 37, 2022).
HOLDER_A = HolderParams(k_tt=1.90e9, k_rr=9.37e3, eta_tt=1.98e-3, eta_rr=8.20e-3, alpha=-10.0,
                        density_factor=7478 / 7800, modulus_factor=1.0)


@pytest.fixture(scope="module")
def er32():
    return load_assembly(REPO / "assets" / "er32_hsk63_d16.toml")


def f1_to_f3(asm, holder):
    return np.array(truth_modes(asm, holder).bending_hz)


@pytest.mark.parametrize("asset, stickout_mm", [("er32_hsk63_d16", 53.5), ("er32_hsk63_d16", 73.5),
                                                ("shrinkfit_hsk63_d12", 48.0), ("er32_hsk63_d6", 30.0)])
def test_linear_profile_without_deviations_is_the_product_model(asset, stickout_mm):
    # Halved mesh and 12-point profile quadrature against the product's default model: the
    # only difference left is mesh convergence, which docs/physics.md §1 bounds by 0.05 %.
    asm = load_assembly(REPO / "assets" / f"{asset}.toml").with_stickout(stickout_mm * 1e-3)
    product = solve_modes(build_model(asm), HOLDER_A, 3).frequency_hz
    truth = f1_to_f3(asm, TruthHolder(HOLDER_A))
    np.testing.assert_allclose(truth, product, rtol=5e-4)


def test_reference_assembly_matches_the_published_converged_values(er32):
    # Holder A at 53.5 and 63.5 mm (converged values of two independent implementations): 4685.8 / 14934.8 / 19891.9 and 3748.4 / 13124.7 / 17765.9 Hz.
    np.testing.assert_allclose(f1_to_f3(er32, TruthHolder(HOLDER_A)), [4685.8, 14934.8, 19891.9], rtol=5e-4)
    np.testing.assert_allclose(f1_to_f3(er32.with_stickout(0.0635), TruthHolder(HOLDER_A)),
                               [3748.4, 13124.7, 17765.9], rtol=5e-4)


def test_linear_profile_contact_equals_the_product_layer_on_the_same_mesh(er32):
    # 12-point quadrature of (1 + a ξ) reproduces the product's exact T0 + a·T1, R0 + a·R1.
    options = ModelOptions()
    mesh = build_mesh(er32, options)
    fe = assemble(mesh, options)
    T, R = profile_contact(fe, mesh, er32, TruthHolder(HOLDER_A))
    a = HOLDER_A.alpha / 100
    for mine, ref in ((T, fe.T0 + a * fe.T1), (R, fe.R0 + a * fe.R1)):
        assert abs(mine - ref).max() <= 1e-10 * abs(ref).max()


def test_profiles_are_normalised_to_mean_one_over_the_grip():
    for profile in (Profile("soft_front", 0.3, 10.0), Profile("crowned", 0.6), Profile("gap", 0.0, 8.0, 20.0)):
        d = np.linspace(0, 40.0, 20001)
        assert np.trapezoid(profile.shape(d, 40.0), d) / 40.0 == pytest.approx(1.0, abs=1e-4)
    soft = Profile("soft_front", 0.3, 10.0).shape(np.array([0.0, 5.0, 20.0]), 40.0)
    assert soft[0] < soft[1] < soft[2]  # soft at the front face, full intensity deeper in


def test_soft_front_edge_lowers_f1_against_the_linear_profile_of_the_same_mean(er32):
    # The front edge of the grip carries most of the bending moment: softening it matters
    # more than stiffening the deep end by the same total.
    linear = f1_to_f3(er32, TruthHolder(HOLDER_A))
    soft = f1_to_f3(er32, TruthHolder(HOLDER_A, Profile("soft_front", depth=0.3, length_mm=10.0)))
    assert soft[0] < linear[0] * 0.99


def test_a_collet_nut_lowers_f1(er32):
    nut = ExtraMass(mass=0.08, z_from_front=0.011, length=0.022, radius2=(0.025**2 + 0.018**2))
    plain = f1_to_f3(er32, TruthHolder(HOLDER_A))
    heavy = f1_to_f3(er32, TruthHolder(HOLDER_A, extra_mass=nut))
    assert np.all(heavy < plain)
    assert heavy[0] < plain[0] * 0.995


@pytest.mark.parametrize("kind", ["contact", "section"])
def test_asymmetry_splits_every_mode_into_a_close_doublet(er32, kind):
    delta = 0.01
    modes = truth_modes(er32, TruthHolder(HOLDER_A, asymmetry=delta, asymmetry_kind=kind, tap_angle_deg=30.0))
    fx, fy = np.array(modes.plane_hz)
    split = fx - fy
    # The softer plane is lower, by less than the stiffness ratio alone would give (√(1-δ)).
    assert np.all(split > 0)
    assert np.all(split / fx < 0.5 * delta + 1e-9)
    np.testing.assert_allclose(modes.bending_hz, 0.5 * (fx + fy))


def test_tap_angle_weights_the_two_planes(er32):
    holder = TruthHolder(HOLDER_A, asymmetry=0.01, asymmetry_kind="section", tap_angle_deg=0.0)
    f = np.array([1000.0, 4000.0, 12000.0])
    only_x = truth_receptance(er32, holder, f)
    np.testing.assert_allclose(only_x, truth_receptance(er32, holder.plane(0), f), rtol=1e-12)
    both = truth_receptance(er32, replace(holder, tap_angle_deg=45.0), f)
    np.testing.assert_allclose(both, 0.5 * (only_x + truth_receptance(er32, holder.plane(1), f)), rtol=1e-10)


def test_modal_receptance_agrees_with_the_direct_solve(er32):
    holder = TruthHolder(HOLDER_A, Profile("gap", 0.05, 8.0, 20.0), ExtraMass(0.05, 0.011, 0.022, 1e-3))
    f = np.array([500.0, 3000.0, 4600.0, 9000.0, 14000.0, 18000.0, 22000.0])
    modal = truth_receptance(er32, holder, f, method="modal")
    direct = truth_receptance(er32, holder, f, method="direct")
    # The first-order residual of the modes above the 20th leaves a few ppm at 20 kHz.
    np.testing.assert_allclose(modal, direct, rtol=1e-5)


def test_worn_holder_has_softer_contact_and_lower_f1(er32):
    holder = TruthHolder(HOLDER_A, Profile("crowned", 0.5))
    worn = holder.worn(0.5)
    assert worn.params.k_tt == pytest.approx(0.5 * HOLDER_A.k_tt)
    assert worn.params.k_rr == pytest.approx(0.5 * HOLDER_A.k_rr)
    assert f1_to_f3(er32, worn)[0] < f1_to_f3(er32, holder)[0]


def test_truth_model_refuses_an_asymmetric_holder(er32):
    with pytest.raises(ValueError):
        truth_model(er32, TruthHolder(HOLDER_A, asymmetry=0.01))


def test_extra_mass_adds_its_mass_and_rotary_inertia_to_the_rigid_body(er32):
    # Rigid-body checks by hand: a unit translation w = 1 (θ = 0) of the whole assembly
    # gains exactly the ring's mass m; a unit rotation about the ring's centre
    # (w = z - zc, θ = 1) gains m·radius2/4 plus m·L²/12 for the spread over L
    # (to the lumping on the mesh's nodes).
    nut = ExtraMass(mass=0.08, z_from_front=0.011, length=0.022, radius2=(0.025**2 + 0.018**2))
    plain, _ = truth_model(er32, TruthHolder(HOLDER_A))
    heavy, _ = truth_model(er32, TruthHolder(HOLDER_A, extra_mass=nut))
    added = (heavy.M_tool - plain.M_tool).toarray()
    z = plain.z_nodes
    translation = np.zeros(plain.n_dofs)
    translation[0::2] = 1.0
    assert translation @ added @ translation == pytest.approx(nut.mass, rel=1e-12)
    zc = er32.holder.length - nut.z_from_front
    rotation = np.zeros(plain.n_dofs)
    rotation[0::2], rotation[1::2] = z - zc, 1.0
    expected = nut.mass * (nut.radius2 / 4 + nut.length**2 / 12)
    assert rotation @ added @ rotation == pytest.approx(expected, rel=0.01)  # 0.013 % on this mesh
