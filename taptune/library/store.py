"""The holder library: :class:`HolderLibrary` and where it is (:func:`default_library_path`).

The interface and the shared logic are in :mod:`taptune.library.base`; the stores in
:mod:`taptune.library.sql_store` (SQLite, PostgreSQL) and :mod:`taptune.library.json_store`
(the JSON file). Importing this module registers them, so ``HolderLibrary(location)``
opens whichever ``location`` names.
"""

from taptune.library import json_store, sql_store  # noqa: F401  (register the stores)
from taptune.library.base import (ENV_VAR, FILE_NAME, LOCK_TIMEOUT_S, OLD_FILE_NAME, SUGGESTION_POOL, HolderLibrary,
                                  HolderSummary, default_library_path, is_server_url, library_files, store_kind)

__all__ = ["ENV_VAR", "FILE_NAME", "LOCK_TIMEOUT_S", "OLD_FILE_NAME", "SUGGESTION_POOL", "HolderLibrary",
           "HolderSummary", "default_library_path", "is_server_url", "library_files", "store_kind"]
