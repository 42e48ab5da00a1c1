"""Background updates that follow a slider: one call at a time, and only the latest request waits.

Dragging a slider asks for many updates; computing each in turn would queue work and
show stale pictures for seconds. :class:`LatestOnly` runs one call in a worker thread;
requests that arrive meanwhile replace each other, and the last one runs when the
current call ends. A result that a newer request has already overtaken is not shown.
"""

from __future__ import annotations

from typing import Callable

from PySide6.QtCore import QObject

from taptune.gui.workers import TaskRunner


class LatestOnly(QObject):
    """Run ``fn(*args)`` in the background, skipping every request but the latest.

    ``on_result(result)`` and ``on_error(message)`` run on the GUI thread.
    """

    def __init__(self, on_result: Callable, on_error: Callable, parent=None):
        super().__init__(parent)
        self._runner = TaskRunner(self)
        self._on_result, self._on_error = on_result, on_error
        self._running = False
        self._pending: tuple | None = None

    @property
    def busy(self) -> bool:
        """True while a call runs or one waits."""
        return self._running or self._pending is not None

    def request(self, fn: Callable, *args) -> None:
        if self._running:
            self._pending = (fn, args)
            return
        self._running = True
        self._runner.start(fn, *args, with_progress=False, on_finished=self._finished, on_failed=self._failed)

    def _finished(self, result) -> None:
        if self._pending is None:
            self._on_result(result)
        self._next()

    def _failed(self, message: str) -> None:
        if self._pending is None:
            self._on_error(message)
        self._next()

    def _next(self) -> None:
        self._running = False
        if self._pending is not None:
            (fn, args), self._pending = self._pending, None
            self.request(fn, *args)

    def shutdown(self) -> None:
        self._pending = None
        self._runner.shutdown()
