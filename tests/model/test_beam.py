"""A uniform free-free steel cylinder against closed-form and exact results (Timoshenko beam theory; Hutchinson 2001 shear coefficient)."""

import numpy as np
import pytest
import scipy.linalg as sla
import scipy.sparse as sp

from taptune.model.elements import BeamElements, consistent_mass_matrices, stiffness_matrices
from taptune.model.fe import element_dofs, scatter
from taptune.model.modes import direct_receptance

D = 0.020  # Ø20 solid steel, E = 210 GPa, ρ = 7800 kg/m³, ν = 0.29


def cylinder(length, n_elements, shear="hutchinson"):
    z = np.linspace(0.0, length, n_elements + 1)
    return BeamElements(
        z=z, od=np.full(n_elements, D), id=np.zeros(n_elements),
        density=7800.0, youngs_modulus=210e9, poisson=0.29, loss_factor=0.0, shear=shear,
    )


def body_matrices(el: BeamElements, euler_bernoulli=False):
    """Global (K, M) of one free-free body; EB: φ = 0 and no rotary inertia."""
    n = 2 * len(el.z)
    dofs = element_dofs(el.n_elements, 0)
    if euler_bernoulli:
        area, inertia = el.sections()
        zero = np.zeros(el.n_elements)
        k = stiffness_matrices(el.youngs_modulus, inertia, el.length, zero)
        m = consistent_mass_matrices(el.density, area, zero, el.length, zero)
    else:
        k, m = el.K().real, el.M()
    return scatter(k, dofs, n).toarray(), scatter(m, dofs, n).toarray()


def bending_hz(el, euler_bernoulli=False):
    K, M = body_matrices(el, euler_bernoulli)
    lam = sla.eigh(K, M, eigvals_only=True)
    return np.sqrt(np.abs(lam[2:5])) / (2 * np.pi)


@pytest.mark.parametrize(
    "length, shear, exact",
    [
        (0.100, "hutchinson", (8429.1, 20422.3, 34933.4)),
        (0.100, "cowper", (8417.5, 20341.6, 34712.5)),
        (0.200, "hutchinson", (2251.9, 5949.5, 11043.1)),
        (0.200, "cowper", (2251.0, 5941.1, 11013.5)),
    ],
)
def test_fine_mesh_matches_exact_timoshenko_free_free_frequencies_to_0_05_percent(length, shear, exact):
    """0.5 mm elements reproduce the exact Timoshenko (transfer-matrix) frequencies."""
    f = bending_hz(cylinder(length, int(round(length / 0.0005)), shear))
    assert np.allclose(f, exact, rtol=5e-4)


@pytest.mark.parametrize(
    "length, fe_rows",
    [(0.100, (8438.7, 20551.2, 35556.1)), (0.200, (2252.1, 5953.0, 11065.0))],
)
def test_10_mm_elements_match_the_reference_fe_rows_to_0_01_percent(length, fe_rows):
    """10 mm elements (Hutchinson κ); the FE converges from above."""
    f = bending_hz(cylinder(length, int(round(length / 0.010))))
    assert np.allclose(f, fe_rows, rtol=1e-4)


def test_euler_bernoulli_limit_converges_to_the_closed_form():
    """φ = 0 without rotary inertia → f_n = (β_n L)²/(2πL²)·sqrt(EI/ρA): 9238.1 / 25465.2 / 49921.9 Hz at L = 100 mm."""
    beta_l = np.array([4.7300, 7.8532, 10.9956])
    closed = beta_l**2 / (2 * np.pi * 0.1**2) * (D / 4) * np.sqrt(210e9 / 7800.0)
    assert np.allclose(closed, (9238.1, 25465.2, 49921.9), rtol=2e-5)
    assert bending_hz(cylinder(0.1, 10), euler_bernoulli=True)[0] == pytest.approx(9238.4, abs=0.1)
    assert np.allclose(bending_hz(cylinder(0.1, 100), euler_bernoulli=True), closed, rtol=1e-4)


def test_shear_and_rotary_inertia_lower_the_frequencies_more_for_stubby_beams():
    """Timoshenko against Euler–Bernoulli: −8.8 / −19.8 / −30.0 % against Euler–Bernoulli at L/D = 5, −2.5 / −6.5 / −11.5 % at L/D = 10."""
    for length, drop in ((0.1, (8.8, 19.8, 30.0)), (0.2, (2.5, 6.5, 11.5))):
        el = cylinder(length, int(round(length / 0.001)))
        rel = 100 * (1 - bending_hz(el) / bending_hz(el, euler_bernoulli=True))
        assert np.allclose(rel, drop, atol=0.1)


def test_low_frequency_end_receptance_follows_the_rigid_body_mass_line():
    """Rigid-body asymptote −(1/m + d²/J)/ω², Ø20 × 100 mm at 10 Hz: H_end,end = −4.0445e-3 m/N (−4.1348e-3 without rotary inertia)."""
    el = cylinder(0.1, 20)
    K, M = body_matrices(el)
    n = K.shape[0]
    h = direct_receptance(sp.csr_matrix(K), sp.csr_matrix(M), n - 2, n - 2, [10.0])[0]
    assert h.real == pytest.approx(-4.0445e-3, rel=1e-4)
    K0, M0 = body_matrices(el, euler_bernoulli=True)
    h0 = direct_receptance(sp.csr_matrix(K0), sp.csr_matrix(M0), n - 2, n - 2, [10.0])[0]
    assert h0.real == pytest.approx(-4.1348e-3, rel=1e-4)
    # Far end: −(1/m − (L/2)²/J)/ω² with J = mL²/12 + ρIL.
    m = 7800.0 * np.pi * D**2 / 4 * 0.1
    J = m * 0.1**2 / 12 + 7800.0 * np.pi * D**4 / 64 * 0.1
    w2 = (2 * np.pi * 10.0) ** 2
    h_cross = direct_receptance(sp.csr_matrix(K), sp.csr_matrix(M), 0, n - 2, [10.0])[0]
    assert h_cross.real == pytest.approx(-(1 / m - 0.05**2 / J) / w2, rel=1e-4)
