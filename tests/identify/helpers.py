"""Test helpers: spectra made from the model itself, and a full-model evaluator."""

from __future__ import annotations

from dataclasses import dataclass
from types import SimpleNamespace

import numpy as np

from taptune.model import build_model, solve_modes, tip_receptance
from taptune.model.params import from_p


@dataclass(frozen=True)
class FullEvaluation:
    bending_hz: np.ndarray
    damping_ratio: np.ndarray
    tip_receptance: np.ndarray


class FullModelEvaluator:
    """The converged model behind the optimiser's evaluator interface (slow; reference only)."""

    def __init__(self, assembly, options=None):
        self.fe = build_model(assembly) if options is None else build_model(assembly, options)

    def evaluate(self, p, window_hz):
        params = from_p(p)
        modes = solve_modes(self.fe, params, n_modes=3)
        return FullEvaluation(
            np.asarray(modes.frequency_hz[:3]),
            np.asarray(modes.damping_ratio[:3]),
            tip_receptance(self.fe, params, window_hz),
        )


def model_analysis(assembly, params, df_hz=0.5, f_max_hz=22000.0, path="model.wav"):
    """A noise-free 'measured' analysis: |H_tip| of the model and its bending peaks."""
    fe = build_model(assembly)
    freq = np.arange(df_hz, f_max_hz, df_hz)
    mag = np.abs(tip_receptance(fe, params, freq))
    modes = solve_modes(fe, params, n_modes=3)
    peaks = [
        SimpleNamespace(hz=float(f), level_db=0.0, kind="bending", mode=n + 1)
        for n, f in enumerate(modes.frequency_hz[:3])
    ]
    return SimpleNamespace(freq_hz=freq, magnitude=mag, peaks=peaks, path=path, excluded_bands_hz=())
