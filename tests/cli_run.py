"""Running a taptune command inside a test, as the user would from the shell."""

from __future__ import annotations

from taptune.cli import main


def taptune(capsys, *argv) -> tuple[int, str, str]:
    """Run ``taptune *argv`` in this process: ``(exit code, stdout, stderr)``."""
    code = main([str(a) for a in argv])
    out, err = capsys.readouterr()
    return code, out, err


def one_line_error(capsys, *argv) -> str:
    """Run a command that must fail on bad input: exit 2, one line on stderr, no traceback."""
    code, out, err = taptune(capsys, *argv)
    assert code == 2, (out, err)
    assert err.count("\n") == 1 and "Traceback" not in err, err
    return err
