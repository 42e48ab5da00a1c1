"""Error types. Deep code raises these; the front ends turn them into messages.

``InputError`` means the user gave us something we cannot use (a file, a value, a
geometry): the CLI prints ``str(err)`` on one line and exits 2. Its message names the
file and the problem. Any other ``TaptuneError`` exits 1.
"""


class TaptuneError(Exception):
    """Base class of every error taptune raises on purpose."""


class InputError(TaptuneError):
    """Bad input from the user: unreadable or invalid file, impossible geometry, bad option."""


class DeviceError(TaptuneError):
    """No audio library, no input device, or a device that went away."""


class LibraryError(TaptuneError):
    """The holder library file is broken, locked too long, or has no such holder."""


class InterruptedAfterWrite(KeyboardInterrupt):
    """Ctrl-C arrived while a file was being put in place: the new file is complete and
    stays (``path``); the command stops there."""

    def __init__(self, path):
        super().__init__(str(path))
        self.path = path
