"""Fixtures for the GUI tests: a generated tap recording with its assembly, a temporary library.

The recording is made from the model itself: the first three bending modes of the
reference assembly (the example of docs/assembly-format.md) with holder A's published
parameters (CIRP J. Manuf. Sci. Technol. 37, 2022) ring down after each tap, on a low noise floor,
as a microphone would hear a tool-tip tap.
"""

from __future__ import annotations

import gc

import numpy as np
import pytest

# Holder A, published identified values (CIRP J. Manuf. Sci. Technol. 37 (2022)).
HOLDER_A = dict(k_tt=1.90e9, k_rr=9.37e3, eta_tt=1.98e-3, eta_rr=8.20e-3, alpha=-10.0,
                density_factor=7478 / 7800, modulus_factor=1.0)
FS = 48000


def tap_sound(frequencies_hz, damping, amplitudes, onsets_s, seconds, fs=FS, noise=2e-4, seed=1):
    """Decaying sines (one per mode) starting at each onset, on white noise; shape (n,)."""
    rng = np.random.default_rng(seed)
    x = noise * rng.standard_normal(int(seconds * fs))
    t = np.arange(int(0.5 * fs)) / fs
    ring = np.zeros_like(t)
    for f, z, a in zip(frequencies_hz, damping, amplitudes):
        w = 2 * np.pi * f
        ring += a * np.exp(-z * w * t) * np.sin(w * np.sqrt(1 - z * z) * t)
    for k, t0 in enumerate(onsets_s):
        i = int(t0 * fs)
        n = min(ring.size, x.size - i)
        x[i:i + n] += (0.8 + 0.1 * k % 3) * ring[:n]
    return 0.5 * x / np.max(np.abs(x))


def write_recording(folder, stickout_mm: float, seed: int = 1, contact_factor: float = 1.0):
    """A 5-tap WAV of the reference assembly (holder A) at ``stickout_mm`` and its sidecar assembly file.

    ``contact_factor`` scales both contact stiffnesses (a worn or badly seated holder).
    Returns ``(wav, toml, (f1, f2, f3) [Hz])``.
    """
    import soundfile

    from taptune.io.assembly import load_assembly
    from taptune.model import build_model, solve_modes
    from taptune.model.params import HolderParams
    from tests.conftest import REFERENCE_TOML

    toml = folder / f"er32_d16_{stickout_mm:g}mm.toml"
    toml.write_text(REFERENCE_TOML.replace("stickout = 53.5", f"stickout = {stickout_mm:g}"))
    assembly = load_assembly(toml)
    params = HolderParams(**{**HOLDER_A, "k_tt": contact_factor * HOLDER_A["k_tt"],
                             "k_rr": contact_factor * HOLDER_A["k_rr"]})
    modes = solve_modes(build_model(assembly), params, n_modes=3)
    x = tap_sound(modes.frequency_hz[:3], modes.damping_ratio[:3], (1.0, 0.5, 0.35),
                  onsets_s=(0.3, 1.0, 1.7, 2.4, 3.1), seconds=3.8, seed=seed)
    wav = toml.with_suffix(".wav")
    soundfile.write(wav, x, FS, subtype="PCM_24")
    return wav, toml, tuple(float(f) for f in modes.frequency_hz[:3])


@pytest.fixture(scope="session")
def generated_recording(tmp_path_factory):
    """A 5-tap WAV of the reference assembly (holder A) at 53.5 mm and its sidecar assembly file."""
    return write_recording(tmp_path_factory.mktemp("recordings"), 53.5)


@pytest.fixture(scope="session")
def second_recording(tmp_path_factory):
    """The same holder and tool tapped at 63.5 mm (another folder: its own sidecar file)."""
    return write_recording(tmp_path_factory.mktemp("recordings2"), 63.5, seed=2)


@pytest.fixture
def library_path(tmp_path, monkeypatch):
    """An empty temporary holder library (and TAPTUNE_LIBRARY pointing at it)."""
    path = tmp_path / "library" / "holders.json"
    monkeypatch.setenv("TAPTUNE_LIBRARY", str(path))
    return path


@pytest.fixture
def fast_identify_options():
    """A small optimiser budget: the GUI path is tested, not the optimiser's accuracy."""
    from taptune.identify import GAOptions, IdentifyOptions

    return IdentifyOptions(seed=0, jobs=1, islands=1, ga=GAOptions(population=24, generations=10, patience=5),
                           polish_evaluations=60)


@pytest.fixture(autouse=True, scope="session")
def _own_settings(tmp_path_factory):
    """Every QSettings() of the tests lives in a temporary folder: the user's remembered
    machine file is neither read nor overwritten."""
    from PySide6.QtCore import QSettings

    QSettings.setPath(QSettings.IniFormat, QSettings.UserScope, str(tmp_path_factory.mktemp("settings")))


@pytest.fixture(autouse=True)
def _clear_messages():
    from taptune.gui import messages

    messages.history.clear()
    yield
    messages.history.clear()


@pytest.fixture
def settings(tmp_path):
    """Settings in a temporary INI file (the user's own are never touched)."""
    from PySide6.QtCore import QSettings

    return QSettings(str(tmp_path / "settings.ini"), QSettings.IniFormat)


@pytest.fixture
def window(qtbot, library_path, fast_identify_options, settings):
    """The real main window at laptop size, with no audio device."""
    from taptune.gui.main_window import MainWindow

    win = MainWindow(library_path, identify_options=fast_identify_options, devices=lambda: [], settings=settings)
    qtbot.addWidget(win)
    win.resize(1366, 768)
    win.show()
    yield win
    win.close()
    delete_now(win)


def delete_now(widget) -> None:
    """Delete a closed window now, on the GUI thread, and collect the garbage it leaves.

    Otherwise pytest-qt's ``deleteLater`` is carried out by the next test's event loop
    (while that test's worker thread runs), and Qt objects that only Python cycles hold
    (settings, event loops, timers) are deleted by whichever thread next collects
    garbage — the analysis worker threads do.
    """
    from PySide6.QtCore import QCoreApplication, QEvent

    widget.deleteLater()
    QCoreApplication.sendPostedEvents(None, QEvent.DeferredDelete)
    gc.collect()
