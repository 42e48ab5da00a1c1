"""The Machine view: tool-point FRF and lobes of a library holder, the stick-out slider, the machine file.

The machine is the bundled synthetic example (recordings/machine); the holder is holder A
(CIRP J. Manuf. Sci. Technol. 37 (2022)) with its published parameters (no identification needed).
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from taptune.gui import messages

MACHINE = Path(__file__).resolve().parents[2] / "recordings" / "machine" / "machine.toml"


@pytest.fixture
def holder_a(library_path, reference_assembly):
    from taptune.library import HolderEntry, HolderLibrary
    from taptune.model.params import HolderParams

    from tests.gui.conftest import HOLDER_A

    entry = HolderEntry.create(reference_assembly.holder, HolderParams(**HOLDER_A))
    HolderLibrary(library_path).put(entry)
    return HolderLibrary(library_path).get(entry.name)


def _show_on_machine(qtbot, window, reference_assembly):
    window.library_view.refresh()
    window.assembly_panel.set_assembly(reference_assembly)
    assert window.machine.load_machine(str(MACHINE))
    with qtbot.waitSignal(window.machine.updated, timeout=30000) as blocker:
        window.library_view.buttons["machine"].click()
    return blocker.args[0]


def test_machine_view_draws_the_frf_and_lobes_as_the_cli_computes_them(qtbot, window, holder_a, reference_assembly,
                                                                     library_path, tmp_path, capsys):
    from taptune.cli import main

    stickout_mm, frf, lobes = _show_on_machine(qtbot, window, reference_assembly)
    view = window.machine
    assert window.tabs.currentWidget() is view
    assert stickout_mm == pytest.approx(53.5)
    ax_f, ax_l = view.canvas.figure.axes
    assert len(ax_f.lines) >= 2 and ax_l.collections  # |G| in x and y; the stable region
    # The tool's diameter and teeth came from the tool ("D16 4FL"), the cut is a quarter of it.
    assert (view.diameter.value(), view.teeth.value(), view.ae.value()) == (16.0, 4, 4.0)
    assert "Zero-order preview, central estimate: stable at every speed up to" in view.summary.text()

    # The CLI (2 Hz grid, 10 rpm steps) gives the same lobes to within the grid's effect.
    out = tmp_path / "lobes.json"
    c = view.cut()
    status = main(["lobes", str(MACHINE.parents[1] / "er32_d16.toml"), "--holder", holder_a.name,
                   "--library", str(library_path), "--machine", str(MACHINE), "--teeth", str(c.teeth),
                   "--ktc", f"{c.ktc_mpa:g}", "--krc", f"{c.krc_mpa:g}", "--ae", f"{c.ae_mm:g}", "--milling",
                   c.milling, "--rpm", f"{c.rpm_min:g}", f"{c.rpm_max:g}", "10", "--json", str(out),
                   "--method", "zoa"])  # the view's first picture is the zero-order preview
    capsys.readouterr()
    assert status == 0
    cli = json.loads(out.read_text())
    assert lobes.a_crit * 1e3 == pytest.approx(cli["a_crit_mm"], rel=2e-3)
    a_cli = np.array([np.inf if a is None else a for a in cli["a_lim_mm"]])
    np.testing.assert_allclose(np.interp(cli["rpm"], lobes.rpm, lobes.a_lim * 1e3), a_cli, rtol=0.02)


def test_the_slider_updates_frf_and_lobes(qtbot, window, holder_a, reference_assembly):
    _stickout, frf, lobes = _show_on_machine(qtbot, window, reference_assembly)
    view = window.machine
    with qtbot.waitSignal(view.updated, timeout=30000) as blocker:
        view.slider.setValue(635)  # 10 mm longer
    stickout_mm, frf_long, lobes_long = blocker.args[0]
    assert stickout_mm == pytest.approx(63.5) and view.spin.value() == pytest.approx(63.5)
    # A longer tool is more flexible: a larger tool-point peak and a smaller safe depth.
    assert np.abs(frf_long.xx).max() > 1.2 * np.abs(frf.xx).max()
    assert lobes_long.a_crit < 0.9 * lobes.a_crit
    assert "63.5 mm" in view.canvas.figure.axes[0].get_title(loc="left")
    # A burst of moves (a drag) ends on the last one, without queueing the others.
    with qtbot.waitSignal(view.updated, timeout=30000):
        for value in range(540, 601, 5):
            view.slider.setValue(value)
    qtbot.waitUntil(lambda: not view.busy, timeout=30000)
    assert view.result[0] == pytest.approx(60.0)


def test_a_bad_machine_file_changes_nothing(qtbot, window, holder_a, reference_assembly, tmp_path, settings):
    _show_on_machine(qtbot, window, reference_assembly)
    view = window.machine
    before = (view.machine, view.result, settings.value("machine/file"))
    bad = tmp_path / "bad.toml"
    bad.write_text('[machine]\nname = "broken"\ninterface = "HSK-A63"\n[spindle]\nx = "missing.csv"\n')
    assert not view.load_machine(str(bad))
    title, text = messages.history[-1]
    assert title == "Cannot use this machine file" and "missing.csv" in text and "unchanged" in text
    assert (view.machine, view.result, settings.value("machine/file")) == before
    assert "bad.toml" in view.machine_label.text()


def test_the_machine_file_is_remembered(qtbot, settings):
    from taptune.gui.machine_view import MachineView

    first = MachineView(settings)
    qtbot.addWidget(first)
    assert first.load_machine(str(MACHINE))
    again = MachineView(settings)
    qtbot.addWidget(again)
    assert again.machine is not None and again.machine.name == first.machine.name
    assert again.rpm_max.value() == 24000


def test_teeth_from_tool_names():
    from taptune.gui.machine_view import tool_teeth

    assert tool_teeth("solid carbide end mill D16 4FL") == 4
    assert tool_teeth("3-flute roughing") == 3
    assert tool_teeth("HSS Z2 slot drill") == 2
    assert tool_teeth("end mill D16") is None


def test_screenshot_of_the_machine_view(holder_a, library_path, tmp_path, reference_toml):
    from PySide6.QtGui import QImage

    from taptune.cli import main

    png = tmp_path / "machine.png"
    assert main(["gui", "--assembly", str(reference_toml), "--holder", holder_a.name, "--library", str(library_path),
                 "--machine", str(MACHINE), "--view", "machine", "--screenshot", str(png)]) == 0
    image = QImage(str(png))
    assert (image.width(), image.height()) == (1366, 768)


def test_the_machine_view_warns_of_another_interface_and_an_off_plane_gauge_length(qtbot, window, holder_a,
                                                                                 reference_assembly, tmp_path):
    """As toolpoint and lobes do on the command line (the app said nothing)."""
    import shutil
    from dataclasses import replace

    _show_on_machine(qtbot, window, reference_assembly)
    view = window.machine
    assert view.setup_warnings() == [] and "⚠" not in view.machine_label.text()
    for name in ("machine.toml", "spindle_x.csv", "spindle_y.csv"):
        shutil.copy(MACHINE.parent / name, tmp_path / name)
    other = tmp_path / "machine.toml"
    other.write_text(other.read_text().replace('interface = "HSK-A63"', 'interface = "BT40"'))
    assert view.load_machine(str(other), remember=False)
    assert "the machine's interface 'BT40' differs from the holder's 'HSK-A63'" in view.machine_label.text()
    catalogue = replace(view.source, assembly=view.source.assembly.with_holder(
        replace(view.source.assembly.holder, gauge_length=0.100)))
    view.set_source(catalogue)
    text = view.machine_label.text()
    assert "gauge_length = 100 mm puts the coupling plane 0 mm" in text and "gauge length 68 mm" in text


@pytest.mark.slow
def test_the_semi_discretization_and_the_band_follow_the_preview(qtbot, window, holder_a, reference_assembly):
    _show_on_machine(qtbot, window, reference_assembly)
    view = window.machine
    with qtbot.waitSignal(view.refined, timeout=600000) as blocker:
        pass
    stickout_mm, cut, lobes, band = blocker.args[0]
    assert lobes.method in ("sdm", "zoa") and band.samples >= 50 and "prediction band" in band.sources
    assert "Safe pockets (90 %)" in view.summary.text()
    ax_l = view.canvas.figure.axes[1]
    assert view._artists["band"] is not None and len(ax_l.collections) >= 2


def test_the_preview_lobes_use_fewer_frequencies_far_from_the_modes_and_lose_nothing(reference_assembly):
    """The thinned FRF (full step near the modes, 20 Hz elsewhere) gives the same boundary where it is drawn."""
    from taptune.gui.machine_view import RPM_STEP, frf_grid, lobe_frequencies
    from taptune.io.machine import load_machine
    from taptune.library.exchange import frequency_grid
    from taptune.machine import stability_lobes, toolpoint_frf
    from taptune.model.params import HolderParams

    from tests.gui.conftest import HOLDER_A

    machine = load_machine(MACHINE)
    frf = toolpoint_frf(reference_assembly.with_stickout(0.060), HolderParams(**HOLDER_A),
                        {"x": machine.x, "y": machine.y}, frf_grid(machine))
    near = lobe_frequencies(frf)
    assert 0.2 < near.mean() < 0.7  # far fewer frequencies, every one near the modes kept
    for m in frf.modes:
        assert near[np.abs(frf.freq_hz - m.hz) < 4 * m.damping_ratio * m.hz].all()
    cut = dict(teeth=3, ktc=796e6, krc=169e6, diameter=16e-3, ae=1.6e-3, milling="up",
               rpm=frequency_grid(2000.0, 24000.0, RPM_STEP), method="zoa")
    full = stability_lobes(frf.freq_hz, frf.xx, frf.yy, **cut)
    thin = stability_lobes(frf.freq_hz[near], frf.xx[near], frf.yy[near], **cut)
    assert thin.a_crit == pytest.approx(full.a_crit, rel=1e-9)
    shown = full.a_lim < 12 * full.a_crit  # the most the plot shows
    np.testing.assert_allclose(thin.a_lim[shown], full.a_lim[shown], rtol=1e-6)
    np.testing.assert_allclose(thin.pockets[:3], full.pockets[:3], rtol=1e-6)


def test_the_refinement_waits_for_the_slider_to_rest(qtbot, window, holder_a, reference_assembly):
    """While the stick-out moves no semi-discretization starts (it would slow every preview)."""
    from taptune.gui.machine_view import REFINE_DELAY_MS

    _show_on_machine(qtbot, window, reference_assembly)
    view = window.machine
    view._refine_timer.stop()  # (the first picture's refinement is not the point here)
    qtbot.waitUntil(lambda: not view._refines.busy, timeout=120000)
    with qtbot.waitSignal(view.updated, timeout=30000):
        view.slider.setValue(600)
    # The preview is drawn; its refinement waits for REFINE_DELAY_MS of rest.
    assert view.refining and view._refine_timer.isActive() and not view._refines.busy
    assert "follow" in view.summary.text()
    assert view._refine_timer.interval() == REFINE_DELAY_MS
    qtbot.waitUntil(lambda: view._refines.busy, timeout=5000)  # at rest: it starts


def test_the_refined_summary_says_which_depth_is_stable_at_every_speed():
    """With a band, 'stable at every speed' is the lowest safe depth; the central one is named as such."""
    from types import SimpleNamespace

    from taptune.gui.machine_view import refined_text
    from taptune.machine.band import LobeBand
    from taptune.machine.lobes import Lobes

    rpm = np.linspace(10000.0, 12000.0, 5)
    lobes = Lobes(rpm=rpm, a_lim=np.array([1.3, 2.0, 5.0, 2.0, 1.4]) * 1e-3, chatter_hz=np.full(5, 3000.0),
                  a_crit=1.3e-3, method="sdm", depth_cap=0.030)
    band = LobeBand(rpm=rpm, a_safe=np.array([1.0, 1.5, 3.0, 1.6, 1.1]) * 1e-3, a_low=np.zeros(5), a_high=np.ones(5),
                    confidence=0.9, sources="tool-point modal frequencies ±3 %", samples=64)
    source = SimpleNamespace(label="holder A", assembly=SimpleNamespace(holder=SimpleNamespace(name="ER32"),
                                                                         tool=SimpleNamespace(name="D16 4FL")))
    text = refined_text(source, None, lobes, band)
    assert "stable at every speed up to 1 mm with 90 % confidence (central estimate 1.3 mm; semi-discretization)" in text
    no_band = refined_text(source, None, lobes, LobeBand(rpm=rpm, a_safe=lobes.a_lim, a_low=lobes.a_lim,
                                                         a_high=lobes.a_lim, samples=1))
    assert "stable at every speed up to 1.3 mm (semi-discretization, central estimate: no band)" in no_band
