"""The binding mesh-convergence requirement (docs/physics.md §1).

At the default mesh, halving every element must change f1–f3 by less than 0.05 % and ζ1
by less than 1 %, on every assembly of the suite and across the search space of docs/physics.md §2
(including its stiff, soft and lossy corners): the holder parameters are properties of
the holder, not of a mesh.
"""

import itertools
from pathlib import Path

import numpy as np
import pytest

from taptune.io.assembly import load_assembly
from taptune.model.fe import build_model
from taptune.model.modes import solve_modes
from taptune.model.options import ModelOptions
from taptune.model.params import NOMINAL, P_LOWER, P_UPPER, HolderParams, from_p

REPO = Path(__file__).resolve().parents[2]
ASSETS = sorted((REPO / "assets").glob("*.toml"))
HOLDER_A = HolderParams(1.90e9, 9.37e3, 1.98e-3, 8.20e-3, -10.0, 7478 / 7800, 1.0)


def corner(bits) -> HolderParams:
    """A corner of the search space (docs/physics.md §2): bit 1 = upper bound of that p."""
    return from_p(np.where(np.asarray(bits) == 1, P_UPPER, P_LOWER))


# Published holder A, the nominal set, and corners that stress the mesh most:
# stiffest and lossiest contact, softest contact, and the mixed corners where a soft
# translational layer meets a stiff, lossy rotational one (slowest convergence seen).
PARAMS = {
    "holder_A": HOLDER_A,
    "nominal": NOMINAL,
    "stiff_lossy": corner((1, 1, 1, 1, 1, 0, 1)),
    "stiff_lossless_negative_slope": corner((1, 1, 0, 0, 0, 1, 0)),
    "soft": corner((0, 0, 0, 0, 0, 1, 0)),
    "soft_t_stiff_r_lossy": corner((0, 1, 1, 0, 0, 0, 1)),
    "soft_t_stiff_lossy_r": corner((0, 1, 0, 1, 0, 1, 1)),
    "stiff_t_soft_r": corner((1, 0, 1, 0, 1, 1, 0)),
}


def convergence(fe, fe_half, params):
    """(relative change of f1–f3, relative change of ζ1) when every element is halved."""
    m, h = solve_modes(fe, params, 3), solve_modes(fe_half, params, 3)
    df = np.abs(m.frequency_hz / h.frequency_hz - 1)
    dz = abs(m.damping_ratio[0] / h.damping_ratio[0] - 1)
    return df, dz


@pytest.fixture(scope="module", params=[p.name for p in ASSETS])
def models(request):
    asm = load_assembly(REPO / "assets" / request.param)
    return build_model(asm), build_model(asm, ModelOptions(mesh_scale=0.5))


def test_assets_cover_the_three_holder_types_and_several_tool_diameters():
    names = " ".join(p.name for p in ASSETS)
    assert all(kind in names for kind in ("er32", "shrinkfit", "hydraulic"))
    assert len(ASSETS) >= 4


@pytest.mark.parametrize("name", list(PARAMS))
def test_halving_every_element_changes_f1_f3_by_under_0_05_percent_and_zeta1_by_under_1_percent(models, name):
    """Mesh convergence on the bundled assemblies (ER32 Ø16 and Ø6, shrink-fit Ø12, hydraulic Ø20)."""
    df, dz = convergence(*models, PARAMS[name])
    assert np.all(df < 5e-4), df
    assert dz < 1e-2, dz


def test_the_default_mesh_stays_small_and_converged(reference_assembly):
    """A few hundred DOFs for the reference assembly, and the converged value within 0.05 % of the converged values of two independent implementations."""
    fe = build_model(reference_assembly)
    assert fe.n_dofs < 500
    assert solve_modes(fe, HOLDER_A, 1).frequency_hz[0] == pytest.approx(4685.8, rel=5e-4)


@pytest.mark.slow
def test_every_corner_of_the_search_space_converges_on_every_asset(models):
    """Mesh convergence at all 128 corners of the search space (slow: ~2 s per assembly)."""
    for bits in itertools.product((0, 1), repeat=7):
        df, dz = convergence(*models, corner(bits))
        assert np.all(df < 5e-4) and dz < 1e-2, (bits, df, dz)
