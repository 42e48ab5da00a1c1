"""What every pool of worker processes shares (identification, SDM lobes, bulk import, batch)."""

from __future__ import annotations

import signal


def ignore_interrupt() -> None:
    """Initializer of a worker process: Ctrl-C is the parent's to handle.

    Ctrl-C reaches the terminal's whole process group. A worker that took it too printed
    its own KeyboardInterrupt traceback, and one interrupted while sending its result left
    half a message in the pipe, on which the parent's pool then waited for ever. The
    parent cancels and stops its workers instead.
    """
    signal.signal(signal.SIGINT, signal.SIG_IGN)
