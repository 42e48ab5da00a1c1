"""Synthetic tap recordings of an assembly: the model's tip receptance plus the workshop.

Used by the tests (audio is generated, never committed), the example recordings in
``recordings/`` (``scripts/make_recordings.py``) and the benchmarks. It sits above
``model`` and ``signal`` and below every front end.
"""

from __future__ import annotations

import numpy as np

from taptune.signal.synth import Nuisances, synthesize_recording, tap_grid

# Local modes of an HSK-A63 interface (docs/tap-test.md): near 9.7 and 10.2 kHz, often
# louder than the bending peaks. (f_hz, zeta, peak relative to the loudest bending peak)
HSK_A63_LOCAL_MODES = ((9700.0, 0.0015, 1.5), (10200.0, 0.0018, 0.8))


def simulate_tap_recording(
    assembly,
    params,
    nuisances: Nuisances = Nuisances(),
    rng: np.random.Generator | None = None,
    *,
    extra_modes=HSK_A63_LOCAL_MODES,
    path: str = "",
    model_options=None,
):
    """A tap :class:`~taptune.io.audio.Recording` of ``assembly`` with holder ``params``.

    Parameters
    ----------
    assembly : Assembly
    params : HolderParams
        The true holder parameters.
    nuisances : Nuisances
        Sample rate, taps, noise, hum, microphone, reflections, clipping … (signal.synth).
    rng : numpy.random.Generator
        Required when there is noise or hum.
    extra_modes : sequence of (f_hz, zeta, rel_peak)
        Peaks that are not bending modes (interface local modes, axial modes …).
    """
    from taptune.model import ModelOptions, build_model, tip_receptance

    grid = tap_grid(nuisances.sample_rate)
    fe = build_model(assembly, model_options or ModelOptions())
    h = np.zeros(grid.shape, dtype=complex)
    # H is undefined at 0 Hz (rigid-body terms); the microphone's high-pass removes it anyway.
    h[1:] = tip_receptance(fe, params, grid[1:])
    return synthesize_recording(grid, h, nuisances, rng, extra_modes=extra_modes, path=path)


def write_tap_recording(path, assembly, params, seed: int = 0, subtype: str = "PCM_24", **nuisance_settings) -> str:
    """Write a synthetic tap recording of ``assembly`` to ``path`` (WAV/FLAC); returns the path.

    ``nuisance_settings`` override fields of :class:`Nuisances`; ``extra_modes`` is passed on.
    """
    from taptune.io.audio import write_audio

    extra = nuisance_settings.pop("extra_modes", HSK_A63_LOCAL_MODES)
    nuisances = Nuisances(**nuisance_settings)
    rec = simulate_tap_recording(assembly, params, nuisances, np.random.default_rng(seed), extra_modes=extra, path=str(path))
    write_audio(str(path), rec.samples, rec.sample_rate, subtype)
    return str(path)
