"""The main window: assembly on the left; record, spectrum, fit, predict and library on the right.

The window holds the session (recording, analysis, identification) and wires the views
to the same functions the CLI calls: ``read_audio`` → ``analyse_for_assembly`` →
``identify`` → ``save to library`` → ``predict``. Long calls run in worker threads
(:mod:`taptune.gui.workers`); every failure is shown as a message and leaves the
recording, the assembly and the library as they were.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from pathlib import Path

from PySide6.QtCore import Qt, QTimer, Signal
from PySide6.QtWidgets import (
    QFileDialog,
    QHBoxLayout,
    QLabel,
    QMainWindow,
    QProgressBar,
    QCheckBox,
    QPushButton,
    QScrollArea,
    QSplitter,
    QTabWidget,
    QVBoxLayout,
    QWidget,
)

from taptune.gui.advice import Banner, second_tap_advice
from taptune.gui.assembly_panel import AssemblyPanel
from taptune.gui.check_view import CheckView
from taptune.gui.fit_view import FitView
from taptune.gui.layout import ElidedLabel
from taptune.gui.library_view import LibraryView
from taptune.gui.machine_view import MachineView
from taptune.gui.messages import show_error
from taptune.gui.predictor import Predictor, PredictorSource
from taptune.gui.recorder_panel import RecorderPanel
from taptune.gui.signals import emit
from taptune.gui.spectrum_view import SpectrumView, relabel
from taptune.gui.workers import TaskRunner
from taptune.identify.bands import measured_modes
from taptune.io.assembly import assembly_beside
from taptune.io.audio import AUDIO_SUFFIXES

# The open dialogs' filter: every format read_audio reads, in both cases.
AUDIO_FILTER = "Recordings (" + " ".join(f"*{s} *{s.upper()}" for s in AUDIO_SUFFIXES) + ")"

VIEWS = ("record", "spectrum", "fit", "predict", "machine", "library", "check")


def analyse_file(path: str, assembly, recording=None):
    """Read a recording and analyse it, guided by ``assembly`` when there is one (worker thread).

    ``recording``, when given, is the audio of ``path`` already read: an analysis again
    after an assembly edit does not read and decode the file again. Returns ``(recording, analysis, expected_hz)``; ``expected_hz`` is the model's guess
    of f1–f3 with nominal parameters (None without an assembly).
    """
    from taptune.identify.pipeline import analyse_for_assembly, model_expectation
    from taptune.io.audio import read_audio

    if recording is None:
        recording = read_audio(path)
    guidance = model_expectation(assembly) if assembly is not None else None
    analysis = analyse_for_assembly(recording, assembly, guidance=guidance)
    return recording, analysis, None if guidance is None else guidance[0]


@dataclass(frozen=True)
class Take:
    """A recording opened in the window: file, audio, analysis, the model's guess, its assembly."""

    path: str
    recording: object
    analysis: object
    expected_hz: object
    assembly: object


def run_check(recording, assembly, entry, library_path, progress=None):
    """Check library holder ``entry`` with one tap (worker thread): ``taptune check``'s call, saved to its history."""
    from taptune.library.checks import check_holder

    return check_holder(recording, assembly, entry.name, str(library_path), save=True, entry=entry)


def run_identification(analyses, assemblies, options, progress=None):
    """Joint identification of one or several recordings (worker thread); ``progress`` may cancel it."""
    from taptune.identify import identify

    return identify(list(analyses), list(assemblies), options, progress=progress)


class MainWindow(QMainWindow):
    """taptune's desktop window.

    Parameters
    ----------
    library_path : path
        The holder library file.
    identify_options : IdentifyOptions, optional
        Default: seed 0, one process (forking a process with Qt threads running is not
        safe), the standard optimiser budget.
    stream_factory, devices : optional
        Passed to the recording panel (tests use a fake input stream).
    settings : QSettings, optional
        Where choices are remembered (the machine file, the recordings folder); default: the user's settings.
    """

    analysis_ready = Signal(object)
    identification_ready = Signal(object)
    identification_ended = Signal(str)  # "finished", "failed" or "cancelled"
    advice_ready = Signal(str)  # the second-tap advice after one recording ("" when none)
    saved_to_library = Signal(str)
    check_ended = Signal(object)  # the HolderCheck, or None when it failed
    load_failed = Signal(str)

    def __init__(self, library_path, identify_options=None, stream_factory=None, devices=None, settings=None,
                 parent=None):
        super().__init__(parent)
        from taptune import __version__

        self.setWindowTitle(f"taptune {__version__} — tool-holder dynamics from a tap")
        self.setAcceptDrops(True)
        if identify_options is None:
            from taptune.identify import IdentifyOptions

            identify_options = IdentifyOptions(seed=0, jobs=1)
        self.identify_options = identify_options
        self.runner = TaskRunner(self)
        self.recording = None
        self.recording_path: str | None = None
        self.analysis = None
        self.expected_hz = None
        self.analysed_assembly = None
        self.identification = None
        self.identified = None  # ([recordings], [assemblies]) the identification was made from
        self.second: Take | None = None  # the recording at the 2nd stick-out, if any
        self._second_seq = 0
        self._second_loading = None
        self._loading = None
        self._analysis_seq = 0
        self._identify_task = None

        self.assembly_panel = AssemblyPanel()
        self.recorder = RecorderPanel(self._assembly_for_recording, stream_factory=stream_factory, devices=devices,
                                      settings=settings)
        self.spectrum = SpectrumView()
        self.spectrum2 = SpectrumView()
        self.fit = FitView()
        self.predictor = Predictor()
        self.machine = MachineView(settings)
        self.library_view = LibraryView(library_path)
        self.check_view = CheckView()
        self._check_task = None

        record_tab = QWidget()
        rl = QVBoxLayout(record_tab)
        rl.addWidget(self.recorder)
        open_box = QLabel("…or open a recording made earlier: <b>Open recording…</b> above, or drop an audio "
                          "file (WAV, FLAC, MP3, a phone's M4A or video…) onto the window. An assembly file with "
                          "the same name (or named like the start of its name, or assembly.toml) beside it is loaded too.")
        open_box.setWordWrap(True)
        open_box.setMaximumWidth(760)
        rl.addWidget(open_box)
        self.record_second = QCheckBox("Record the 2nd stick-out (same holder and tool; set it on the left, "
                                       "then both recordings are identified together)")
        rl.addWidget(self.record_second)
        rl.addStretch(1)

        self.tabs = QTabWidget()
        self.tabs.addTab(record_tab, "1  Record")
        self.tabs.addTab(self._spectrum_page(), "2  Spectrum")
        self.tabs.addTab(self.fit, "3  Fit")
        self.tabs.addTab(self.predictor, "4  Predict")
        self.tabs.addTab(self.machine, "5  Machine")
        self.tabs.addTab(self.library_view, "Library")
        self.tabs.addTab(self.check_view, "Check")

        # The workflow bar: always visible, in the order of the job.
        self.open_button = QPushButton("Open recording…")
        self.open2_button = QPushButton("Add 2nd stick-out…")
        self.open2_button.setToolTip("Open a recording of the same holder and tool at another stick-out: "
                                     "both are identified together, which narrows the predicted bands")
        self.identify_button = QPushButton("Identify holder")
        self.cancel_button = QPushButton("Cancel")
        self.save_button = QPushButton("Save to library")
        self.check_button = QPushButton("Check")
        self.progress = QProgressBar()
        self.progress.setRange(0, 1000)
        self.progress.setTextVisible(True)
        self.progress.setFormat("")
        # Two long file names must not widen the window past a laptop screen: the label
        # shortens them in the middle, keeping both ends (the tooltip has the paths in full).
        self.file_label = ElidedLabel("No recording")
        self.file_label.setMinimumWidth(120)
        self.open_button.clicked.connect(self._open_dialog)
        self.open2_button.clicked.connect(self._open_second_dialog)
        self.identify_button.clicked.connect(self.start_identification)
        self.cancel_button.clicked.connect(self.cancel_identification)
        self.save_button.clicked.connect(self.save_to_library)
        self.check_button.clicked.connect(self.start_check)
        bar = QHBoxLayout()
        bar.addWidget(self.open_button)
        bar.addWidget(self.open2_button)
        bar.addWidget(self.file_label, 1)
        bar.addWidget(self.identify_button)
        bar.addWidget(self.progress, 1)
        bar.addWidget(self.cancel_button)
        bar.addWidget(self.save_button)
        bar.addWidget(self.check_button)

        right = QWidget()
        rv = QVBoxLayout(right)
        rv.setContentsMargins(0, 0, 0, 0)
        rv.addLayout(bar)
        self.banner = Banner("Add 2nd stick-out…")
        self.banner.action.connect(self._open_second_dialog)
        rv.addWidget(self.banner)
        rv.addWidget(self.tabs, 1)
        scroll = QScrollArea()
        scroll.setWidget(self.assembly_panel)
        scroll.setWidgetResizable(True)
        scroll.setHorizontalScrollBarPolicy(Qt.ScrollBarAlwaysOff)
        scroll.setMinimumWidth(340)
        self.splitter = QSplitter(Qt.Horizontal)
        self.splitter.addWidget(scroll)
        self.splitter.addWidget(right)
        self.splitter.setStretchFactor(0, 0)
        self.splitter.setStretchFactor(1, 1)
        self.splitter.setChildrenCollapsible(False)
        self.setCentralWidget(self.splitter)

        self._reanalyse = QTimer(self)
        self._reanalyse.setSingleShot(True)
        self._reanalyse.setInterval(600)
        self._reanalyse.timeout.connect(self._reanalyse_now)
        self.assembly_panel.assembly_changed.connect(self._assembly_changed)
        self.recorder.recorded.connect(self._recorded)
        self.assembly_panel.second_stickout_changed.connect(self._second_stickout_changed)
        self.spectrum2.relabel_requested.connect(self.relabel_second_peak)
        self.recorder.status.connect(self.statusBar().showMessage)
        self.spectrum.relabel_requested.connect(self.relabel_peak)
        self.library_view.changed.connect(self.assembly_panel.reload_choices)
        self.library_view.changed.connect(lambda _entries: self._update_actions())
        self.library_view.table.itemSelectionChanged.connect(self._update_actions)
        self.library_view.use_for_prediction.connect(self.use_library_entry)
        self.library_view.use_on_machine.connect(self.use_library_entry_on_machine)
        self.predictor.failed.connect(lambda m: self.statusBar().showMessage(f"Prediction: {m}", 8000))
        self.assembly_panel.reload_choices(self.library_view.entries)
        self._update_actions()
        self.progress.setVisible(False)
        self.statusBar().showMessage("Choose the holder and tool, then record or open a recording.")

    # ------------------------------------------------------------------ helpers

    def _spectrum_page(self) -> QWidget:
        """Both spectra, one above the other; the second pane only while there is a 2nd recording."""
        self.second_label = QLabel()
        self.remove_second_button = QPushButton("Remove 2nd recording")
        self.remove_second_button.clicked.connect(self.remove_second_recording)
        head = QHBoxLayout()
        head.setContentsMargins(0, 0, 0, 0)
        head.addWidget(self.second_label, 1)
        head.addWidget(self.remove_second_button)
        self.second_pane = QWidget()
        pane = QVBoxLayout(self.second_pane)
        pane.setContentsMargins(0, 4, 0, 0)
        pane.addLayout(head)
        pane.addWidget(self.spectrum2, 1)
        self.second_pane.setVisible(False)
        self.spectrum_page = QSplitter(Qt.Vertical)
        self.spectrum_page.addWidget(self.spectrum)
        self.spectrum_page.addWidget(self.second_pane)
        self.spectrum_page.setChildrenCollapsible(False)
        return self.spectrum_page

    def show_view(self, name: str) -> None:
        """Bring one of :data:`VIEWS` to the front."""
        self.tabs.setCurrentIndex(VIEWS.index(name))

    def _assemblies(self) -> list:
        """The assembly of each recording to identify: the panel's, and the 2nd stick-out's."""
        first = self.assembly_panel.assembly
        if self.second is None or first is None:
            return [first]
        second, _problem = self.assembly_panel.second_assembly()
        return [first, second]

    @property
    def busy(self) -> bool:
        """True while a recording is analysed or a holder identified."""
        return (self._loading is not None or self._second_loading is not None
                or self._identify_task is not None or self._check_task is not None)

    def _update_actions(self) -> None:
        identifying = self._identify_task is not None
        ready = self.analysis is not None and None not in self._assemblies()
        self.identify_button.setEnabled(ready and not self.busy)
        self.identify_button.setText("Identify both together" if self.second is not None else "Identify holder")
        if self.assembly_panel.assembly is None:
            self.identify_button.setToolTip("Describe the assembly first (left)")
        elif None in self._assemblies():
            self.identify_button.setToolTip("2nd recording: " + self.assembly_panel.second_assembly()[1])
        else:
            self.identify_button.setToolTip("")
        self.open2_button.setEnabled(self.analysis is not None and not identifying)
        holder = self.library_view.selected()
        self.check_button.setEnabled(holder is not None and self.recording is not None
                                     and self.assembly_panel.assembly is not None and not self.busy)
        self.check_button.setToolTip(
            f"Check this tap against library holder '{holder.name}' (selected in the Library tab)" if holder
            else "Select a holder in the Library tab, and open or record a tap of it, to check it")
        self.cancel_button.setEnabled(identifying)
        unreadable = self.library_view.error
        self.save_button.setEnabled(self.identification is not None and not identifying and unreadable is None)
        # A file that cannot be read is never written over (the library refuses it too).
        self.save_button.setToolTip(
            "" if unreadable is None else
            f"The holder library cannot be read, so nothing is saved into it: {unreadable}. "
            "Repair the file or open another library (Library tab).")
        self.open_button.setEnabled(not identifying)

    # ------------------------------------------------------------------ recordings

    def _open_dialog(self) -> None:
        path, _ = QFileDialog.getOpenFileName(self, "Open recording", str(Path.cwd() / "recordings"),
                                              AUDIO_FILTER)
        if path:
            self.load_recording(path)

    def _open_second_dialog(self) -> None:
        path, _ = QFileDialog.getOpenFileName(self, "Open the recording at the 2nd stick-out",
                                              str(Path(self.recording_path or Path.cwd() / "recordings").parent),
                                              AUDIO_FILTER)
        if path:
            self.load_second_recording(path)

    def _recorded(self, path: str) -> None:
        if self.record_second.isChecked():
            self.load_second_recording(path)
        else:
            self.load_recording(path)

    def _assembly_for_recording(self):
        if self.record_second.isChecked():
            second, problem = self.assembly_panel.second_assembly()
            if second is not None:
                from taptune.io.assembly import assembly_to_toml

                return second, assembly_to_toml(second)
        return self.assembly_panel.assembly, self.assembly_panel.assembly_toml()

    def load_second_recording(self, path: str) -> None:
        """Read and analyse a recording of the same holder and tool at the 2nd stick-out.

        Its stick-out comes from the assembly file beside it when that file has the panel's
        holder and tool, else from the panel's "2nd stick-out" field.
        """
        from taptune.errors import InputError
        from taptune.io.assembly import load_assembly

        if self._identify_task is not None:
            show_error(self, "Busy", "Wait for the identification to end (or cancel it) first.")
            return
        first = self.assembly_panel.assembly
        if self.analysis is None or first is None:
            show_error(self, "Open the first recording first",
                       "The 2nd recording is the same holder and tool at another stick-out: open or record "
                       "the first one and describe its assembly on the left.")
            return
        toml_path = assembly_beside(path)
        if toml_path:
            try:
                beside = load_assembly(toml_path)
            except InputError as err:
                beside = None
                show_error(self, "Cannot use the assembly file", f"{err}\nThe 2nd stick-out field is used instead.")
            if beside is not None and (beside.holder, beside.tool) == (first.holder, first.tool):
                self.assembly_panel.set_second_stickout_mm(round(beside.stickout / 1e-3, 3))
            elif beside is not None:
                show_error(self, "Different holder or tool",
                           f"{toml_path} describes another holder or tool than the first recording; "
                           "only its stick-out would be right for a joint fit. The 2nd stick-out field "
                           "(left) is used.")
        second, problem = self.assembly_panel.second_assembly()
        if second is None:
            show_error(self, "Set the 2nd stick-out", f"Cannot open the 2nd recording yet: {problem}.")
            return
        self._analyse_second(str(path), second)

    def _analyse_second(self, path: str, assembly, recording=None) -> None:
        self.statusBar().showMessage(f"Analysing the 2nd recording {path}…")
        self._second_seq += 1
        seq = self._second_seq
        self._second_loading = self.runner.start(
            analyse_file, path, assembly, recording, with_progress=False,
            on_finished=lambda result: seq == self._second_seq and self._second_analysed(path, assembly, result),
            on_failed=lambda message: seq == self._second_seq and self._analysis_failed(path, message, second=True),
        )
        self._update_actions()

    def _second_analysed(self, path: str, assembly, result) -> None:
        self._second_loading = None
        recording, analysis, expected = result
        self.second = Take(path, recording, analysis, expected, assembly)
        self._show_second()
        self.banner.hide()
        self.show_view("spectrum")
        self.statusBar().showMessage(f"2nd recording analysed: {analysis.n_taps} taps. Identify both together.")
        self._update_file_label()
        self._update_actions()
        emit(self.analysis_ready, analysis)

    def _show_second(self) -> None:
        take = self.second
        text = f"2nd recording: {Path(take.path).name} — stick-out {take.assembly.stickout * 1e3:g} mm"
        self.second_label.setText("<b>Identified together with the recording above:</b> same holder and tool, "
                                  f"stick-out {take.assembly.stickout * 1e3:g} mm")
        self.spectrum2.show_analysis(take.analysis, text, take.expected_hz)
        self.second_pane.setVisible(True)

    def remove_second_recording(self) -> None:
        """Forget the 2nd recording (the next identification uses the first alone)."""
        if self._identify_task is not None:
            return
        self._second_seq += 1  # an analysis still running is ignored when it ends
        self._second_loading = None
        self.second = None
        self.second_pane.setVisible(False)
        self.spectrum2.clear("")
        self._update_file_label()
        self._update_actions()

    def relabel_second_peak(self, index: int, kind: str, mode) -> None:
        """Give peak ``index`` of the 2nd recording a new label."""
        if self.second is None or self._identify_task is not None:
            return
        self.second = dataclasses.replace(self.second, analysis=relabel(self.second.analysis, index, kind, mode))
        self._show_second()

    def _second_stickout_changed(self, _value: float) -> None:
        # The labels of the 2nd recording follow the model at its stick-out: analyse it
        # again once the edits settle.
        if self.second is not None:
            self._reanalyse.start()
        self._update_actions()

    def _update_file_label(self) -> None:
        names = [Path(p).name for p in (self.recording_path, self.second and self.second.path) if p]
        self.file_label.setText(" + ".join(names) or "No recording")
        self.file_label.setToolTip("\n".join(p for p in (self.recording_path, self.second and self.second.path) if p))

    def load_recording(self, path: str, assembly_path: str | None = None) -> None:
        """Read and analyse a recording in the background.

        The assembly comes from ``assembly_path``, else from the assembly file beside the
        recording (:func:`taptune.io.assembly.assembly_beside`), else from the panel as it is.
        """
        from taptune.errors import InputError

        if self._identify_task is not None:
            show_error(self, "Busy", "Wait for the identification to end (or cancel it) before opening a recording.")
            return
        toml_path = assembly_path or assembly_beside(path)
        if toml_path:
            try:
                self.assembly_panel.load_file(toml_path)
            except InputError as err:
                show_error(self, "Cannot use the assembly file", f"{err}\nThe assembly on the left is used instead.")
        self._reanalyse.stop()
        self.remove_second_recording()  # a new first recording starts a new session
        self.banner.hide()
        self._analyse(str(path))

    def _analyse(self, path: str, recording=None) -> None:
        assembly = self.assembly_panel.assembly
        self.statusBar().showMessage(f"Analysing {path}…")
        self._set_progress(None, "analysing the recording")
        # Only the latest request counts: an older analysis that ends later is ignored.
        self._analysis_seq += 1
        seq = self._analysis_seq
        task = self.runner.start(
            analyse_file, path, assembly, recording, with_progress=False,
            on_finished=lambda result: seq == self._analysis_seq and self._analysed(path, assembly, result),
            on_failed=lambda message: seq == self._analysis_seq and self._analysis_failed(path, message),
        )
        self._loading = task
        self._update_actions()

    def _analysed(self, path: str, assembly, result) -> None:
        self._loading = None
        recording, analysis, expected = result
        self.recording, self.recording_path, self.analysis, self.expected_hz = recording, path, analysis, expected
        self.analysed_assembly = assembly
        self._update_file_label()
        self._set_progress(0, "")
        title = f"{Path(path).name}" + (f" — {assembly.holder.name}, stick-out {assembly.stickout * 1e3:g} mm"
                                        if assembly is not None else " — no assembly: bending labels are a guess")
        self.spectrum.show_analysis(analysis, title, expected)
        self.show_view("spectrum")
        self.statusBar().showMessage(f"Analysed {path}: {analysis.n_taps} taps used.")
        self._update_actions()
        emit(self.analysis_ready, analysis)

    def _analysis_failed(self, path: str, message: str, second: bool = False) -> None:
        if second:
            self._second_loading = None
        else:
            self._loading = None
        self._set_progress(0, "")
        self.statusBar().showMessage(f"Could not analyse {path}", 10000)
        show_error(self, "Cannot analyse the recording", message)
        self._update_actions()
        emit(self.load_failed, message)

    def relabel_peak(self, index: int, kind: str, mode) -> None:
        """Give peak ``index`` a new label (from a click in the spectrum)."""
        if self.analysis is None or self._identify_task is not None:
            return
        self.analysis = relabel(self.analysis, index, kind, mode)
        title = self.spectrum.canvas.figure.axes[0].get_title(loc="left") if self.spectrum.canvas.figure.axes else ""
        self.spectrum.show_analysis(self.analysis, title, self.expected_hz)
        self.statusBar().showMessage("Peak relabelled; identify again to use the new labels.", 8000)

    def _assembly_changed(self, assembly) -> None:
        # The model's guess guides the peak labels: analyse again once the edits settle.
        if self.recording_path is not None and assembly is not None:
            self._reanalyse.start()
        self._retarget_predictor(assembly)
        self._update_actions()

    def _reanalyse_now(self) -> None:
        if self.recording_path is None or self.assembly_panel.assembly is None:
            return
        if self.busy:
            self._reanalyse.start()  # try again when the running job has ended
            return
        if self.assembly_panel.assembly != self.analysed_assembly:
            self._analyse(self.recording_path, self.recording)
        second, _problem = self.assembly_panel.second_assembly()
        if self.second is not None and second is not None and second != self.second.assembly:
            self._analyse_second(self.second.path, second, self.second.recording)

    # ------------------------------------------------------------------ identification

    def start_identification(self) -> None:
        """Fit the holder to the analysed recording in a worker thread (Cancel stops it)."""
        assemblies = self._assemblies()
        if self.analysis is None or None in assemblies or self.busy:
            return
        self._set_progress(0, "starting")
        self.banner.hide()
        joint = " from both recordings" if len(assemblies) == 2 else ""
        self.statusBar().showMessage(f"Identifying the holder{joint}… the window stays usable; Cancel stops it.")
        takes = [self.analysis] + ([self.second.analysis] if len(assemblies) == 2 else [])
        recordings = [self.recording] + ([self.second.recording] if len(assemblies) == 2 else [])
        self._identify_task = self.runner.start(
            run_identification, takes, assemblies, self.identify_options,
            on_finished=lambda result: self._identified(result, recordings, assemblies),
            on_failed=self._identification_failed,
            on_progress=self._set_progress,
            on_cancelled=self._identification_cancelled,
        )
        self._update_actions()

    def cancel_identification(self) -> None:
        if self._identify_task is not None:
            self._identify_task.cancel()
            self._set_progress(None, "cancelling")

    def _set_progress(self, fraction, message: str) -> None:
        # Shown only while something runs: an idle empty bar looks like an input field.
        self.progress.setVisible(bool(message) and message not in ("done",) or self.busy)
        if fraction is None:
            self.progress.setRange(0, 0)  # busy indicator
        else:
            self.progress.setRange(0, 1000)
            self.progress.setValue(int(round(1000 * max(0.0, min(1.0, fraction)))))
        self.progress.setFormat(message)

    def _identified(self, result, recordings, assemblies) -> None:
        assembly = assemblies[0]
        self._identify_task = None
        self.identification = result
        self.identified = (recordings, assemblies)
        self._set_progress(1.0, "done")
        names = [f"{Path(r.path).name} ({a.stickout * 1e3:g} mm)" for r, a in zip(recordings, assemblies)]
        self.fit.show_identification(result, f"{assembly.holder.name}: measured vs identified model", names)
        source = PredictorSource(f"identified now ({assembly.holder.name})", tuple(result.param_sets), assembly,
                                 self.identify_options.model, result.relative_floor, tuple(assemblies),
                                 measured_modes(result.bending_measured_hz))
        self.show_view("fit")
        if self.library_view.error is None:
            self.statusBar().showMessage(
                f"Identified in {result.seconds:.1f} s. Save it to the library, or predict other stick-outs.")
        else:
            self.statusBar().showMessage(
                f"Identified in {result.seconds:.1f} s. The holder library {self.library_view.location} "
                "cannot be read (Library tab), so it cannot be saved there; predict other stick-outs.")
        self._update_actions()
        emit(self.identification_ready, result)
        emit(self.identification_ended, "finished")
        # The predictions (the Predict and Machine views) and the second-tap advice start
        # after the fitted view has painted (queued before this timer): their threads
        # would otherwise share the interpreter with the drawing.
        QTimer.singleShot(0, self, lambda: self._after_identified(result, source, len(assemblies) == 1))

    def _after_identified(self, result, source, advise: bool) -> None:
        if self.identification is not result:
            return  # a newer identification has replaced it meanwhile
        self.set_holder_source(source)
        if advise:
            self._advise(result, source.assembly)

    def _advise(self, result, assembly) -> None:
        """Ask for a second tap when one recording leaves the bands wide. Its prediction
        (the band 20 mm further out, 0.2 s) runs after the fitted view is up; the banner
        shows only if no newer identification has replaced this one meanwhile."""

        def show(advice) -> None:
            line, details = advice or ("", "")
            if line and self.identification is result:
                self.banner.show_text(line, details)
            emit(self.advice_ready, line)

        def failed(message: str) -> None:
            self.statusBar().showMessage(f"No second-tap advice: {message}", 8000)
            emit(self.advice_ready, "")

        self.runner.start(second_tap_advice, result, assembly, on_finished=show, on_failed=failed,
                          with_progress=False)

    def _identification_failed(self, message: str) -> None:
        self._identify_task = None
        self._set_progress(0, "failed")
        show_error(self, "Identification failed", message)
        self._update_actions()
        emit(self.identification_ended, "failed")

    def _identification_cancelled(self) -> None:
        self._identify_task = None
        self._set_progress(0, "cancelled")
        self.statusBar().showMessage("Identification cancelled.", 8000)
        self._update_actions()
        emit(self.identification_ended, "cancelled")

    # ------------------------------------------------------------------ check

    def start_check(self) -> None:
        """Check the loaded tap against the library holder selected in the Library tab (worker thread).

        The tap's tool and stick-out are the panel's; the holder's geometry is the library's.
        """
        from taptune.errors import InputError

        entry = self.library_view.selected()
        assembly = self.assembly_panel.assembly
        if entry is None or self.recording is None or assembly is None or self.busy:
            return
        try:
            assembly = assembly.with_holder(entry.holder_geometry())
        except (InputError, TypeError, ValueError) as err:
            show_error(self, "Cannot check this holder with this tool", str(err))
            return
        self._set_progress(None, f"checking {entry.name}")
        self.statusBar().showMessage(f"Checking the tap against {entry.name!r}…")
        self._check_task = self.runner.start(
            run_check, self.recording, assembly, entry, self.library_view.library_path, with_progress=False,
            on_finished=self._checked, on_failed=self._check_failed)
        self._update_actions()

    def _checked(self, check) -> None:
        self._check_task = None
        self._set_progress(0, "")
        self.check_view.show_check(check)
        self.show_view("check")
        self.library_view.refresh()
        self.library_view.select(check.holder)
        if check.holder in self.library_view.entries:
            self.check_view.show_history(self.library_view.entries[check.holder])
        self.statusBar().showMessage(f"Check of {check.holder!r}: {check.verdict}.")
        self._update_actions()
        emit(self.check_ended, check)

    def _check_failed(self, message: str) -> None:
        self._check_task = None
        self._set_progress(0, "")
        show_error(self, "Check failed", f"{message}\nThe library is unchanged.")
        self._update_actions()
        emit(self.check_ended, None)

    # ------------------------------------------------------------------ library and prediction

    def save_to_library(self) -> str | None:
        """Store the identified holder in the library file; returns its name."""
        from taptune.errors import TaptuneError
        from taptune.library import HolderLibrary
        from taptune.library.record import entry_from_identification

        if self.identification is None:
            return None
        recordings, assemblies = self.identified
        try:
            entry = entry_from_identification(self.identification, recordings, assemblies,
                                              self.identify_options.model)
            HolderLibrary(self.library_view.library_path).put(entry)
        except (TaptuneError, OSError) as err:
            show_error(self, "Cannot save to the library",
                       f"{err}\nNothing was written; the identification is kept.")
            return None
        self.library_view.refresh()
        self.library_view.select(entry.name)
        self.statusBar().showMessage(f"Saved {entry.name!r} to {self.library_view.location}.")
        emit(self.saved_to_library, entry.name)
        return entry.name

    def use_library_entry(self, entry) -> None:
        """Predict with a library holder and the tool and stick-out of the panel."""
        from taptune.errors import InputError

        assembly = self.assembly_panel.assembly
        if assembly is None:
            show_error(self, "No tool", "Describe the tool and stick-out on the left first.")
            return
        try:
            assembly = assembly.with_holder(entry.holder_geometry())
            options = entry.options()
        except (InputError, TypeError, ValueError) as err:
            show_error(self, "Cannot use this holder with this tool", str(err))
            return
        sets = tuple(entry.prediction_sets())
        self.set_holder_source(PredictorSource(f"library ({entry.name})", sets, assembly, options,
                                               entry.relative_floor(), tuple(entry.identified_assemblies()),
                                               entry.measured_modes()))
        if self.tabs.currentWidget() is not self.machine:
            self.show_view("predict")

    def use_library_entry_on_machine(self, entry) -> None:
        """Lobes of a library holder with the panel's tool and stick-out (the Machine view)."""
        self.show_view("machine")
        self.use_library_entry(entry)

    def set_holder_source(self, source) -> None:
        """The holder parameters and assembly the predictor and the machine view work with."""
        self.predictor.set_source(source)
        self.machine.set_source(source)

    def _retarget_predictor(self, assembly) -> None:
        """The predictor follows the panel's tool; its holder stays the one its parameters belong to."""
        from taptune.errors import InputError

        source = self.predictor.source
        if source is None or assembly is None or assembly == source.assembly:
            return
        try:
            moved = assembly.with_holder(source.assembly.holder)
        except InputError as err:
            self.statusBar().showMessage(f"Prediction keeps the previous tool: {err}", 10000)
            return
        self.set_holder_source(dataclasses.replace(source, assembly=moved))

    # ------------------------------------------------------------------ drag and drop, closing

    def dragEnterEvent(self, event) -> None:
        if self._dropped_paths(event):
            event.acceptProposedAction()

    def dropEvent(self, event) -> None:
        paths = self._dropped_paths(event)
        audio = [p for p in paths if p.lower().endswith(AUDIO_SUFFIXES)]
        toml = [p for p in paths if p.lower().endswith(".toml")]
        event.acceptProposedAction()
        if audio:
            self.load_recording(audio[0], toml[0] if toml else None)
        elif toml:
            from taptune.errors import InputError

            try:
                self.assembly_panel.load_file(toml[0])
            except InputError as err:
                show_error(self, "Cannot open the assembly", str(err))

    @staticmethod
    def _dropped_paths(event) -> list[str]:
        mime = event.mimeData()
        if not mime.hasUrls():
            return []
        return [u.toLocalFile() for u in mime.urls()
                if u.isLocalFile() and u.toLocalFile().lower().endswith(AUDIO_SUFFIXES + (".toml",))]

    def closeEvent(self, event) -> None:
        # Stop the workers before Qt tears the window down; recordings are on disk already.
        self.recorder.shutdown()
        self.predictor.shutdown()
        self.machine.shutdown()
        self.runner.shutdown()
        super().closeEvent(event)
