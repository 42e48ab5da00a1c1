"""Timoshenko element matrices and shear coefficients (Friedman & Kosmatka 1993; Hutchinson 2001)."""

import numpy as np
import pytest

from taptune.model.contact import GAUSS_W, GAUSS_XI
from taptune.model.elements import (
    BeamElements,
    consistent_mass_matrices,
    core_mass_matrices,
    section_properties,
    shape_functions,
    shear_coefficient,
    shear_parameter,
    stiffness_matrices,
)

STEEL = dict(density=7800.0, youngs_modulus=210e9, poisson=0.29, loss_factor=0.0)


def one_element(l=0.010, d=0.020, **material):
    mat = {**STEEL, **material}
    return BeamElements(z=np.array([0.0, l]), od=np.array([d]), id=np.array([0.0]), **mat)


def test_solid_steel_element_of_10_mm_matches_reference_stiffness_and_mass():
    """One element, checked by hand: Ø20 solid steel, l = 10 mm: κ = 0.923098, φ = 8.384806 and the listed entries."""
    el = one_element()
    kappa = shear_coefficient(el.od, el.id, el.poisson)[0]
    assert kappa == pytest.approx(0.923098, abs=1e-6)
    assert el.phi()[0] == pytest.approx(8.384806, rel=1e-6)
    K = el.K()[0].real
    M = el.M()[0]
    assert K[0, 0] == pytest.approx(2.108944e9, rel=1e-6)
    assert K[0, 1] == pytest.approx(1.054472e7, rel=1e-6)
    assert K[1, 1] == pytest.approx(2.176572e5, rel=1e-6)
    assert K[1, 3] == pytest.approx(-1.122100e5, rel=1e-6)
    for (i, j), ref in {
        (0, 0): 8.339969e-3, (0, 1): 7.587883e-6, (0, 2): 3.912243e-3,
        (0, 3): -1.283247e-5, (1, 1): 1.941052e-7, (1, 3): 5.116278e-8,
    }.items():
        assert M[i, j] == pytest.approx(ref, rel=1e-6)


def test_element_stiffness_has_exactly_two_rigid_body_modes_and_mass_sums_to_rho_A_l():
    """One element: K_e has two zero eigenvalues; M11 + M13 + M31 + M33 = ρAl = 0.0245044 kg."""
    el = one_element()
    ev = np.linalg.eigvalsh(el.K()[0].real)
    assert np.sum(np.abs(ev) < 1e-9 * ev.max()) == 2
    M = el.M()[0]
    assert M[0, 0] + M[0, 2] + M[2, 0] + M[2, 2] == pytest.approx(0.0245044, rel=1e-6)
    assert np.allclose(M, M.T) and np.allclose(el.K()[0], el.K()[0].T)


def test_material_loss_factor_scales_the_whole_stiffness_by_one_plus_i_eta():
    """Friedman & Kosmatka (1993) stiffness: Ẽ = E(1 + iη) with φ unchanged gives exactly K̃_e = (1 + iη) K_e."""
    el = one_element(loss_factor=0.003)
    assert np.allclose(el.K()[0], (1 + 0.003j) * one_element().K()[0].real, rtol=1e-15)


@pytest.mark.parametrize(
    "d_in, d_out, nu, hutchinson, cowper",
    [
        (0, 1, 0.22, 0.9082, 0.8798),
        (0, 1, 0.29, 0.9231, 0.8856),
        (0, 1, 0.30, 0.9252, 0.8864),
        (0.5, 1, 0.29, 0.6553, 0.6194),
        (16, 50, 0.29, 0.7596, 0.7221),
    ],
)
def test_shear_coefficients_of_solid_and_hollow_circles(d_in, d_out, nu, hutchinson, cowper):
    """Shear coefficients of Hutchinson (2001) and Cowper (1966); only the diameter ratio matters."""
    assert shear_coefficient([d_out], [d_in], nu, "hutchinson")[0] == pytest.approx(hutchinson, abs=5e-5)
    assert shear_coefficient([d_out], [d_in], nu, "cowper")[0] == pytest.approx(cowper, abs=5e-5)


def test_thin_walled_hutchinson_limit_is_one_plus_nu_over_two_plus_nu():
    """Hutchinson (2001): κ → (1 + ν)/(2 + ν) as the wall gets thin."""
    k = shear_coefficient([1.0], [0.99999], 0.29, "hutchinson")[0]
    assert k == pytest.approx(1.29 / 2.29, rel=1e-6)


def test_zero_shear_parameter_gives_the_classical_hermite_matrices():
    """Friedman & Kosmatka (1993) consistent mass: φ = 0 reduces K_e and M_A + M_I to the Euler–Bernoulli / Rayleigh matrices."""
    l, E, I, rho, A = 0.01, 2e11, 1e-8, 7800.0, 3e-4
    K = stiffness_matrices(E, np.array([I]), np.array([l]), np.array([0.0]))[0]
    herm_k = E * I / l**3 * np.array(
        [[12, 6 * l, -12, 6 * l], [6 * l, 4 * l * l, -6 * l, 2 * l * l],
         [-12, -6 * l, 12, -6 * l], [6 * l, 2 * l * l, -6 * l, 4 * l * l]]
    )
    assert np.allclose(K, herm_k)
    M = consistent_mass_matrices(rho, np.array([A]), np.array([I]), np.array([l]), np.array([0.0]))[0]
    herm_m = rho * A * l / 420 * np.array(
        [[156, 22 * l, 54, -13 * l], [22 * l, 4 * l * l, 13 * l, -3 * l * l],
         [54, 13 * l, 156, -22 * l], [-13 * l, -3 * l * l, -22 * l, 4 * l * l]]
    )
    rot = rho * I / (30 * l) * np.array(
        [[36, 3 * l, -36, 3 * l], [3 * l, 4 * l * l, -3 * l, -l * l],
         [-36, -3 * l, 36, -3 * l], [3 * l, -l * l, -3 * l, 4 * l * l]]
    )
    assert np.allclose(M, herm_m + rot, rtol=1e-12, atol=0)


def test_core_mass_is_hermite_translation_plus_linear_rotation_inertia():
    """mass="core": rotary inertia (ρIl/6)[0 0 0 0; 0 2 0 1; 0 0 0 0; 0 1 0 2]."""
    l, rho, A, I = 0.01, 7800.0, 3e-4, 1e-8
    M = core_mass_matrices(rho, np.array([A]), np.array([I]), np.array([l]))[0]
    trans = core_mass_matrices(rho, np.array([A]), np.array([0.0]), np.array([l]))[0]
    assert trans[0, 0] == pytest.approx(rho * A * l * 156 / 420)
    assert (M - trans)[1, 1] == pytest.approx(rho * I * l / 3)
    assert (M - trans)[1, 3] == pytest.approx(rho * I * l / 6)
    assert (M - trans)[0, 0] == 0


def test_matrices_are_the_energy_integrals_of_the_interpolation():
    """Friedman & Kosmatka (1993) interpolation: K_e = ∫ EI N_θ'ᵀN_θ' + κGA (N_w' − N_θ)ᵀ(N_w' − N_θ), M_e = ∫ ρA N_wᵀN_w + ρI N_θᵀN_θ."""
    el = BeamElements(z=np.array([0.0, 0.007]), od=np.array([0.05]), id=np.array([0.016]), **STEEL)
    l, phi = el.length, el.phi()
    A, I = el.sections()
    kappa = shear_coefficient(el.od, el.id, el.poisson)[0]
    G = el.youngs_modulus / (2 * (1 + el.poisson))
    # Derivatives by central differences of the analytic interpolation (cubic: exact to round-off).
    h = 1e-5
    n_w, n_t = shape_functions(GAUSS_XI, l, phi)
    dw = (shape_functions(GAUSS_XI + h, l, phi)[0] - shape_functions(GAUSS_XI - h, l, phi)[0]) / (2 * h * l[0])
    dt = (shape_functions(GAUSS_XI + h, l, phi)[1] - shape_functions(GAUSS_XI - h, l, phi)[1]) / (2 * h * l[0])
    gamma = dw - n_t
    wq = GAUSS_W * l[0]
    K = el.youngs_modulus * I[0] * np.einsum("q,qi,qj->ij", wq, dt[0], dt[0]) + kappa * G * A[0] * np.einsum(
        "q,qi,qj->ij", wq, gamma[0], gamma[0]
    )
    M = el.density * (A[0] * np.einsum("q,qi,qj->ij", wq, n_w[0], n_w[0]) + I[0] * np.einsum("q,qi,qj->ij", wq, n_t[0], n_t[0]))
    assert np.allclose(K, el.K()[0].real, rtol=1e-6, atol=1e-6 * np.abs(K).max())
    assert np.allclose(M, el.M()[0], rtol=1e-9, atol=1e-12 * np.abs(M).max())


def test_interpolation_reproduces_rigid_translation_and_rotation():
    """The contact matrices (docs/physics.md §1) rely on it: N_w reproduces w = 1 and w = z, N_θ gives θ = 0 and θ = 1."""
    l, phi = np.array([0.004]), np.array([3.0])
    xi = np.linspace(0, 1, 7)
    n_w, n_t = shape_functions(xi, l, phi)
    t = np.array([1.0, 0.0, 1.0, 0.0])
    r = np.array([0.0, 1.0, l[0], 1.0])
    assert np.allclose(n_w[0] @ t, 1) and np.allclose(n_t[0] @ t, 0)
    assert np.allclose(n_w[0] @ r, xi * l[0]) and np.allclose(n_t[0] @ r, 1)


def test_section_and_shear_parameter_follow_the_definitions():
    """A, I of a tube and φ = 24 (1 + ν) I / (κ A l²), independent of E."""
    A, I = section_properties([0.05], [0.016])
    assert A[0] == pytest.approx(np.pi * (0.05**2 - 0.016**2) / 4)
    assert I[0] == pytest.approx(np.pi * (0.05**4 - 0.016**4) / 64)
    assert shear_parameter([0.01], A, I, 0.76, 0.29)[0] == pytest.approx(24 * 1.29 * I[0] / (0.76 * A[0] * 1e-4))
