"""PySide6 must not wear out ``True`` or ``None``: 6.12.0 takes a reference to ``True`` per emit
and disconnect, and to ``None`` per Qt call that returns ``None``. With a sound PySide6 (the
one taptune asks for) these run through unrepaired; with 6.12.0 only the repair saves them."""

import sys

from PySide6.QtCore import QObject, Signal
from PySide6.QtWidgets import QWidget

from taptune.gui import signals
from taptune.gui.signals import emit


class _Source(QObject):
    progress = Signal(float, str)


def _references(obj) -> int:
    """References the program holds to ``obj`` (without the ones the repair added)."""
    count = sys.getrefcount(obj)
    return count - signals.IMMORTAL if count > signals.IMMORTAL // 2 else count


def test_ten_thousand_emits_leave_the_refcount_of_true_alone(qtbot):
    source = _Source()
    received = []
    source.progress.connect(lambda f, m: received.append(f))
    before = sys.getrefcount(True)
    for i in range(10000):
        emit(source.progress, i / 10000, "fitting")
    # Without the compensation this drops by 10 000 (and the interpreter aborts near 0).
    assert abs(sys.getrefcount(True) - before) < 100
    assert len(received) == 10000


def test_more_void_qt_calls_than_references_to_none_do_not_abort(qtbot):
    # Each setEnabled() costs None a reference: without the repair the interpreter aborts
    # ("Fatal Python error: none_dealloc") before the loop ends — a canvas redraw makes 4-5
    # such calls, so a long session of slider drags got there too.
    widget = QWidget()
    qtbot.addWidget(widget)
    before = sys.getrefcount(None)
    calls = _references(None) + 10000
    for _ in range(calls):
        widget.setEnabled(True)
    assert widget.isEnabled()
    _sound_or_repaired(None, before)


def test_more_disconnects_than_references_to_true_do_not_abort(qtbot):
    # Each disconnect() returns True without a reference ("bool_dealloc" without the repair).
    source = _Source()
    received = []

    def slot(fraction, message):
        received.append(fraction)

    before = sys.getrefcount(True)
    for _ in range(_references(True) + 1000):
        source.progress.connect(slot)
        source.progress.disconnect(slot)
    emit(source.progress, 0.5, "done")
    assert received == []
    _sound_or_repaired(True, before)


def _sound_or_repaired(obj, before: int) -> None:
    """The binding kept its references to ``obj`` (6.11), or the repair made it immortal (6.12.0)."""
    after = sys.getrefcount(obj)
    assert after > signals.IMMORTAL // 2 or abs(after - before) < 100, (before, after)
