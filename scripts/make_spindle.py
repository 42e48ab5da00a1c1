"""Make the bundled example machine in recordings/machine/ (synthetic, from a small FE model).

A simple HSK-A63 motor spindle: a stepped hollow steel shaft (Timoshenko elements of
taptune.model.elements) on three lossy bearing springs k (1 + i η) — a front pair near
the nose, one rear bearing. The coupling plane is the shaft's front end (z = 0, where the
holder's flange meets the spindle nose); z runs from the spindle toward the tool, θ = dw/dz,
as in the machine files. The 2×2 receptance [h_wf, h_wm; h_θf, h_θm] at that node is
computed by direct solution of (K − ω² M) u = f on a logarithmic grid (50 Hz – 15 kHz),
for x and for y (the y bearings 5 % stiffer, as with an uneven preload).

Writes recordings/machine/machine.toml, spindle_x.csv, spindle_y.csv, and
recordings/er32_d16.params.json (the true holder parameters of the er32_d16 example, in
the form ``--params`` reads) so that ``taptune toolpoint`` / ``lobes`` run on a fresh
checkout. Run: ``python scripts/make_spindle.py`` (deterministic).
"""

from __future__ import annotations

import json
import os
import sys
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

import numpy as np  # noqa: E402
import scipy.linalg as la  # noqa: E402

from taptune.io.machine import SpindleReceptance, write_spindle_csv  # noqa: E402
from taptune.model.elements import BeamElements  # noqa: E402
from taptune.model.fe import element_dofs, scatter  # noqa: E402

OUT = REPO / "recordings" / "machine"
MM = 1e-3
# Shaft segments from the rear end to the nose: (length, od, id) [mm]. The last one is the
# nose with the HSK-A63 receptacle and the holder's taper shank clamped in it.
SEGMENTS = [(110.0, 55.0, 20.0), (190.0, 70.0, 20.0), (85.0, 80.0, 30.0), (32.0, 95.0, 24.0)]
STEEL = {"density": 7850.0, "youngs_modulus": 210e9, "poisson": 0.29, "loss_factor": 0.03}  # rotor, sleeves and joints: a lossy shaft
# Bearings: (distance behind the nose [mm], stiffness [N/m], loss factor).
BEARINGS = [(45.0, 3.0e8, 0.15), (75.0, 3.0e8, 0.15), (385.0, 1.2e8, 0.15)]
Y_STIFFNESS_FACTOR = 1.05
F_MIN_HZ, F_MAX_HZ, N_FREQ = 50.0, 15000.0, 1100
H_MAX_MM = 5.0


def shaft_nodes() -> np.ndarray:
    """Node positions [m], z = 0 at the nose, negative toward the rear; nodes at every step and bearing."""
    length = sum(s[0] for s in SEGMENTS)
    points = {0.0, -length} | {-b[0] for b in BEARINGS}
    z = -length
    for seg in SEGMENTS:
        z += seg[0]
        points.add(round(z, 9))
    points = np.array(sorted(points))
    nodes = [points[0]]
    for a, b in zip(points[:-1], points[1:]):
        n = int(np.ceil((b - a) / H_MAX_MM - 1e-9))
        nodes += list(a + (b - a) * np.arange(1, n + 1) / n)
    return np.array(nodes) * MM


def shaft_matrices(z: np.ndarray, bearing_factor: float) -> tuple[np.ndarray, np.ndarray]:
    """Complex stiffness and real mass of the shaft on its bearings (dense; ~170 DOFs)."""
    mid = 0.5 * (z[:-1] + z[1:]) / MM
    length = sum(s[0] for s in SEGMENTS)
    ends = -length + np.cumsum([s[0] for s in SEGMENTS])
    seg = np.minimum(np.searchsorted(ends, mid), len(SEGMENTS) - 1)
    od = np.array([SEGMENTS[i][1] for i in seg]) * MM
    id_ = np.array([SEGMENTS[i][2] for i in seg]) * MM
    beams = BeamElements(z=z, od=od, id=id_, **STEEL)
    dofs = element_dofs(beams.n_elements, 0)
    n = 2 * len(z)
    K = scatter(beams.K(), dofs, n).toarray()
    M = scatter(beams.M(), dofs, n).toarray().real
    for at_mm, k, eta in BEARINGS:
        node = int(np.argmin(np.abs(z / MM + at_mm)))
        K[2 * node, 2 * node] += bearing_factor * k * (1 + 1j * eta)
    return K, M


def nose_receptance(freq_hz: np.ndarray, bearing_factor: float) -> np.ndarray:
    """[[w/f, w/m], [θ/f, θ/m]] at the nose node, shape (n, 2, 2), by direct solution."""
    z = shaft_nodes()
    K, M = shaft_matrices(z, bearing_factor)
    nose = 2 * (len(z) - 1)
    rhs = np.zeros((K.shape[0], 2))
    rhs[nose, 0] = 1.0  # unit force
    rhs[nose + 1, 1] = 1.0  # unit moment
    h = np.empty((len(freq_hz), 2, 2), dtype=complex)
    for i, f in enumerate(freq_hz):
        u = la.solve(K - (2 * np.pi * f) ** 2 * M, rhs, assume_a="sym")
        h[i] = u[nose:nose + 2, :]
    return h


def modes(bearing_factor: float) -> list[tuple[float, float]]:
    """(frequency [Hz], damping ratio) of the shaft's first modes, for the record."""
    K, M = shaft_matrices(shaft_nodes(), bearing_factor)
    lam = la.eigvals(K, M)
    lam = lam[np.argsort(lam.real)][:4]
    return [(float(np.sqrt(v.real) / (2 * np.pi)), float(v.imag / v.real / 2)) for v in lam]


def main() -> None:
    OUT.mkdir(parents=True, exist_ok=True)
    freq = np.geomspace(F_MIN_HZ, F_MAX_HZ, N_FREQ)
    for direction, factor in (("x", 1.0), ("y", Y_STIFFNESS_FACTOR)):
        h = nose_receptance(freq, factor)
        shown = ", ".join(f"{f:.0f} Hz ζ {100 * z:.1f} %" for f, z in modes(factor))
        comments = [
            "SYNTHETIC example spindle made by scripts/make_spindle.py (not a measurement)",
            f"direction {direction}: stepped steel shaft on bearing springs x {factor:g}; modes {shown}",
            "receptance at the coupling plane (spindle nose): m/N, 1/N, rad/(N m); theta = dw/dz, z toward the tool",
        ]
        path = OUT / f"spindle_{direction}.csv"
        write_spindle_csv(path, SpindleReceptance(freq, h, str(path)), comments)
        print(f"{path.relative_to(REPO)}: {path.stat().st_size / 1e3:.0f} kB; modes {shown}")
    (OUT / "machine.toml").write_text(
        "# SYNTHETIC example machine (scripts/make_spindle.py): an HSK-A63 spindle modelled as a\n"
        "# stepped shaft on three lossy bearings. Not a measurement of a real machine.\n"
        "[machine]\n"
        'name = "Example HSK-A63 spindle (synthetic)"\n'
        'interface = "HSK-A63"\n'
        "max_rpm = 24000        # top speed: the default top of the lobe diagram\n\n"
        "[spindle]\n"
        'x = "spindle_x.csv"   # relative to this file\n'
        'y = "spindle_y.csv"\n',
        encoding="utf-8",
    )
    truth = json.loads((REPO / "recordings" / "er32_d16.truth.json").read_text(encoding="utf-8"))
    params = REPO / "recordings" / "er32_d16.params.json"
    params.write_text(json.dumps(truth["true_params"], indent=1) + "\n", encoding="utf-8")
    print(f"{(OUT / 'machine.toml').relative_to(REPO)}, {params.relative_to(REPO)}")


if __name__ == "__main__":
    main()
