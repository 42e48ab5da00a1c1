"""Physical bounds of the bending frequencies over the search space (``bending_bounds``)."""

import itertools

import numpy as np

from taptune.model.bounds import bending_bounds
from taptune.model.fe import build_model, rigid_contact_model
from taptune.model.modes import solve_modes
from taptune.model.params import NOMINAL, P_LOWER, P_UPPER, HolderParams, from_p

HOLDER_A = HolderParams(1.90e9, 9.37e3, 1.98e-3, 8.20e-3, -10.0, 7478 / 7800, 1.0)


def test_bounds_bracket_every_admissible_holder(reference_assembly):
    """Lower < f_n < upper for holder A, the nominal set and a spread of search-space points;
    the upper bound exceeds the rigid-contact frequencies (5787.9 / 15392.2 / 23005.9 Hz, converged values of two independent implementations)."""
    fe = build_model(reference_assembly)
    bounds = bending_bounds(reference_assembly, fe=fe)
    assert bounds.shape == (3, 2) and np.all(bounds[:, 0] < bounds[:, 1])
    assert np.all(bounds[:, 1] > [5787.9, 15392.2, 23005.9])
    rng = np.random.default_rng(1)
    samples = [HOLDER_A, NOMINAL] + [from_p(P_LOWER + rng.random(7) * (P_UPPER - P_LOWER)) for _ in range(12)]
    samples += [from_p(np.where(np.array(b) == 1, P_UPPER, P_LOWER)) for b in itertools.product((0, 1), repeat=7)][::9]
    for params in samples:
        f = solve_modes(fe, params, 3).frequency_hz
        assert np.all(f > bounds[:, 0]) and np.all(f < bounds[:, 1]), (params, f, bounds)


def test_upper_bound_is_the_stiff_light_rigid_contact_model(reference_assembly):
    """Tied contact with modulus factor 1.10 and density factor 0.95 (frequency ∝ sqrt(E/ρ) on the holder part)."""
    fe = build_model(reference_assembly)
    tied = solve_modes(rigid_contact_model(fe), NOMINAL, 3).frequency_hz
    upper = bending_bounds(reference_assembly, fe=fe)[:, 1]
    assert np.all(upper > tied) and np.all(upper < tied * np.sqrt(1.10 / 0.95))
