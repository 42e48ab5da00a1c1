"""Taps, spectra, peaks, labels and tap-sound synthesis: pure functions on arrays.

The front ends need one call, :func:`analyse_recording`; the pieces are importable from
their modules (``taps``, ``spectrum``, ``peaks``, ``labels``, ``synth``).
"""

from taptune.signal.analysis import SpectrumAnalysis, SpectrumOptions, analyse_recording
from taptune.signal.peaks import Peak
from taptune.signal.taps import Tap

__all__ = ["Peak", "SpectrumAnalysis", "SpectrumOptions", "Tap", "analyse_recording"]
