"""The independent development case machine-d01 (../shared/cases-dev/machine-d01), read with numpy.

Tests that use it skip when the shared folder is absent (users' checkouts).
"""

from __future__ import annotations

import json

import numpy as np
import pytest

from taptune.io.machine import SpindleReceptance
from tests.conftest import REPO

D01 = REPO.parent / "shared" / "cases-dev" / "machine-d01"


def need_d01():
    if not D01.is_dir():
        pytest.skip("the shared development cases are not here")
    return D01


def columns(name: str) -> np.ndarray:
    return np.loadtxt(need_d01() / name, delimiter=",", skiprows=1, comments="#")


def spindle(name: str) -> SpindleReceptance:
    """A spindle receptance CSV (docs/machine.md columns) as SpindleReceptance."""
    d = columns(name)
    h = np.empty((len(d), 2, 2), dtype=complex)
    h[:, 0, 0] = d[:, 1] + 1j * d[:, 2]
    h[:, 0, 1] = h[:, 1, 0] = d[:, 3] + 1j * d[:, 4]
    h[:, 1, 1] = d[:, 5] + 1j * d[:, 6]
    return SpindleReceptance(d[:, 0], h, name)


def frf(name: str) -> tuple[np.ndarray, np.ndarray]:
    """(f_hz, G) of an ``f_hz,re,im`` CSV."""
    d = columns(name)
    return d[:, 0], d[:, 1] + 1j * d[:, 2]


def truth(name: str) -> dict:
    return json.loads((need_d01() / name).read_text())


def complex_of(d: dict) -> np.ndarray:
    return np.asarray(d["re"]) + 1j * np.asarray(d["im"])


def lumped_spindle(freq_hz):
    """A machine side with inertia and lossy, coupled springs: H_S = (K_s − ω² M_s)⁻¹, (n, 2, 2)."""
    k = np.array([[2.0e8, -4.0e6], [-4.0e6, 3.0e5]]) * (1 + 0.04j)
    m, e, j = 6.0, -0.03, 4.0e-3
    mass = np.array([[m, m * e], [m * e, j + m * e * e]])
    z = k[None] - (2 * np.pi * np.asarray(freq_hz))[:, None, None] ** 2 * mass[None]
    return np.linalg.inv(z)
