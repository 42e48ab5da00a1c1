"""Machine view: the holder on a machine — tool-point FRF in x and y and the stability lobes, at any stick-out.

The holder parameters are the predictor's (identified now or from the library), with the
panel's tool; the machine is a machine file (docs/machine.md) chosen once and remembered. Each
update calls :func:`taptune.machine.toolpoint_frf` and the zero-order
:func:`taptune.machine.stability_lobes` — a preview fast enough to follow the slider — in
a worker thread; while one runs only the latest request waits
(:class:`~taptune.gui.latest.LatestOnly`). When a preview is shown, a second worker
computes what ``taptune lobes`` reports — the semi-discretization, the holder's band,
the safe pockets (:func:`taptune.machine.band.lobes_with_band`) — and draws it over the
preview as soon as it is ready, if the stick-out and the cut have not changed meanwhile.
"""

from __future__ import annotations

import html
import re
import threading
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from PySide6.QtCore import Qt, QTimer, Signal
from PySide6.QtWidgets import (
    QComboBox,
    QDoubleSpinBox,
    QFileDialog,
    QGridLayout,
    QHBoxLayout,
    QLabel,
    QPushButton,
    QSpinBox,
    QVBoxLayout,
    QWidget,
)

from taptune.gui.blit import BlitCanvas, add_grid, steady_top
from taptune.gui.latest import LatestOnly
from taptune.gui.messages import show_error
from taptune.gui.plotting import MEASURED, MODEL
from taptune.gui.signals import emit
from taptune.gui.stickout import StickoutSlider

MM = 1e-3
SETTINGS_KEY = "machine/file"
# The FRF grid: the CLI's band (the spindle files' range within 50 Hz–20 kHz) on a 5 Hz
# step instead of 2 Hz. stability_lobes refines near the peaks; on the example machine
# and holder (recordings/machine, er32_d16) the boundary moves by 0.004 % (median) and
# 0.16 % (95th percentile) from the 2 Hz grid, and the update takes 2/3 of the time.
FRF_STEP_HZ = 5.0
# The preview lobes take the FRF at that step within LOBE_BANDS half-power bandwidths of
# each dominant mode the FRF reports, and every LOBE_STEP_HZ elsewhere: far from the modes
# the limit is many times the critical depth and never sets the boundary. On the example
# machine and holder (stick-outs 45–65 mm; 4 teeth ae 4 mm down, 2 teeth slotting, 3 teeth
# ae 1.6 mm up) the boundary, the critical depth and the best pocket are unchanged (under
# 0.001 px of a 400 px plot); the lobes take ~25 % less time.
LOBE_BANDS = 8.0
LOBE_STEP_HZ = 20.0
RPM_STEP = 10.0
# The semi-discretization and band (seconds on both cores) start once the stick-out has
# rested this long: while the slider moves they would slow every preview by half.
REFINE_DELAY_MS = 400
# Below ~2,000 rpm a milling tool's lobes are hundreds of thin ones (k up to 60 f / (N n));
# the default diagram starts there, the user can go lower.
DEFAULT_RPM_MIN = 2000.0
DEFAULT_RPM_MAX = 24000.0
CUSTOM = "custom K_tc, K_rc"
SUMMARY_LINES = 3
STABLE = "#d5ecd4"


@dataclass(frozen=True)
class Cut:
    """The milling cut the lobes are for (mm, MPa, rpm: as typed)."""

    teeth: int
    diameter_mm: float
    ae_mm: float
    milling: str
    ktc_mpa: float
    krc_mpa: float
    rpm_min: float
    rpm_max: float


def frf_grid(machine) -> np.ndarray:
    """Frequencies of the tool-point FRF [Hz]: the spindle files' band within the CLI's limits."""
    from taptune.cli.cmd_toolpoint import DEFAULT_F_MAX_HZ, DEFAULT_F_MIN_HZ
    from taptune.library.exchange import frequency_grid

    lo = max(float(machine.x.freq_hz[0]), float(machine.y.freq_hz[0]), DEFAULT_F_MIN_HZ)
    hi = min(float(machine.x.freq_hz[-1]), float(machine.y.freq_hz[-1]), DEFAULT_F_MAX_HZ)
    return frequency_grid(FRF_STEP_HZ * np.ceil(lo / FRF_STEP_HZ), hi, FRF_STEP_HZ)


def compute_machine(source, machine, stickout_mm: float, cut: Cut, freq_hz=None):
    """``(stickout_mm, ToolpointFRF, Lobes)`` of the holder and tool of ``source`` on ``machine`` (worker)."""
    from taptune.errors import InputError
    from taptune.library.exchange import frequency_grid
    from taptune.machine import stability_lobes, toolpoint_frf

    if not cut.rpm_min < cut.rpm_max:
        raise InputError(f"speed range {cut.rpm_min:g}–{cut.rpm_max:g} rpm: the first must be below the second")
    assembly = source.assembly.with_stickout(stickout_mm * MM)
    freq = frf_grid(machine) if freq_hz is None else freq_hz
    frf = toolpoint_frf(assembly, source.param_sets[0], {"x": machine.x, "y": machine.y}, freq, source.model_options)
    near = lobe_frequencies(frf)
    lobes = stability_lobes(frf.freq_hz[near], frf.xx[near], frf.yy[near], teeth=cut.teeth, ktc=cut.ktc_mpa * 1e6,
                            krc=cut.krc_mpa * 1e6, diameter=cut.diameter_mm * MM, ae=cut.ae_mm * MM,
                            milling=cut.milling, rpm=frequency_grid(cut.rpm_min, cut.rpm_max, RPM_STEP),
                            method="zoa", depth_cap=depth_cap(assembly))
    return stickout_mm, frf, lobes


def lobe_frequencies(frf) -> np.ndarray:
    """Which frequencies of ``frf`` (bool mask) the preview lobes use: all within LOBE_BANDS
    half-power bandwidths of each of its dominant modes, one per LOBE_STEP_HZ elsewhere."""
    f = frf.freq_hz
    if not frf.modes:  # no peak to keep sharp: every frequency
        return np.ones(len(f), bool)
    keep = np.zeros(len(f), bool)
    step = np.median(np.diff(f)) if len(f) > 1 else LOBE_STEP_HZ
    keep[:: max(1, int(round(LOBE_STEP_HZ / step)))] = True
    keep[-1] = True
    for mode in frf.modes:
        keep |= np.abs(f - mode.hz) <= max(LOBE_BANDS * 2 * mode.damping_ratio * mode.hz, 4 * step)
    return keep


def depth_cap(assembly) -> float:
    """The tool's flute length [m] (inf when the assembly does not give it)."""
    flute = assembly.tool.flute_length
    return flute if flute is not None else float("inf")


def compute_refined(source, stickout_mm: float, frf, cut: Cut, confidence: float = 0.9, cuts=()):
    """``(stickout_mm, cut, Lobes, LobeBand)``: the semi-discretization lobes of ``frf`` with the
    holder's prediction band (its near-optimal sets, the geometry tolerances, the model form),
    weighed by the observed ``cuts`` (rpm, depth [m], verdict) of this cut (worker)."""
    from taptune.identify.core import predict
    from taptune.library.exchange import frequency_grid
    from taptune.machine.band import band_from_prediction
    from taptune.machine.observed import lobes_with_observations

    assembly = source.assembly.with_stickout(stickout_mm * MM)
    band = band_from_prediction(predict(list(source.param_sets), assembly, source.model_options))
    lobes, observed = lobes_with_observations(frf.freq_hz, frf.xx, frf.yy, teeth=cut.teeth, ktc=cut.ktc_mpa * 1e6,
                                       krc=cut.krc_mpa * 1e6, diameter=cut.diameter_mm * MM, ae=cut.ae_mm * MM,
                                       milling=cut.milling, rpm=frequency_grid(cut.rpm_min, cut.rpm_max, RPM_STEP),
                                       method="auto", confidence=confidence, band=band,
                                       depth_cap=depth_cap(assembly), cuts=cuts)
    return stickout_mm, cut, lobes, observed.band


def warm_up() -> threading.Thread:
    """Import what the preview uses (~1 s when cold), in a background thread.

    Started when the view is made, so that the first picture and the first slider move do
    not wait for imports (the first ``compute_machine`` took 1.2 s cold, 0.06 s warm).
    """
    def imports() -> None:
        import scipy.interpolate  # noqa: F401  (the lobes' spline; slow to import)
        import scipy.sparse.linalg  # noqa: F401  (the holder's modes)

        import taptune.machine  # noqa: F401  (the refinement's modules load in its own worker, after a rest)

    thread = threading.Thread(target=imports, name="machine-view warm-up", daemon=True)
    thread.start()
    return thread


def tool_teeth(name: str) -> int | None:
    """Number of teeth written in a tool's name ("D16 4FL", "3-flute", "Z4"), or None."""
    m = re.search(r"(\d+)\s*-?\s*(?:FL\b|flutes?\b|teeth\b|T\b)|\bZ\s*(\d+)\b", name, re.IGNORECASE)
    return int(m.group(1) or m.group(2)) if m else None


def _spin(lo, hi, decimals, suffix, value) -> QDoubleSpinBox:
    box = QDoubleSpinBox()
    box.setRange(lo, hi)
    box.setDecimals(decimals)
    box.setSuffix(suffix)
    box.setValue(value)
    box.setKeyboardTracking(False)
    return box


class MachineView(QWidget):
    """Tool-point FRF and stability lobes of the current holder, tool and stick-out on a machine.

    Parameters
    ----------
    settings : QSettings, optional
        Where the machine file is remembered (default: the user's taptune settings).

    Signals
    -------
    updated(object)
        ``(stickout_mm, ToolpointFRF, Lobes)`` just drawn (the zero-order preview).
    refined(object)
        ``(stickout_mm, Cut, Lobes, LobeBand)`` just drawn over the preview.
    failed(str)
        An update could not be computed (the message is also shown in the view).
    """

    updated = Signal(object)
    refined = Signal(object)
    failed = Signal(str)

    def __init__(self, settings=None, parent=None):
        super().__init__(parent)
        from PySide6.QtCore import QSettings

        from taptune.machine.materials import MATERIALS

        self.settings = settings if settings is not None else QSettings()
        self.source = None
        self.machine = None
        self.result = None
        self._artists = None  # the plot's axes and lines, made on the first draw
        self._updates = LatestOnly(self._show, self._failed, self)
        self._refines = LatestOnly(self._show_refined, self._refine_failed, self)
        self.refined_result = None
        self._refine_timer = QTimer(self)
        self._refine_timer.setSingleShot(True)
        self._refine_timer.setInterval(REFINE_DELAY_MS)
        self._refine_timer.timeout.connect(self._refine)
        self.warming = warm_up()  # imports, off the slider's path

        self.machine_label = QLabel()
        self.machine_label.setWordWrap(True)
        self.machine_label.setTextInteractionFlags(Qt.TextSelectableByMouse)
        self.choose_button = QPushButton("Choose machine file…")
        self.choose_button.clicked.connect(self._choose_dialog)
        top = QHBoxLayout()
        top.addWidget(self.machine_label, 1)
        top.addWidget(self.choose_button)

        # The cut: one compact grid, labels above the fields.
        self.teeth = QSpinBox()
        self.teeth.setRange(1, 24)
        self.teeth.setValue(4)
        self.teeth.setKeyboardTracking(False)
        self.diameter = _spin(0.5, 200.0, 2, " mm", 16.0)
        self.ae = _spin(0.01, 200.0, 2, " mm", 4.0)
        self.ae.setToolTip("Radial depth of cut; equal to the diameter is slotting")
        self.milling = QComboBox()
        self.milling.addItems(["down", "up"])
        self.material = QComboBox()
        self._materials = dict(MATERIALS)
        self.material.addItems(list(self._materials) + [CUSTOM])
        self.ktc = _spin(1.0, 20000.0, 0, " MPa", 796.0)
        self.krc = _spin(0.0, 20000.0, 0, " MPa", 169.0)
        self.rpm_min = _spin(10.0, 200000.0, 0, " rpm", DEFAULT_RPM_MIN)
        self.rpm_max = _spin(100.0, 200000.0, 0, " rpm", DEFAULT_RPM_MAX)
        for box in (self.rpm_min, self.rpm_max):
            box.setSingleStep(500.0)
        cut = QGridLayout()
        cut.setHorizontalSpacing(8)
        cut.setVerticalSpacing(1)
        fields = (("Teeth", self.teeth), ("Tool Ø", self.diameter), ("ae", self.ae), ("Milling", self.milling),
                  ("Material", self.material), ("K_tc", self.ktc), ("K_rc", self.krc),
                  ("Speeds from", self.rpm_min), ("to", self.rpm_max))
        for c, (label, widget) in enumerate(fields):
            cut.addWidget(QLabel(label), 0, c)
            cut.addWidget(widget, 1, c)
        self.teeth.valueChanged.connect(self.request)
        for box in (self.diameter, self.ae, self.ktc, self.krc, self.rpm_min, self.rpm_max):
            box.valueChanged.connect(self.request)
        self.milling.currentTextChanged.connect(self.request)
        self.material.currentTextChanged.connect(self._material_changed)

        self.stickout = StickoutSlider()
        self.stickout.changed.connect(self.request)
        self.slider, self.spin = self.stickout.slider, self.stickout.spin

        self.summary = QLabel()
        self.summary.setWordWrap(True)
        self.summary.setTextInteractionFlags(Qt.TextSelectableByMouse)
        self.summary.setAlignment(Qt.AlignLeft | Qt.AlignTop)
        # Room for the refined summary (safe pockets and the band's make-up) from the start, and
        # then for the longest one so far: a summary that grows and shrinks would resize the
        # plot at each slider move, and a resize redraws it whole.
        self.summary.setMinimumHeight(SUMMARY_LINES * self.summary.fontMetrics().lineSpacing() + 4)
        # Fixed margins instead of the constrained layout: that would be solved again on
        # every render, which costs more than the plots themselves.
        self.canvas = BlitCanvas(self)

        layout = QVBoxLayout(self)
        layout.setContentsMargins(0, 0, 0, 0)
        layout.addLayout(top)
        layout.addLayout(cut)
        layout.addWidget(self.stickout)
        layout.addWidget(self.summary)
        from taptune.gui.cut_panel import CutPanel  # listen to a cut (issue 21)

        self.cut_panel = CutPanel(self)
        layout.addWidget(self.cut_panel)
        layout.addWidget(self.canvas, 1)
        self._material_changed(self.material.currentText())

        remembered = self.settings.value(SETTINGS_KEY, "")
        if remembered:
            self.load_machine(str(remembered), remember=False, quiet=True)
        self._update_state()

    # ------------------------------------------------------------------ inputs

    def cut(self) -> Cut:
        return Cut(self.teeth.value(), self.diameter.value(), self.ae.value(), self.milling.currentText(),
                   self.ktc.value(), self.krc.value(), self.rpm_min.value(), self.rpm_max.value())

    def _material_changed(self, name: str) -> None:
        custom = name == CUSTOM
        for box in (self.ktc, self.krc):
            box.setEnabled(custom)
        if not custom:
            c = self._materials[name]
            for box, value in ((self.ktc, c.ktc), (self.krc, c.krc)):
                box.blockSignals(True)
                box.setValue(value / 1e6)
                box.blockSignals(False)
            self.material.setToolTip(c.source)
        self.request()

    def set_source(self, source) -> None:
        """The holder parameters and assembly (a :class:`~taptune.gui.predictor.PredictorSource`, or None)."""
        previous = self.source
        self.source = source
        if source is None:
            self._update_state()
            return
        tool = source.assembly.tool
        if previous is None or previous.assembly.tool != tool:
            # A new tool brings its diameter, teeth (from its name) and a quarter-diameter cut.
            from taptune.cli.cut import tool_diameter_mm

            d = tool_diameter_mm(source.assembly)  # as ``taptune lobes`` takes it
            for box, value in ((self.diameter, d), (self.ae, round(d / 4, 2)),
                               (self.teeth, tool_teeth(tool.name) or self.teeth.value())):
                box.blockSignals(True)
                box.setValue(value)
                box.blockSignals(False)
        self.stickout.set_assembly(source.assembly)
        self._update_state()
        self.request()

    def set_stickout_mm(self, value: float) -> None:
        """Move the stick-out (as the user would with the field)."""
        self.stickout.set_value(value)

    # ------------------------------------------------------------------ the machine file

    def _choose_dialog(self) -> None:
        start = str(Path(self.machine.source).parent) if self.machine else str(Path.cwd() / "recordings" / "machine")
        path, _ = QFileDialog.getOpenFileName(self, "Choose a machine file", start, "Machine files (*.toml)")
        if path:
            self.load_machine(path)

    def load_machine(self, path: str, remember: bool = True, quiet: bool = False) -> bool:
        """Use the machine file ``path`` (and remember it); a bad file changes nothing and says why.

        ``quiet`` reports a problem in the view only (the remembered file at start-up).
        """
        from taptune.errors import InputError
        from taptune.io.machine import load_machine

        try:
            machine = load_machine(path)
        except InputError as err:
            keep = f"The machine in use is unchanged ({self.machine.name})." if self.machine else ""
            if not quiet:
                show_error(self, "Cannot use this machine file", f"{err}\n{keep}".strip())
            self._set_label(f"Cannot use {path}: {err}" + (f" — still using {self.machine.name}" if self.machine
                                                          else ""), error=True)
            return False
        self.machine = machine
        if remember:
            self.settings.setValue(SETTINGS_KEY, str(Path(path).resolve()))
        if machine.max_rpm:
            self.rpm_max.blockSignals(True)
            self.rpm_max.setValue(machine.max_rpm)
            self.rpm_max.blockSignals(False)
        self._update_state()
        self.request()
        return True

    def _set_label(self, text: str, error: bool = False) -> None:
        self.machine_label.setText(text)
        self.machine_label.setStyleSheet("color: #b00020;" if error else "")

    def _update_state(self) -> None:
        if self.machine is not None:
            note = "; y uses the x receptance" if self.machine.y_from_x else ""
            text = [html.escape(t, quote=False) for t in (self.machine.name, self.machine.interface,
                                                          Path(self.machine.source).name)]
            warnings = "".join(f"<br><span style='color:#b35900'>⚠ {html.escape(w, quote=False)}</span>"
                               for w in self.setup_warnings())
            self._set_label(f"<b>Machine:</b> {text[0]} ({text[1]}) — {text[2]}{note}{warnings}")
        elif not self.machine_label.text():
            self._set_label("Choose the machine file of the spindle (docs/machine.md): it is remembered for next time.")
        ready = self.machine is not None and self.source is not None
        self.stickout.setEnabled(ready)
        if not ready and self.result is None:
            missing = [w for w, ok in (("a machine file", self.machine is not None),
                                       ("holder parameters (identify, or pick a library holder)",
                                        self.source is not None)) if not ok]
            self._artists = None
            self.canvas.message("Needs " + " and ".join(missing) + ".")

    def setup_warnings(self) -> list[str]:
        """What the command line warns about this holder on this machine: another interface,
        a gauge_length that moves the coupling plane off the taper's end."""
        from taptune.machine.plane import interface_warning, plane_warning

        if self.machine is None or self.source is None:
            return []
        holder = self.source.assembly.holder
        found = (interface_warning(self.machine.interface, holder), plane_warning(holder, self.source.assembly.source))
        return [w for w in found if w]

    # ------------------------------------------------------------------ updates

    @property
    def busy(self) -> bool:
        return self._updates.busy

    @property
    def refining(self) -> bool:
        """True while the semi-discretization and the band of the preview wait to start or are computed."""
        return self._refine_timer.isActive() or self._refines.busy

    def request(self, *_args) -> None:
        """Compute the FRF and lobes at the current stick-out and cut (latest request wins)."""
        if self.machine is not None and self.source is not None:
            self._refine_timer.stop()  # the refinement waits for the slider to rest
            self._updates.request(compute_machine, self.source, self.machine, self.spin.value(), self.cut())

    def _failed(self, message: str) -> None:
        self.result = None
        self._artists = None
        self.summary.setText("")
        self.canvas.message(f"Cannot compute the tool point here:\n{message}")
        emit(self.failed, message)

    def _show(self, result) -> None:
        self.result = result
        self.refined_result = None
        stickout_mm, frf, lobes = result
        self.summary.setText(summary_text(self.source, frf, lobes) + " <i>Semi-discretization and band follow…</i>")
        self.draw(stickout_mm, frf, lobes)
        emit(self.updated, result)
        self._refine_timer.start()  # (again): the refinement of the picture the slider rests on

    def _refine(self) -> None:
        if self.result is None or self.source is None:
            return
        stickout_mm, frf, _lobes = self.result
        self._refines.request(compute_refined, self.source, stickout_mm, frf, self.cut(), 0.9,
                             self.cut_panel.observed_cuts())

    def _show_refined(self, result) -> None:
        stickout_mm, cut, lobes, band = result
        if self.result is None or abs(stickout_mm - self.spin.value()) > 1e-9 or cut != self.cut():
            return  # overtaken: a newer preview asks for its own
        self.refined_result = result
        self.summary.setText(refined_text(self.source, self.result[1], lobes, band))
        self._keep_summary_room()
        self.draw_refined(lobes, band)
        emit(self.refined, result)

    def _keep_summary_room(self) -> None:
        """Keep the summary at least as high as its longest text so far (the plot keeps its size)."""
        needed = self.summary.heightForWidth(max(self.summary.width(), 1))
        if needed > self.summary.minimumHeight():
            self.summary.setMinimumHeight(needed)

    def _refine_failed(self, message: str) -> None:
        if self.result is not None:
            self.summary.setText(self.summary.text().replace(" <i>Semi-discretization and band follow…</i>", "")
                                 + f" <span style='color:#b00020'>No semi-discretization here: "
                                   f"{html.escape(message, quote=False)}</span>")

    def draw(self, stickout_mm: float, frf, lobes) -> None:
        """The FRF (left) and the lobe diagram (right).

        The axes and artists are made once and then given new data; the canvas redraws
        only the data over a kept picture of the axes (:class:`~taptune.gui.blit.BlitCanvas`)
        as long as the limits stay: each y axis keeps its round top while the curve fits
        (:func:`~taptune.gui.blit.steady_top`), so a drag redraws the ticks only now and then.
        """
        if self._artists is None:
            self._make_axes()
        art = self._artists
        context = (id(self.source), id(self.machine), self.cut())
        fresh = art["context"] != context  # another holder, machine or cut: fit the axes again
        art["context"] = context
        f_khz = frf.freq_hz / 1e3
        gx, gy = np.abs(frf.xx) * 1e6, np.abs(frf.yy) * 1e6
        art["x"].set_data(f_khz, gx)
        art["y"].set_data(f_khz, gy)
        # The strongest peak only: x and y peaks a few Hz apart would print on top of each other.
        mode = frf.modes[0] if frf.modes else None
        art["mode"].set_visible(mode is not None)
        if mode is not None:
            art["mode"].xy = (mode.hz / 1e3, mode.magnitude * 1e6)
            art["mode"].set_text(f"{mode.hz:,.0f} Hz ({mode.direction})")
        ax_f = art["ax_f"]
        if fresh or ax_f.get_xlim() != (f_khz[0], f_khz[-1]):
            ax_f.set_xlim(f_khz[0], f_khz[-1])
        top = steady_top(1.15 * max(gx.max(), gy.max()), None if fresh else ax_f.get_ylim()[1])
        if ax_f.get_ylim() != (0, top):
            ax_f.set_ylim(0, top)
        ax_f.set_title(f"Tool-point FRF at {stickout_mm:.1f} mm", loc="left")

        ax_l = art["ax_l"]
        a_mm = np.where(np.isfinite(lobes.a_lim), lobes.a_lim / MM, np.nan)
        art["stable"].set_data(lobes.rpm, 0, a_mm)
        art["band"].set_visible(False)
        art["safe"].set_data([], [])
        art["boundary"].set_data(lobes.rpm, a_mm)
        cap = lobes.depth_cap / MM
        art["cap"].set_visible(bool(np.isfinite(cap)))
        if np.isfinite(cap):
            art["cap"].set_ydata([cap, cap])
        ax_l.set_title("Stability lobes (zero-order preview)", loc="left")
        a_crit = lobes.a_crit / MM
        best = lobes.pockets[0] if lobes.pockets else None
        self._mark(a_crit, None if best is None else (best[0], best[1] / MM, f"{best[0]:,.0f} rpm\n{best[1] / MM:.2g} mm"))
        top = max(a / MM for _, a in lobes.pockets) if lobes.pockets else 4 * a_crit
        need = min(1.3 * top, 12 * a_crit, 1.1 * cap if np.isfinite(cap) else np.inf)
        top = steady_top(need, None if fresh else ax_l.get_ylim()[1])
        if ax_l.get_ylim() != (0, top):
            ax_l.set_ylim(0, top)
        if fresh or ax_l.get_xlim() != (lobes.rpm[0], lobes.rpm[-1]):
            ax_l.set_xlim(lobes.rpm[0], lobes.rpm[-1])
        self.cut_panel.mark(ax_l)  # the observed cuts, ✓ / ✗
        self.canvas.render()

    def draw_refined(self, lobes, band) -> None:
        """The semi-discretization boundary, the shaded band, the safe depth and the best safe pocket over the preview."""
        art = self._artists
        if art is None:
            return
        ax_l = art["ax_l"]
        cap = lobes.depth_cap
        capped = np.minimum(lobes.a_lim, cap)  # stable up to the flute length: the cap, not a gap
        a_mm = np.where(np.isfinite(capped), capped / MM, np.nan)
        art["stable"].set_data(lobes.rpm, 0, a_mm)
        with_band = band.samples > 1
        art["band"].set_visible(with_band)
        if with_band:
            art["band"].set_data(band.rpm, band.a_low / MM, band.a_high / MM)
            art["safe"].set_data(band.rpm, band.a_safe / MM)
        art["boundary"].set_data(lobes.rpm, a_mm)
        best = band.safe_pockets[0] if band.safe_pockets else None
        self._mark(min(lobes.a_crit, cap) / MM, None if best is None else (
            best.rpm, best.a / MM, f"{best.rpm_low:,.0f}–{best.rpm_high:,.0f} rpm\n{best.a / MM:.2g} mm "
                                   f"({100 * band.confidence:.0f} %)"))
        kind = "semi-discretization" if lobes.method == "sdm" else "zero-order"
        ax_l.set_title(f"Stability lobes ({kind})", loc="left")
        self.cut_panel.mark(ax_l)
        self.canvas.render()

    def _mark(self, a_crit_mm: float, best) -> None:
        """The critical-depth line with its depth written on it, and the best pocket ``(rpm, a [mm], label)``
        (None: no marker)."""
        art = self._artists
        art["crit"].set_ydata([a_crit_mm, a_crit_mm])
        art["crit_note"].set_y(a_crit_mm)
        art["crit_note"].set_text(f"{a_crit_mm:.2g} mm")
        art["pocket"].set_visible(best is not None)
        art["pocket_note"].set_visible(best is not None)
        if best is not None:
            rpm, a, text = best
            art["pocket"].set_data([rpm], [a])
            art["pocket_note"].xy = (rpm, a)
            art["pocket_note"].set_text(text)

    def _make_axes(self) -> None:
        from matplotlib.transforms import blended_transform_factory

        fig = self.canvas.figure
        fig.clear()
        self.canvas.invalidate()
        fig.subplots_adjust(left=0.065, right=0.99, bottom=0.11, top=0.92, wspace=0.2)
        with self.canvas.styled():
            ax_f, ax_l = fig.subplots(1, 2, width_ratios=(2, 3))
            grids = [add_grid(ax) for ax in (ax_f, ax_l)]
            x, = ax_f.plot([], [], color=MEASURED, lw=1.1, label="x")
            y, = ax_f.plot([], [], color=MODEL, lw=1.0, ls="--", label="y")
            mode = ax_f.annotate("", (0, 0), xytext=(5, -3), textcoords="offset points", fontsize=8,
                                 color="#333333")
            ax_f.set_xlabel("frequency [kHz]")
            ax_f.set_ylabel("|G| at the tool point [µm/N]")
            ax_f.legend(loc="upper right", framealpha=1.0)
            stable = ax_l.fill_between([], [], [], color=STABLE, lw=0, zorder=0)
            band = ax_l.fill_between([], [], [], color="#f5c16c", alpha=0.5, lw=0, zorder=0.5)
            boundary, = ax_l.plot([], [], color=MEASURED, lw=1.0, label="stability limit")
            crit = ax_l.axhline(0.0, color=MODEL, lw=0.9, ls="--", label="critical depth (central)")
            crit_note = ax_l.text(0.995, 0.0, "", transform=blended_transform_factory(ax_l.transAxes, ax_l.transData),
                                  ha="right", va="bottom", fontsize=8, color=MODEL)
            pocket, = ax_l.plot([], [], "v", color=MODEL, ms=7)
            safe, = ax_l.plot([], [], color="#2c3e50", lw=0.9, ls="--", label="safe depth (band)")
            cap = ax_l.axhline(0.0, color="#7f8c8d", lw=1.0, ls=":", label="flute length")
            pocket_note = ax_l.annotate("", (0, 0), xytext=(0, 8), textcoords="offset points", ha="center",
                                        va="bottom", fontsize=8, color=MODEL)
            ax_l.set_xlabel("spindle speed [rpm]")
            ax_l.set_ylabel("axial depth of cut [mm]")
            legend = ax_l.legend(loc="upper left", framealpha=1.0)
        self._artists = dict(ax_f=ax_f, ax_l=ax_l, x=x, y=y, mode=mode, boundary=boundary, crit=crit,
                             crit_note=crit_note, pocket=pocket, pocket_note=pocket_note, legend=legend,
                             stable=stable, band=band, safe=safe, cap=cap, grids=grids, context=None)

    def shutdown(self) -> None:
        self._refine_timer.stop()
        self._updates.shutdown()
        self._refines.shutdown()


def summary_text(source, frf, lobes) -> str:
    """One line a machinist reads first: the critical depth, the lobe peaks, the mode that limits.

    It is the zero-order preview's central estimate and says so: the semi-discretization
    and the band that follow give the depth to trust.
    """
    pockets = ", ".join(f"{rpm:,.0f} rpm → {min(a, lobes.depth_cap) / MM:.2g} mm" for rpm, a in lobes.pockets[:3])
    mode = frf.modes[0] if frf.modes else None
    limit = (f"; weakest tool-point mode {mode.hz:,.0f} Hz ({mode.direction}), ζ {100 * mode.damping_ratio:.1f} %"
             if mode else "")
    return (f"<b>{source.assembly.holder.name}</b> with {source.assembly.tool.name} "
            f"(holder parameters: {source.label}). "
            f"<b>Zero-order preview, central estimate: {_every_speed(min(lobes.a_crit, lobes.depth_cap))}</b>; "
            f"lobe peaks: {pockets or 'none in this range'}{limit}.")


def refined_text(source, frf, lobes, band) -> str:
    """The summary once the semi-discretization and the band are in: safe pockets first.

    With a band, the depth stable at every speed is the lowest safe depth (stable with the
    band's confidence), and the central estimate is named as such beside it.
    """
    cap = lobes.depth_cap
    central = min(lobes.a_crit, cap)
    pockets = ", ".join(f"{p.rpm_low:,.0f}–{p.rpm_high:,.0f} rpm → {p.a / MM:.2g} mm" for p in band.safe_pockets[:3])
    kind = "semi-discretization" if lobes.method == "sdm" else "zero-order"
    p = f"{100 * band.confidence:.0f} %"
    if band.samples > 1:
        safe = np.minimum(np.asarray(band.a_safe, dtype=float), cap)
        safe = safe[np.isfinite(safe)]
        lowest = float(safe.min()) if safe.size else float("inf")
        every = (f"{_every_speed(lowest)} with {p} confidence "
                 f"(central estimate {_depth_mm(central)}; {kind})")
    else:
        every = f"{_every_speed(central)} ({kind}, central estimate: no band)"
    return (f"<b>{source.assembly.holder.name}</b> with {source.assembly.tool.name} "
            f"(holder parameters: {source.label}). <b>Safe pockets ({p}): "
            f"{pockets or 'none in this range'}</b>; {every}. "
            f"<span style='color:#555555'>Band: {html.escape(band.sources, quote=False)}.</span>")


def _depth_mm(a: float) -> str:
    return f"{a / MM:.2g} mm" if np.isfinite(a) else "no limit"


def _every_speed(a: float) -> str:
    return f"stable at every speed up to {a / MM:.2g} mm" if np.isfinite(a) else "no depth chatters in this range"
