"""The holder library: one JSON file of identified holders, written atomically under a lock.

``HolderLibrary(path)`` reads, validates and changes the file; ``HolderEntry`` is one
holder (geometry, best parameters, near-optimal sets, model options, provenance);
``default_library_path()`` resolves ``--library``, ``TAPTUNE_LIBRARY`` and the user data
folder. Atomic file writing is :mod:`taptune.io.atomic`. Import/export and receptance files live in :mod:`taptune.library.exchange`
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
from taptune.library.store import HolderLibrary, default_library_path

__all__ = [
    "SCHEMA",
    "VERSION",
    "HolderEntry",
    "HolderLibrary",
    "LibraryFormatError",
    "ProvenanceRecord",
    "UnknownHolderError",
    "default_library_path",
    "sha256_file",
    "tool_from_dict",
    "tool_to_dict",
    "utc_now",
]
