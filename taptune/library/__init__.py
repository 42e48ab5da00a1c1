"""The holder library: identified holders in an SQLite database, a shop's PostgreSQL server or a JSON file.

``HolderLibrary(location)`` opens the library (the store is chosen by the location, see
:mod:`taptune.library.store`); ``HolderEntry`` is one holder (geometry, best parameters,
near-optimal sets, model options, provenance); ``default_library_path()`` resolves
``--library``, ``TAPTUNE_LIBRARY`` and the user data folder. Atomic file writing is :mod:`taptune.io.atomic`. Import/export and receptance files live in :mod:`taptune.library.exchange`
(imported on use, so pyuff is only needed there).
"""

from taptune.library.schema import (
    SCHEMA,
    VERSION,
    HolderEntry,
    LibraryFormatError,
    ProvenanceRecord,
    UnknownHolderError,
    sha256_file,
    tool_from_dict,
    tool_to_dict,
    utc_now,
)
from taptune.library.store import HolderLibrary, HolderSummary, default_library_path

__all__ = [
    "SCHEMA",
    "VERSION",
    "HolderEntry",
    "HolderLibrary",
    "HolderSummary",
    "LibraryFormatError",
    "ProvenanceRecord",
    "UnknownHolderError",
    "default_library_path",
    "sha256_file",
    "tool_from_dict",
    "tool_to_dict",
    "utc_now",
]
