"""Emitting Qt signals safely from Python.

PySide6 6.12.0 on CPython 3.11 returns the bool of ``SignalInstance.emit()`` without
taking a reference to it: every emit from Python costs ``True`` one reference, and after
a few thousand emits (one identification's progress reports) the interpreter aborts
with "Fatal Python error: bool_dealloc". :func:`emit` gives the reference back. Whether
the running PySide6 has the bug is measured once; where it does not, nothing is added.
"""

from __future__ import annotations

import ctypes
import sys

from PySide6.QtCore import QObject, Signal


class _Probe(QObject):
    ping = Signal()


def _emit_steals_a_reference() -> bool:
    probe = _Probe()
    trials = 32
    before = sys.getrefcount(True)
    results = [probe.ping.emit() for _ in range(trials)]
    stolen = results.count(True)
    del results
    lost = before - sys.getrefcount(True)
    if lost >= trials // 2:
        for _ in range(stolen):
            ctypes.pythonapi.Py_IncRef(ctypes.py_object(True))
        return True
    return False


_STEALS = _emit_steals_a_reference()


def emit(signal, *args) -> None:
    """``signal.emit(*args)``, returning the reference PySide6 6.12 takes from the result."""
    result = signal.emit(*args)
    if _STEALS:
        ctypes.pythonapi.Py_IncRef(ctypes.py_object(result))
