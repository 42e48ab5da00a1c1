"""Background work for the GUI: any long call runs in a QThread and reports through signals.

The window never waits for the physics: :class:`TaskRunner` moves a :class:`TaskWorker`
to a fresh QThread, passes it a ``progress(fraction, message) -> bool`` callback (the
contract of ``taptune.identify.identify``) and delivers the result, an error message or
"cancelled" back on the GUI thread through queued signals.
"""

from __future__ import annotations

import logging
import threading
import traceback
from typing import Callable

from PySide6.QtCore import QObject, QThread, Signal, Slot

from taptune.gui.signals import emit

log = logging.getLogger(__name__)


def describe_error(err: BaseException) -> str:
    """A one-paragraph message for the user: taptune's own errors as they are, others with their type."""
    from taptune.errors import TaptuneError

    if isinstance(err, TaptuneError):
        return str(err)
    if isinstance(err, MemoryError):
        return "out of memory"
    return f"unexpected error ({type(err).__name__}: {err})"


class TaskWorker(QObject):
    """Runs ``fn(*args, progress=callback, **kwargs)`` once, in whatever thread it lives in.

    Signals
    -------
    progress(float, str)
        Fraction done (0–1) and what is happening.
    finished(object)
        The return value.
    failed(str)
        A message for the user. The traceback of unexpected errors goes to the log at
        ERROR level; taptune's own errors (:class:`~taptune.errors.TaptuneError`, such as
        an InputError naming a bad file) only as one line at INFO level.
    cancelled()
        :meth:`cancel` was called and the function stopped.
    """

    progress = Signal(float, str)
    finished = Signal(object)
    failed = Signal(str)
    cancelled = Signal()

    def __init__(self, fn: Callable, *args, with_progress: bool = True, **kwargs):
        super().__init__()
        self._fn, self._args, self._kwargs = fn, args, kwargs
        self._with_progress = with_progress
        self._cancel = threading.Event()

    def cancel(self) -> None:
        """Ask the function to stop at its next progress report (thread-safe)."""
        self._cancel.set()

    @property
    def cancel_requested(self) -> bool:
        return self._cancel.is_set()

    def _report(self, fraction: float, message: str = "") -> bool:
        emit(self.progress, float(fraction), str(message))
        return not self._cancel.is_set()

    @Slot()
    def run(self) -> None:
        try:
            self._run()
        finally:
            # End the thread from inside: the GUI thread may be blocked waiting for it
            # (window closing) and cannot deliver the queued quit.
            QThread.currentThread().quit()

    def _run(self) -> None:
        kwargs = dict(self._kwargs)
        if self._with_progress:
            kwargs["progress"] = self._report
        try:
            result = self._fn(*self._args, **kwargs)
        except BaseException as err:  # noqa: BLE001 - every failure must reach the user as a message
            if self._cancel.is_set():
                emit(self.cancelled)
            else:
                from taptune.errors import InputError

                if isinstance(err, InputError):
                    # Bad input: its message names the file and the problem, and the window
                    # shows it; a traceback would only alarm. A model failure keeps it.
                    log.info("background task failed: %s", err)
                else:
                    log.error("background task failed:\n%s", traceback.format_exc())
                emit(self.failed, describe_error(err))
            return
        if self._cancel.is_set():
            emit(self.cancelled)
        else:
            emit(self.finished, result)


class Task(QObject):
    """A running background call: its worker, its thread and the callbacks to deliver to.

    Lives in the GUI thread, so the worker's signals reach the callbacks through queued
    connections (on the GUI thread) whatever thread emitted them.
    """

    done = Signal()  # emitted after any outcome, once the callbacks ran

    def __init__(self, worker: TaskWorker, on_finished, on_failed, on_progress, on_cancelled, parent=None):
        super().__init__(parent)
        self.worker = worker
        self.thread = QThread()
        self._callbacks = (on_finished, on_failed, on_progress, on_cancelled)
        self.running = False
        worker.moveToThread(self.thread)
        self.thread.started.connect(worker.run)
        worker.finished.connect(self._finished)
        worker.failed.connect(self._failed)
        worker.cancelled.connect(self._cancelled)
        worker.progress.connect(self._progress)

    def start(self) -> None:
        self.running = True
        self.thread.start()

    def cancel(self) -> None:
        self.worker.cancel()

    def wait(self, ms: int = 30000) -> bool:
        """Block until the thread ended (for closing the window); True if it did."""
        return self.thread.wait(ms)

    def _end(self, callback, *args) -> None:
        self.running = False
        self.thread.quit()
        self.thread.wait()
        try:
            if callback is not None:
                callback(*args)
        finally:
            emit(self.done)

    @Slot(object)
    def _finished(self, result) -> None:
        self._end(self._callbacks[0], result)

    @Slot(str)
    def _failed(self, message: str) -> None:
        self._end(self._callbacks[1], message)

    @Slot()
    def _cancelled(self) -> None:
        self._end(self._callbacks[3])

    @Slot(float, str)
    def _progress(self, fraction: float, message: str) -> None:
        if self._callbacks[2] is not None and self.running:
            self._callbacks[2](fraction, message)


class TaskRunner(QObject):
    """Starts background tasks and keeps them alive until they end."""

    def __init__(self, parent=None):
        super().__init__(parent)
        self._tasks: set[Task] = set()

    def start(self, fn: Callable, *args, on_finished=None, on_failed=None, on_progress=None,
              on_cancelled=None, with_progress: bool = True, **kwargs) -> Task:
        """Run ``fn`` in a new thread; the callbacks run on the GUI thread."""
        task = Task(TaskWorker(fn, *args, with_progress=with_progress, **kwargs),
                    on_finished, on_failed, on_progress, on_cancelled, parent=self)
        self._tasks.add(task)
        task.done.connect(lambda: self._forget(task))
        task.start()
        return task

    def _forget(self, task: Task) -> None:
        self._tasks.discard(task)
        task.deleteLater()

    @property
    def busy(self) -> bool:
        return any(t.running for t in self._tasks)

    def shutdown(self, ms: int = 30000) -> None:
        """Cancel every task and wait for its thread (window closing)."""
        for task in list(self._tasks):
            task.cancel()
        for task in list(self._tasks):
            # A computation inside numpy cannot be stopped, and a QThread destroyed while it
            # runs aborts the whole app (seen: the Machine view closed while the lobes'
            # band was computed): past ``ms`` wait for it to end rather than crash.
            if not task.wait(ms):
                task.thread.wait()
