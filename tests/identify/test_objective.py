"""The objective of docs/physics.md §4: frequency terms plus the normalised shape in the mode-1 window."""

import numpy as np
import pytest

from taptune.errors import InputError
from taptune.identify.objective import Objective, ObjectiveOptions, make_target, model_shape, objective_terms


def resonance(f, fn=5000.0, zeta=0.004):
    """Single-mode hysteretic receptance [m/N] of a 1 kg, fn Hz oscillator."""
    w, wn = 2 * np.pi * f, 2 * np.pi * fn
    return 1.0 / (wn**2 * (1 + 2j * zeta) - w**2)


FREQ = np.arange(0.5, 20000.0, 0.5)


def test_window_is_200_points_of_1_hz_centred_on_measured_f1():
    t = make_target(FREQ, np.abs(resonance(FREQ)), {1: 5000.3, 2: 12000.0, 3: 17000.0})
    assert len(t.window_hz) == 201
    assert t.window_hz[0] == pytest.approx(4900.3) and t.window_hz[-1] == pytest.approx(5100.3)
    assert np.allclose(np.diff(t.window_hz), 1.0)
    assert t.shape.max() == pytest.approx(1.0)


def test_perfect_model_gives_zero_and_gain_does_not_matter():
    bending = {1: 5000.0, 2: 12000.0, 3: 17000.0}
    opts = ObjectiveOptions()
    # Unknown tap force and microphone gain: the measured curve is the receptance × 1e9.
    t = make_target(FREQ, 1e9 * np.abs(resonance(FREQ)), bending, opts)
    f_term, s_term = objective_terms(t, np.array([5000.0, 12000.0, 17000.0]), resonance(t.window_hz), opts)
    assert f_term == 0.0
    assert s_term < 1e-6  # interpolation of the 0.5 Hz grid onto the 1 Hz window only


def test_frequency_term_counts_tolerances_squared():
    t = make_target(FREQ, np.abs(resonance(FREQ)), {1: 5000.0, 2: 12000.0, 3: 17000.0})
    # f1 off by exactly one tolerance (0.5 %), the others exact: the term is 1.
    f_term, _ = objective_terms(t, np.array([5025.0, 12000.0, 17000.0]), resonance(t.window_hz), ObjectiveOptions())
    assert f_term == pytest.approx(1.0)


def test_wrong_damping_raises_the_shape_term():
    opts = ObjectiveOptions()
    t = make_target(FREQ, np.abs(resonance(FREQ, zeta=0.004)), {1: 5000.0}, opts)
    _, right = objective_terms(t, np.array([5000.0, 1, 1]), resonance(t.window_hz, zeta=0.004), opts)
    _, wrong = objective_terms(t, np.array([5000.0, 1, 1]), resonance(t.window_hz, zeta=0.008), opts)
    assert wrong > 100 * max(right, 1e-6)


def test_accelerance_and_db_variants_are_normalised_too():
    for opts in (ObjectiveOptions(quantity="accelerance"), ObjectiveOptions(compare="db")):
        w = np.arange(4900.0, 5101.0)
        shape = model_shape(w, resonance(w), opts)
        assert shape.max() == pytest.approx(0.0 if opts.compare == "db" else 1.0)


def test_fewer_than_three_modes_warns_and_fits_the_ones_found():
    t = make_target(FREQ, np.abs(resonance(FREQ)), {1: 5000.0, 3: 17000.0}, label="tap.wav")
    assert t.modes == (1, 3)
    assert any("mode(s) 2 not found" in w for w in t.warnings)


@pytest.mark.parametrize(
    "bending, message",
    [({}, "no bending peak"), ({2: 12000.0}, "first bending mode was not found"), ({1: 19950.0}, "does not cover")],
)
def test_unusable_measurements_are_clear_errors(bending, message):
    with pytest.raises(InputError, match=message):
        make_target(FREQ, np.abs(resonance(FREQ)), bending, label="tap.wav")


def test_bad_options_are_rejected():
    with pytest.raises(InputError):
        ObjectiveOptions(compare="log")
    with pytest.raises(InputError):
        ObjectiveOptions(sigma_f=0)


def test_objective_sums_recordings_and_counts_evaluations():
    class Fixed:
        def __init__(self, fn):
            self.fn = fn

        def evaluate(self, p, window_hz):
            from types import SimpleNamespace

            return SimpleNamespace(bending_hz=np.array([self.fn, 12000, 17000.0]), tip_receptance=resonance(window_hz, self.fn))

    t = make_target(FREQ, np.abs(resonance(FREQ)), {1: 5000.0, 2: 12000.0, 3: 17000.0})
    obj = Objective([t, t], [Fixed(5000.0), Fixed(5025.0)])
    value = obj(np.zeros(7))
    assert obj.evaluations == 1
    # Second recording: one tolerance off in f1 (term 1) plus a shifted peak in the window.
    assert value > 1.0
    assert obj.batch(np.zeros((3, 7))).shape == (3,)
    assert obj.evaluations == 4


def test_residuals_square_to_the_objective_and_fill_the_memo():
    class Shifted:
        def __init__(self, fn):
            self.fn = fn

        def evaluate(self, p, window_hz):
            from types import SimpleNamespace

            fn = self.fn * (1 + p[0])
            return SimpleNamespace(bending_hz=np.array([fn, 12000, 17000.0]), tip_receptance=resonance(window_hz, fn))

    t = make_target(FREQ, np.abs(resonance(FREQ)), {1: 5000.0, 2: 12000.0, 3: 17000.0})
    t2 = make_target(FREQ, np.abs(resonance(FREQ)), {1: 5000.0, 3: 17000.0})
    p = np.array([0.002, 0, 0, 0, 0, 0, 0])
    fresh = Objective([t, t2], [Shifted(5000.0), Shifted(5010.0)])
    r = fresh.residuals(p)
    assert r.shape == (3 + 201 + 2 + 201,)
    assert fresh.evaluations == 1 and fresh.known(p)
    expected = Objective([t, t2], [Shifted(5000.0), Shifted(5010.0)])
    assert float(r @ r) == pytest.approx(expected(p), rel=1e-12)
    np.testing.assert_allclose(fresh.summed_terms(p), expected.summed_terms(p), rtol=1e-12)
