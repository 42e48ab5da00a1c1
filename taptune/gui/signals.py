"""Emitting Qt signals safely from Python, and keeping ``None``/``True``/``False`` alive.

PySide6 6.12.0 on CPython 3.11 hands out ``None``, ``True`` and ``False`` without taking
a reference to them, as if they were immortal (they are from Python 3.12 on):

- ``SignalInstance.emit()`` and ``disconnect()`` return ``True`` that way: every call
  costs ``True`` one reference;
- every call of a Qt method that returns ``None`` (``setText``, ``update``, ``start``,
  a ``parent()`` that is null, …) costs ``None`` one reference — measured 4.5 per canvas
  redraw, so a session of slider drags wears ``None`` out.

When a count reaches zero the interpreter aborts ("Fatal Python error: none_dealloc" or
"bool_dealloc"). Whether the running PySide6 has these faults is measured once, on
import; where it does, the three objects get :data:`IMMORTAL` extra references — what
Python 3.12 does for them — so no session can wear them out, and :func:`emit` gives back
the reference each emit takes. Where it does not, nothing is changed.
"""

from __future__ import annotations

import ctypes
import sys

from PySide6.QtCore import QObject, Signal

# Extra references given to None, True and False: 2**40, more than any session can lose
# (a billion Qt calls a second would take 18 minutes); 2**29 where Py_ssize_t is 32 bits.
IMMORTAL = 1 << (40 if sys.maxsize > 2**32 else 29)


class _Probe(QObject):
    ping = Signal()


def _lost(obj, call, trials: int = 32) -> bool:
    """True if ``call()`` costs ``obj`` a reference on most of ``trials`` calls."""
    before = sys.getrefcount(obj)
    for _ in range(trials):
        call()
    return before - sys.getrefcount(obj) >= trials // 2


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


def _singletons_lose_references() -> bool:
    """Whether this PySide6 returns ``None`` (from a void call) or ``True`` (from
    ``disconnect``) without a reference; the references lost here are given back."""
    probe = _Probe()

    def reconnect() -> None:
        probe.ping.connect(_noop)
        probe.ping.disconnect(_noop)

    none_lost = _lost(None, lambda: probe.setObjectName("probe"))
    true_lost = _lost(True, reconnect)
    for obj, lost in ((None, none_lost), (True, true_lost)):
        if lost:
            ctypes.pythonapi.Py_IncRef(ctypes.py_object(obj))  # a few back; IMMORTAL covers the rest
    return none_lost or true_lost


def _noop() -> None:
    pass


def _make_immortal() -> None:
    """Add :data:`IMMORTAL` references to None, True and False (CPython < 3.12 only).

    ``ob_refcnt`` is the first field of every object in a release build of CPython.
    """
    for obj in (None, True, False):
        ctypes.c_ssize_t.from_address(id(obj)).value += IMMORTAL


_STEALS = _emit_steals_a_reference()
# ob_refcnt is the first field only in a build without trace-refs (sys.getobjects).
if (sys.implementation.name == "cpython" and sys.version_info < (3, 12) and not hasattr(sys, "getobjects")
        and _singletons_lose_references()):
    _make_immortal()


def emit(signal, *args) -> None:
    """``signal.emit(*args)``, returning the reference PySide6 6.12 takes from the result."""
    result = signal.emit(*args)
    if _STEALS:
        ctypes.pythonapi.Py_IncRef(ctypes.py_object(result))
