"""Speed and accuracy of the machine stage, one core.

Run: ``OPENBLAS_NUM_THREADS=1 python benchmarks/bench_machine.py [--repeat N]``.
On the reference assembly (assets/er32_hsk63_d16.toml, the published holder A) on a synthetic spindle prints
CPU seconds (``time.process_time``, medians of ``--repeat`` runs after one warm-up
that pays the imports):

* the receptance blocks of the cut model on 5,000 frequencies by both routes of
  :mod:`taptune.machine.blocks` (modal superposition, banded direct solve) and their
  largest difference;
* one tool-point FRF (:func:`taptune.machine.toolpoint_frf`, model build included) on
  5,000 frequencies;
* zero-order lobes on 2,000 speeds from that FRF (:func:`taptune.machine.stability_lobes`),
  3,000–30,000 rpm (typical) and 500–24,000 rpm (wide: many lobes);
* the inverse RCSA of a dummy holder on 5,000 frequencies, noise-free and with 1 % noise
  (common-pole rational fit first).
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

import numpy as np  # noqa: E402

from taptune.io.assembly import Holder, Segment, assembly_from_toml  # noqa: E402
from taptune.io.machine import SpindleReceptance  # noqa: E402
from taptune.machine import (couple, cut_assembly, receptance_blocks, spindle_from_dummy,  # noqa: E402
                             stability_lobes, toolpoint_frf)
from taptune.machine.blocks import point_receptance  # noqa: E402
from taptune.machine.dummy import _NOMINAL, dummy_model  # noqa: E402
from taptune.model.fe import build_model  # noqa: E402
from taptune.model.params import HolderParams  # noqa: E402
from tests.conftest import REFERENCE_TOML  # noqa: E402
from tests.machine.cases import lumped_spindle  # noqa: E402

HOLDER_A = HolderParams(k_tt=1.90e9, k_rr=9.37e3, eta_tt=1.98e-3, eta_rr=8.20e-3, alpha=-10.0,
                        density_factor=7478 / 7800, modulus_factor=1.0)
MM = 1e-3


def cpu(fn, repeat: int):
    """(median CPU s, result) of ``repeat`` calls after one warm-up."""
    out = fn()
    times = []
    for _ in range(repeat):
        t = time.process_time()
        out = fn()
        times.append(time.process_time() - t)
    return float(np.median(times)), out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args(argv)
    asm = assembly_from_toml(REFERENCE_TOML, "reference")
    f = np.linspace(200.0, 10000.0, 5000)
    fe = build_model(cut_assembly(asm))
    print(f"cut model: {fe.n_dofs} DOFs, {fe.n_elements} elements")

    t_modal, modal = cpu(lambda: receptance_blocks(fe, HOLDER_A, f, "modal"), args.repeat)
    t_direct, direct = cpu(lambda: receptance_blocks(fe, HOLDER_A, f, "direct"), 1)
    diff = np.max(np.abs(modal.h - direct.h) / np.abs(direct.h).max(axis=0))
    hs = lumped_spindle(f)
    g_m = couple(modal.h11, modal.h12, modal.h21, modal.h22, hs)[:, 0, 0]
    g_d = couple(direct.h11, direct.h12, direct.h21, direct.h22, hs)[:, 0, 0]
    print(f"blocks, 5,000 frequencies: modal {t_modal:.3f} CPU-s, direct {t_direct:.3f} CPU-s "
          f"({t_direct / t_modal:.0f}x); max |modal - direct| / max|H| = {diff:.1e}; "
          f"coupled G11 pointwise {np.max(np.abs(g_m - g_d) / np.abs(g_d)):.1e}")

    spindle = SpindleReceptance(f, hs, "lumped spindle")
    t_tp, tp = cpu(lambda: toolpoint_frf(asm, HOLDER_A, {"x": spindle}, f), args.repeat)
    print(f"tool-point FRF, 5,000 frequencies (build + modes + coupling + peaks): {t_tp:.3f} CPU-s; "
          f"dominant mode {tp.modes[0].hz:.1f} Hz, zeta {tp.modes[0].damping_ratio:.4f}")

    cut = dict(teeth=4, ktc=902e6, krc=243e6, diameter=16 * MM, ae=8 * MM, milling="down")
    for lo, hi in ((3000.0, 30000.0), (500.0, 24000.0)):
        rpm = np.linspace(lo, hi, 2000)
        t_lobes, lobes = cpu(lambda: stability_lobes(f, tp.xx, tp.yy, rpm=rpm, **cut), args.repeat)
        print(f"lobes, 2,000 speeds {lo:.0f}-{hi:.0f} rpm ({len(lobes.curves)} lobe curves): {t_lobes:.3f} CPU-s; "
              f"a_crit {lobes.a_crit / MM:.3f} mm, best pocket {lobes.pockets[0][0]:.0f} rpm / "
              f"{lobes.pockets[0][1] / MM:.2f} mm")

    dummy = Holder(name="dummy", interface="HSK-A63", clamp_length=1 * MM,
                   segments=(Segment(32 * MM, 48 * MM, 24 * MM), Segment(10 * MM, 63 * MM, 24 * MM),
                             Segment(90 * MM, 50 * MM, 0.0)))
    dfe, dofs = dummy_model(dummy, (0.0, 0.06))
    h = point_receptance(dfe, _NOMINAL, dofs, f)
    g = couple(h[:, :2, :2], h[:, :2, 2:], h[:, 2:, :2], h[:, 2:, 2:], hs)
    g = [g[:, 0, 0], g[:, 0, 1], g[:, 1, 1]]
    t_inv, (s, _) = cpu(lambda: spindle_from_dummy(dummy, 0.0, 0.06, f, *g), args.repeat)
    err = np.median(np.abs(s.h - hs) / np.abs(hs))
    rng = np.random.default_rng(0)
    noisy = [v * (1 + 0.01 * (rng.standard_normal(len(v)) + 1j * rng.standard_normal(len(v))) / np.sqrt(2)) for v in g]
    t_noisy, (sn, _) = cpu(lambda: spindle_from_dummy(dummy, 0.0, 0.06, f, *noisy), args.repeat)
    err_n = np.median(np.abs(sn.h - hs) / np.abs(hs))
    print(f"inverse RCSA, 5,000 frequencies: noise-free {t_inv:.3f} CPU-s (median error {err:.1e}); "
          f"1 % noise with rational fit {t_noisy:.3f} CPU-s (median error {err_n:.2%})")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
