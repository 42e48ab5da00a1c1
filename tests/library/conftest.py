"""Fixtures of the holder-library tests: the JSON file, and the same tests on SQLite and PostgreSQL."""

import pytest

from taptune.library import HolderLibrary
from tests.library.pg import pg_url, postgres_server  # noqa: F401  (fixtures)


@pytest.fixture
def lib(tmp_path) -> HolderLibrary:
    """An empty JSON library in a folder that does not exist yet."""
    return HolderLibrary(tmp_path / "data" / "taptune" / "holders.json", lock_timeout=20.0)


@pytest.fixture(params=["sqlite", "postgresql"])
def db_location(request, tmp_path) -> str:
    """Where an empty database library is: an SQLite file (in a folder not made yet) or a PostgreSQL database."""
    if request.param == "sqlite":
        return str(tmp_path / "data" / "taptune" / "holders.db")
    return request.getfixturevalue("pg_url")


@pytest.fixture
def db(db_location) -> HolderLibrary:
    """An empty database library, SQLite or PostgreSQL (every test using it runs on both)."""
    lib = HolderLibrary(db_location, lock_timeout=20.0)
    yield lib
    lib.close()
