"""Two-node Timoshenko beam elements (docs/physics.md §1), vectorised over elements.

Element DOF order is [w1, θ1, w2, θ2] (node 1 at the smaller z). Every function takes
arrays of element properties of shape (n,) and returns stacks of shape (n, 4, 4) (or
(n, q, 4) for the interpolation), so a body of a few hundred elements is built without
a Python loop. :class:`BeamElements` bundles the properties of one body's elements and
hands out their matrices (ROSS-like ``K()``/``M()``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


def section_properties(od, id_):
    """Area [m²] and second moment of area [m⁴] of hollow circular sections.

    Parameters
    ----------
    od, id_ : array_like, shape (n,)
        Outer and inner diameter [m] (inner 0 for a solid section).
    """
    od = np.asarray(od, dtype=float)
    id_ = np.asarray(id_, dtype=float)
    area = np.pi * (od**2 - id_**2) / 4.0
    inertia = np.pi * (od**4 - id_**4) / 64.0
    return area, inertia


def shear_coefficient(od, id_, poisson, formula="hutchinson"):
    """Shear coefficient κ of a hollow circular section (docs/physics.md §1).

    Parameters
    ----------
    od, id_ : array_like, shape (n,)
        Outer and inner diameter [m]; only their ratio matters.
    poisson : float or array_like
        Poisson ratio ν.
    formula : {"hutchinson", "cowper"}
        Hutchinson (2001, exact-elasticity based; the default) or Cowper (1966).
    """
    od = np.asarray(od, dtype=float)
    id_ = np.asarray(id_, dtype=float)
    nu = np.asarray(poisson, dtype=float)
    if formula == "hutchinson":
        a2, b2 = (od / 2) ** 2, (id_ / 2) ** 2
        a4, b4, ab = a2**2, b2**2, a2 * b2
        num = 6.0 * (a2 + b2) ** 2 * (1 + nu) ** 2
        den = (
            7 * a4 + 34 * ab + 7 * b4
            + nu * (12 * a4 + 48 * ab + 12 * b4)
            + nu**2 * (4 * a4 + 16 * ab + 4 * b4)
        )
        return num / den
    if formula == "cowper":
        m2 = (id_ / od) ** 2
        return 6 * (1 + nu) * (1 + m2) ** 2 / ((7 + 6 * nu) * (1 + m2) ** 2 + (20 + 12 * nu) * m2)
    raise ValueError(f"unknown shear-coefficient formula {formula!r}")


def shear_parameter(length, area, inertia, kappa, poisson):
    """Shear deformation parameter φ = 24 (1 + ν) I / (κ A l²) (docs/physics.md §1), shape (n,).

    φ does not depend on E because G is proportional to E; φ = 0 is Euler–Bernoulli.
    """
    l = np.asarray(length, dtype=float)
    return 24.0 * (1 + np.asarray(poisson, dtype=float)) * inertia / (kappa * area * l**2)


def stiffness_matrices(E, inertia, length, phi):
    """Real element stiffness matrices K_e [N/m, N, N·m] (docs/physics.md §1), shape (n, 4, 4).

    Multiply by (1 + i η_mat) for the complex (hysteretic) stiffness.
    """
    l = np.asarray(length, dtype=float)
    phi = np.asarray(phi, dtype=float)
    c = np.asarray(E, dtype=float) * inertia / ((1 + phi) * l**3)
    l2 = l * l
    one = np.ones_like(l)
    k = np.empty(l.shape + (4, 4))
    k[:, 0] = np.stack([12 * one, 6 * l, -12 * one, 6 * l], axis=-1)
    k[:, 1] = np.stack([6 * l, (4 + phi) * l2, -6 * l, (2 - phi) * l2], axis=-1)
    k[:, 2] = -k[:, 0]
    k[:, 3] = np.stack([6 * l, (2 - phi) * l2, -6 * l, (4 + phi) * l2], axis=-1)
    return c[:, None, None] * k


def consistent_mass_matrices(rho, area, inertia, length, phi):
    """Friedman–Kosmatka consistent mass M_A + M_I [kg, kg·m, kg·m²] (docs/physics.md §1), (n, 4, 4)."""
    l = np.asarray(length, dtype=float)
    phi = np.asarray(phi, dtype=float)
    rho = np.asarray(rho, dtype=float)
    p2 = phi * phi
    a1 = 70 * p2 + 147 * phi + 78
    a2 = (35 * p2 + 77 * phi + 44) / 4
    a3 = 35 * p2 + 63 * phi + 27
    a4 = (35 * p2 + 63 * phi + 26) / 4
    a5 = (7 * p2 + 14 * phi + 8) / 4
    a6 = (7 * p2 + 14 * phi + 6) / 4
    l2 = l * l
    ma = np.empty(l.shape + (4, 4))
    ma[:, 0] = np.stack([a1, a2 * l, a3, -a4 * l], axis=-1)
    ma[:, 1] = np.stack([a2 * l, a5 * l2, a4 * l, -a6 * l2], axis=-1)
    ma[:, 2] = np.stack([a3, a4 * l, a1, -a2 * l], axis=-1)
    ma[:, 3] = np.stack([-a4 * l, -a6 * l2, -a2 * l, a5 * l2], axis=-1)
    ma *= (rho * area * l / (210 * (1 + phi) ** 2))[:, None, None]

    b1 = 15 * phi - 3
    b2 = 10 * p2 + 5 * phi + 4
    b3 = 5 * p2 - 5 * phi - 1
    c36 = 36 * np.ones_like(l)
    mi = np.empty(l.shape + (4, 4))
    mi[:, 0] = np.stack([c36, -b1 * l, -c36, -b1 * l], axis=-1)
    mi[:, 1] = np.stack([-b1 * l, b2 * l2, b1 * l, b3 * l2], axis=-1)
    mi[:, 2] = np.stack([-c36, b1 * l, c36, b1 * l], axis=-1)
    mi[:, 3] = np.stack([-b1 * l, b3 * l2, b1 * l, b2 * l2], axis=-1)
    mi *= (rho * inertia / (30 * (1 + phi) ** 2 * l))[:, None, None]
    return ma + mi


def core_mass_matrices(rho, area, inertia, length):
    """The core method's mass: Hermite translational + linear-rotation rotary inertia, (n, 4, 4).

    docs/physics.md §1, option ``mass="core"``.
    """
    l = np.asarray(length, dtype=float)
    rho = np.asarray(rho, dtype=float)
    hermite = np.array(
        [[156, 22, 54, -13], [22, 4, 13, -3], [54, 13, 156, -22], [-13, -3, -22, 4]], dtype=float
    )
    # Powers of l per entry: rows/columns 1 and 3 (θ) carry one l each.
    p = np.array([0, 1, 0, 1])
    lpow = l[:, None, None] ** (p[:, None] + p[None, :])[None]
    ma = (rho * area * l / 420)[:, None, None] * hermite[None] * lpow
    rot = np.zeros((4, 4))
    rot[1, 1] = rot[3, 3] = 2.0
    rot[1, 3] = rot[3, 1] = 1.0
    mi = (rho * inertia * l / 6)[:, None, None] * rot[None]
    return ma + mi


def shape_functions(xi, length, phi):
    """Interdependent Timoshenko interpolation N_w, N_θ (docs/physics.md §1).

    Parameters
    ----------
    xi : array_like, shape (q,)
        Local positions z_local / l in [0, 1].
    length, phi : array_like, shape (n,)
        Element lengths [m] and shear parameters.

    Returns
    -------
    n_w : ndarray, shape (n, q, 4)
        Displacement interpolation (dimensionless for w DOFs, [m] for θ DOFs).
    n_theta : ndarray, shape (n, q, 4)
        Rotation interpolation ([1/m] for w DOFs, dimensionless for θ DOFs).
    """
    x = np.asarray(xi, dtype=float)[None, :]
    l = np.asarray(length, dtype=float)[:, None]
    f = np.asarray(phi, dtype=float)[:, None]
    x2, x3 = x * x, x * x * x
    g = 1.0 / (1 + f)
    n_w = np.stack(
        np.broadcast_arrays(
            g * (2 * x3 - 3 * x2 - f * x + 1 + f),
            g * l * (x3 - (2 + f / 2) * x2 + (1 + f / 2) * x),
            g * (-2 * x3 + 3 * x2 + f * x),
            g * l * (x3 - (1 - f / 2) * x2 - (f / 2) * x),
        ),
        axis=-1,
    )
    n_t = np.stack(
        np.broadcast_arrays(
            g * 6 * (x2 - x) / l,
            g * (3 * x2 - (4 + f) * x + 1 + f),
            -g * 6 * (x2 - x) / l,
            g * (3 * x2 - (2 - f) * x),
        ),
        axis=-1,
    )
    return n_w, n_t


@dataclass(frozen=True)
class BeamElements:
    """The elements of one body, all properties of shape (n,) in SI.

    Attributes
    ----------
    z : ndarray, shape (n + 1,)
        Node positions [m], increasing.
    od, id : ndarray, shape (n,)
        Outer and inner diameters [m].
    density, youngs_modulus, poisson, loss_factor : float
        Material of the body [kg/m³, Pa, –, –].
    shear : str
        Shear-coefficient formula.
    """

    z: np.ndarray
    od: np.ndarray
    id: np.ndarray
    density: float
    youngs_modulus: float
    poisson: float
    loss_factor: float
    shear: str = "hutchinson"

    @property
    def length(self) -> np.ndarray:
        """Element lengths [m], shape (n,)."""
        return np.diff(self.z)

    @property
    def n_elements(self) -> int:
        return len(self.od)

    def sections(self):
        """(A [m²], I [m⁴]) per element."""
        return section_properties(self.od, self.id)

    def phi(self) -> np.ndarray:
        """Shear deformation parameter φ per element."""
        area, inertia = self.sections()
        kappa = shear_coefficient(self.od, self.id, self.poisson, self.shear)
        return shear_parameter(self.length, area, inertia, kappa, self.poisson)

    def K(self) -> np.ndarray:
        """Complex element stiffness (1 + i η_mat) K_e, shape (n, 4, 4)."""
        _, inertia = self.sections()
        k = stiffness_matrices(self.youngs_modulus, inertia, self.length, self.phi())
        return (1 + 1j * self.loss_factor) * k

    def M(self, variant: str = "consistent") -> np.ndarray:
        """Real element mass matrices, shape (n, 4, 4); ``variant`` per docs/physics.md §1."""
        area, inertia = self.sections()
        if variant == "consistent":
            return consistent_mass_matrices(self.density, area, inertia, self.length, self.phi())
        if variant == "core":
            return core_mass_matrices(self.density, area, inertia, self.length)
        raise ValueError(f"unknown mass variant {variant!r}")
