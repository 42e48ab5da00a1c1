"""Reading the user's small text files with one clear error per problem."""

from __future__ import annotations

from pathlib import Path

from taptune.errors import InputError

#: The environment variable that names the user's table of interface local-mode bands
#: (read by :func:`taptune.signal.labels.interface_bands`; here so that the command line
#: can protect that file from being written over without importing the analysis).
BANDS_ENV = "TAPTUNE_INTERFACE_BANDS"


def read_text(path: str | Path, what: str, expected: str) -> str:
    """The UTF-8 text of ``path``; every problem is an InputError naming the file.

    Parameters
    ----------
    what : str
        What the file should be, for messages ("an assembly file").
    expected : str
        Its format, for messages ("TOML").
    """
    name = str(path)
    try:
        raw = Path(path).read_bytes()
    except FileNotFoundError:
        raise InputError(f"{name}: no such file") from None
    except IsADirectoryError:
        raise InputError(f"{name}: is a folder, not {what}") from None
    except OSError as err:
        raise InputError(f"{name}: cannot read ({err.strerror})") from None
    try:
        return raw.decode("utf-8")
    except UnicodeDecodeError:
        raise InputError(f"{name}: not a UTF-8 text file ({what} is {expected})") from None
