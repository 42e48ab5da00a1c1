"""Background tasks: a bad-input failure reaches the user as one line, with no traceback in the log."""

from __future__ import annotations

import logging

import pytest

from taptune.errors import InputError
from taptune.gui.workers import TaskWorker


def _fail_with(err):
    def fn():
        raise err
    return fn


def _run_failing(fn):
    """Run ``fn`` in a TaskWorker (here, on this thread); the messages its ``failed`` signal sent."""
    worker = TaskWorker(fn, with_progress=False)
    failed = []
    worker.failed.connect(failed.append)
    worker._run()
    return failed


def test_bad_input_is_one_line_and_no_traceback(qtbot, caplog):
    caplog.set_level(logging.DEBUG, logger="taptune.gui.workers")
    failed = _run_failing(_fail_with(InputError("/tmp/empty.wav: the file is empty")))
    assert failed == ["/tmp/empty.wav: the file is empty"]
    assert len(caplog.records) <= 1
    for record in caplog.records:
        assert record.levelno < logging.WARNING  # the window shows it; the log need not shout
        assert "Traceback" not in record.getMessage() and record.exc_info is None
        assert "\n" not in record.getMessage()
    assert "Traceback" not in caplog.text


@pytest.mark.parametrize("err", [ValueError("shape mismatch"), ZeroDivisionError("division by zero")])
def test_an_unexpected_error_keeps_its_traceback_in_the_log(qtbot, caplog, err):
    caplog.set_level(logging.DEBUG, logger="taptune.gui.workers")
    failed = _run_failing(_fail_with(err))
    assert failed == [f"unexpected error ({type(err).__name__}: {err})"]
    assert any(r.levelno >= logging.ERROR for r in caplog.records)
    assert "Traceback" in caplog.text and type(err).__name__ in caplog.text


def test_a_model_failure_keeps_its_traceback_in_the_log(qtbot, caplog):
    """Not bad input: a model that cannot be solved is worth its traceback."""
    from taptune.model.eigen import ModelError

    caplog.set_level(logging.DEBUG, logger="taptune.gui.workers")
    _run_failing(_fail_with(ModelError("K̃ − ω²M is singular")))
    assert any(r.levelno >= logging.ERROR for r in caplog.records)
    assert "Traceback" in caplog.text and "ModelError" in caplog.text
