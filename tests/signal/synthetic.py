"""Synthetic tap recordings with known truth, shared by the signal and CLI tests."""

from dataclasses import replace

import numpy as np

from taptune.signal.synth import Nuisances, modal_receptance, synthesize_recording, tap_grid

#: Three bending modes of a typical HSK-A63 assembly: (f [Hz], ζ, relative peak height).
BENDING = ((3520.0, 0.004, 1.0), (10950.0, 0.002, 0.6), (15300.0, 0.003, 0.8))
#: An interface local mode (louder than the bending peaks) and an axial/torsional mode.
LOCAL = ((9710.0, 0.0016, 2.0),)
SPURIOUS = ((16650.0, 0.0025, 0.6),)
WORKSHOP = Nuisances(sample_rate=48000, duration_s=2.0, tap_times_s=(0.2, 0.75, 1.3),
                     tap_strengths=(1.0, 0.7, 0.85), snr_db=45.0, mic_hp_hz=110.0,
                     mic_lp_hz=15500.0, reflections=((0.7e-3, 0.25), (8.0e-3, 0.05)),
                     hum_hz=50.0, hum_harmonics=4, hum_rel_db=-30.0)


def receptance(freq_hz, modes=BENDING):
    """Modal receptance whose radiated peaks (tilt f¹) have the given relative heights."""
    # Peak |H| of one mode is r / (ω² · 2ζ); times f for the radiation tilt.
    return modal_receptance(freq_hz, [(f, z, h * (2 * np.pi * f) ** 2 * 2 * z / f) for f, z, h in modes])


def workshop_recording(seed=0, modes=BENDING, extra=LOCAL + SPURIOUS, **changes):
    """A recording of ``modes`` plus ``extra`` peaks with the WORKSHOP nuisances (changed)."""
    nu = replace(WORKSHOP, **changes)
    grid = tap_grid(nu.sample_rate)
    return synthesize_recording(grid, receptance(grid, modes), nu, np.random.default_rng(seed),
                                extra_modes=extra)


def expected_and_bounds(modes=BENDING, shift=(1.06, 1.02, 1.05)):
    """Model guidance a few % off the truth (as nominal parameters are) and wide bounds."""
    f = np.array([m[0] for m in modes]) * np.array(shift)
    return f, np.column_stack([0.3 * f, 1.12 * f])
