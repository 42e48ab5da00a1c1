"""Start the desktop app, or render its window to a PNG (``--screenshot``) and exit.

Qt and matplotlib are imported here and below only: ``taptune --help`` never loads them.
Where there is no display, Qt's offscreen platform renders the same window a user sees.
"""

from __future__ import annotations

import os
import sys

SCREENSHOT_TIMEOUT_S = 300


def _no_display() -> bool:
    return sys.platform.startswith("linux") and not (os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY"))


def _ensure_platform() -> None:
    if _no_display():
        os.environ.setdefault("QT_QPA_PLATFORM", "offscreen")


def application():
    """The QApplication (created once)."""
    _ensure_platform()
    from PySide6.QtWidgets import QApplication

    app = QApplication.instance()
    if app is None:
        app = QApplication([sys.argv[0] if sys.argv else "taptune"])
        app.setApplicationName("taptune")
        app.setOrganizationName("taptune")
    return app


def install_excepthook(window) -> None:
    """Show an error that escaped a Qt callback as a message instead of losing it on stderr.

    The session (recording, assembly, library) is untouched by such an error, so the
    user can go on; the traceback goes to the log for a bug report.
    """
    import logging
    import traceback

    from taptune.gui.messages import show_error
    from taptune.gui.workers import describe_error

    log = logging.getLogger("taptune.gui")

    def hook(exc_type, exc, tb):
        if issubclass(exc_type, KeyboardInterrupt):
            sys.__excepthook__(exc_type, exc, tb)
            return
        log.error("unexpected error in the window:\n%s", "".join(traceback.format_exception(exc_type, exc, tb)))
        show_error(window, "Something went wrong", f"{describe_error(exc)}\nYour recording, assembly and library are unchanged.")

    sys.excepthook = hook


def wait_for(signal, timeout_s: float):
    """Run the event loop until ``signal`` fires (or the timeout); returns its arguments or None."""
    from PySide6.QtCore import QEventLoop, QTimer

    loop = QEventLoop()
    received = []

    def got(*args):
        received.append(args)
        loop.quit()

    signal.connect(got)
    QTimer.singleShot(int(timeout_s * 1000), loop.quit)
    loop.exec()
    signal.disconnect(got)
    return received[0] if received else None


def settle(window, predictor_timeout_s: float = 30.0) -> None:
    """Let pending background updates and repaints finish before a picture is taken."""
    from PySide6.QtCore import QEventLoop, QTimer

    loop = QEventLoop()
    QTimer.singleShot(0, loop.quit)  # updates queued to start after a paint (a new identification's)
    loop.exec()
    if window.predictor.busy:
        wait_for(window.predictor.predicted, predictor_timeout_s)
    if window.machine.busy:
        wait_for(window.machine.updated, predictor_timeout_s)
    # The picture shows what the machinist sees once the semi-discretization and its band
    # are drawn over the preview (the SDM takes seconds, not the slider's 0.3 s).
    if window.machine.refining:
        wait_for(window.machine.refined, 4 * predictor_timeout_s)
    for _ in range(3):
        loop = QEventLoop()
        QTimer.singleShot(50, loop.quit)
        loop.exec()


def start_process_pool():
    """Start the identification workers once and make every identification use them.

    Forking under Qt's threads is unsafe, so they are ``spawn``-started interpreters,
    kept warm for the whole session (:class:`taptune.identify.search.WarmPool`); they
    start in the background while the window opens. Returns the pool.
    """
    from taptune.identify import search

    pool = search.shared_pool()
    if pool is None:
        pool = search.WarmPool()
        search.set_shared_pool(pool)
    return pool


def stop_process_pool() -> None:
    """Stop the workers of :func:`start_process_pool` (at exit)."""
    from taptune.identify import search

    pool = search.shared_pool()
    if pool is not None:
        search.set_shared_pool(None)
        pool.close()


def run(wav=None, assembly=None, library=None, screenshot=None, size=(1366, 768), view=None,
        identify: bool = False, holder=None, second=None, machine=None, check: bool = False) -> int:
    """Open the main window (and load ``wav``); with ``screenshot`` save a PNG of it and return.

    ``holder`` (a library entry) opens the predictor with it and the assembly's tool;
    ``second`` is a recording at another stick-out, identified jointly with ``wav``;
    ``machine`` a machine file for the Machine view (remembered unless taking a screenshot);
    ``check`` checks ``wav`` against ``holder`` before the screenshot. ``view`` is a view's
    name, or a list of names with ``screenshot`` a file name holding ``{view}``: one
    picture per view from one window (what the real-display test takes).

    Returns the exit status: 0, or 2 when the recording could not be analysed in
    screenshot mode (the picture shows the message), 1 when identification failed.
    """
    if not screenshot and _no_display() and os.environ.get("QT_QPA_PLATFORM", "offscreen") == "offscreen":
        from taptune.errors import TaptuneError

        # An invisible window would wait forever: say so instead.
        raise TaptuneError("no display to show the window on (DISPLAY is not set); run it on the desktop, "
                           "or use --screenshot PNG to render the window to a file")
    app = application()
    from taptune.gui.main_window import MainWindow
    from taptune.identify import IdentifyOptions
    from taptune.library import default_library_path

    # Both cores identify; a screenshot without identification needs no workers.
    pool = start_process_pool() if identify or not screenshot else None
    options = IdentifyOptions(seed=0, jobs=pool.processes if pool else 1)
    window = MainWindow(default_library_path(library), identify_options=options)
    if machine:
        window.machine.load_machine(str(machine), remember=not screenshot)
    previous_hook = sys.excepthook
    install_excepthook(window)
    try:
        return _show(app, window, wav, assembly, screenshot, size, view, identify, holder, second, check)
    finally:
        sys.excepthook = previous_hook
        stop_process_pool()


def _show(app, window, wav, assembly, screenshot, size, view, identify, holder, second=None, check=False) -> int:
    window.resize(*size)
    if assembly:
        window.assembly_panel.load_file(assembly)
    window.show()
    if holder is not None:
        window.use_library_entry(holder)
    status = 0
    if wav:
        window.load_recording(str(wav), assembly)
        if second and not screenshot:
            def then_second(_analysis):
                window.analysis_ready.disconnect(then_second)
                window.load_second_recording(str(second))

            window.analysis_ready.connect(then_second)
        if screenshot:
            outcome = _wait_analysis(window)
            if outcome == "ok" and second:
                window.load_second_recording(str(second))
                outcome = _wait_analysis(window)
            if outcome != "ok":
                print(f"taptune gui: {outcome}", file=sys.stderr)
                status = 2
            elif identify:
                window.start_identification()
                ended = wait_for(window.identification_ended, SCREENSHOT_TIMEOUT_S)
                if not ended or ended[0] != "finished":
                    print("taptune gui: identification did not finish", file=sys.stderr)
                    status = 1
                elif not second:
                    wait_for(window.advice_ready, SCREENSHOT_TIMEOUT_S)  # the picture shows the advice too
            if check and status == 0:
                window.library_view.select(holder.name)
                window.start_check()
                ended = wait_for(window.check_ended, SCREENSHOT_TIMEOUT_S)
                if not ended or ended[0] is None:
                    print("taptune gui: the check did not finish", file=sys.stderr)
                    status = 1
    if not screenshot:
        return app.exec()
    # Several views: one picture each, named by the "{view}" in the file name.
    views = [view] if view is None or isinstance(view, str) else list(view)
    for name in views:
        if name:
            window.show_view(name)
        settle(window)
        path = screenshot.replace("{view}", name) if len(views) > 1 else screenshot
        if not _save_png(window.grab(), path):
            print(f"taptune gui: cannot write {path}", file=sys.stderr)
            status = 1
    window.close()
    return status


def _save_png(pixmap, path) -> bool:
    """Save ``pixmap`` as a PNG through :mod:`taptune.io.atomic` (an old picture stays whole on failure)."""
    from taptune.io.atomic import atomic_write

    def write(tmp) -> None:
        if not pixmap.save(str(tmp), "PNG"):
            raise OSError(f"cannot write {path}")

    try:
        atomic_write(path, write)
    except OSError:
        return False
    return True


def _wait_analysis(window) -> str:
    """'ok' once the recording is analysed, else the failure message."""
    from PySide6.QtCore import QEventLoop, QTimer

    if window.analysis is not None and not window.busy:
        return "ok"
    loop = QEventLoop()
    outcome = []
    window.analysis_ready.connect(lambda _a: (outcome.append("ok"), loop.quit()))
    window.load_failed.connect(lambda m: (outcome.append(m), loop.quit()))
    QTimer.singleShot(SCREENSHOT_TIMEOUT_S * 1000, loop.quit)
    loop.exec()
    return outcome[0] if outcome else "analysis timed out"
