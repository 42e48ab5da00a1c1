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


@pytest.fixture(params=["json", "sqlite", "postgresql"])
def any_lib(request, tmp_path) -> HolderLibrary:
    """An empty library of each kind: the JSON file, SQLite and PostgreSQL (tests using it run on all three)."""
    if request.param == "json":
        location = tmp_path / "data" / "taptune" / "holders.json"
    elif request.param == "sqlite":
        location = tmp_path / "data" / "taptune" / "holders.db"
    else:
        location = request.getfixturevalue("pg_url")
    lib = HolderLibrary(location, lock_timeout=20.0)
    yield lib
    lib.close()


def snapshot(lib: HolderLibrary):
    """Everything a library holds, to compare before and after (the file's bytes for JSON)."""
    if lib.kind == "json":
        return lib.path.read_bytes()
    return {name: entry.to_dict() for name, entry in lib.iter_entries()}


@pytest.fixture
def db(db_location) -> HolderLibrary:
    """An empty database library, SQLite or PostgreSQL (every test using it runs on both)."""
    lib = HolderLibrary(db_location, lock_timeout=20.0)
    yield lib
    lib.close()
