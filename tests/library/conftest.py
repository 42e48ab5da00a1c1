"""Fixtures of the holder-library tests."""

import pytest

from taptune.library import HolderLibrary


@pytest.fixture
def lib(tmp_path) -> HolderLibrary:
    """An empty library in a folder that does not exist yet."""
    return HolderLibrary(tmp_path / "data" / "taptune" / "holders.json", lock_timeout=20.0)
