"""The numpy peak finder agrees with scipy.signal.find_peaks (the definition it reproduces)."""

import numpy as np
import pytest
from scipy.signal import find_peaks as scipy_find_peaks

from taptune.signal.peaks import find_peaks


def _signals():
    rng = np.random.default_rng(5)
    yield rng.standard_normal(2000)  # noise: many small peaks
    yield np.round(rng.standard_normal(3000) * 3)  # quantised: flat runs and ties everywhere
    f = np.arange(0, 20000.0, 0.5)
    mag = sum(a / np.abs(f0**2 - f**2 + 2j * 0.01 * f0 * f) for f0, a in ((4800, 1.0), (9700, 0.2), (13100, 0.5)))
    yield 20 * np.log10(mag * (1 + 0.05 * rng.standard_normal(f.size)))  # a tap spectrum in dB
    yield np.array([1.0, 3, 3, 3, 1, 2, 2, 5, 5])  # plateaus, one running to the end
    yield np.array([2.0, 1.0])
    yield np.zeros(0)


@pytest.mark.parametrize("k", range(6))
@pytest.mark.parametrize("prominence", [None, 0.0, 1.5, 6.0])
def test_peaks_and_prominences_match_scipy(k, prominence):
    x = list(_signals())[k]
    ours, props = find_peaks(x, prominence=prominence)
    theirs, tprops = scipy_find_peaks(x, prominence=prominence)
    np.testing.assert_array_equal(ours, theirs)
    if prominence is not None:
        np.testing.assert_allclose(props["prominences"], tprops["prominences"], rtol=0, atol=1e-12)


def test_importing_the_signal_layer_does_not_load_scipy_signal():
    import subprocess
    import sys

    code = "import sys, taptune.signal.analysis, taptune.signal.synth; print('scipy.signal' in sys.modules)"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.strip() == "False"
