"""A throw-away PostgreSQL server for the tests: initdb into a temporary folder, started once per session.

The server listens on a unix socket in that folder and on 127.0.0.1 (a free port) only,
runs as a non-root user (initdb refuses root: ``runuser -u postgres`` or ``nobody`` when
the tests run as root), uses trust on the socket and passwords on TCP (for the
wrong-password test), and is stopped and deleted at the end. Without PostgreSQL or
psycopg the tests that need it skip — unless ``CI`` is set, where they fail.
"""

from __future__ import annotations

import glob
import itertools
import os
import pwd
import shutil
import socket
import subprocess
import tempfile
from dataclasses import dataclass
from pathlib import Path

import pytest

ADMIN = "taptune_admin"
#: A role with a password, for logging in over TCP.
PASSWORD_ROLE, PASSWORD = "taptune_pw", "s3cret-pw"


@dataclass(frozen=True)
class Server:
    socket_dir: Path
    port: int

    def url(self, database: str = "postgres", user: str = ADMIN) -> str:
        return f"postgresql://{user}@/{database}?host={self.socket_dir}&port={self.port}"

    def tcp_url(self, database: str, user: str = PASSWORD_ROLE, password: str = PASSWORD) -> str:
        return f"postgresql://{user}:{password}@127.0.0.1:{self.port}/{database}"

    def admin(self, *statements: str) -> None:
        import psycopg

        with psycopg.connect(self.url(), autocommit=True) as conn:
            for s in statements:
                conn.execute(s)


def _unavailable(why: str):
    if os.environ.get("CI"):
        pytest.fail(f"PostgreSQL tests cannot run on CI: {why}")
    pytest.skip(why)


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def start_server():
    """Start the server; yields a :class:`Server` and stops it afterwards (a generator for a fixture)."""
    initdbs = sorted(glob.glob("/usr/lib/postgresql/*/bin/initdb"))
    bindir = Path(initdbs[-1]).parent if initdbs else (Path(p).parent if (p := shutil.which("initdb")) else None)
    if bindir is None:
        _unavailable("PostgreSQL is not installed (no initdb)")
    try:
        import psycopg  # noqa: F401
    except ImportError:
        _unavailable("psycopg is not installed (pip install 'psycopg[binary]')")
    base = Path(tempfile.mkdtemp(prefix="taptune-pg-", dir="/tmp"))
    runas: list[str] = []
    if os.geteuid() == 0:
        user = next((u for u in ("postgres", "nobody") if _has_user(u)), None)
        if user is None:
            _unavailable("running as root without a 'postgres' or 'nobody' user to run PostgreSQL")
        entry = pwd.getpwnam(user)
        os.chown(base, entry.pw_uid, entry.pw_gid)
        runas = ["runuser", "-u", user, "--"]
    data, port = base / "data", _free_port()
    env = {**os.environ, "LC_ALL": "C.UTF-8", "LANG": "C.UTF-8"}
    run = dict(check=True, capture_output=True, text=True, env=env, cwd=base)
    try:
        subprocess.run(runas + [str(bindir / "initdb"), "-D", str(data), "-U", ADMIN, "-E", "UTF8", "--no-sync",
                                "--auth-local=trust", "--auth-host=scram-sha-256"], **run)
        options = f"-k {base} -p {port} -c listen_addresses=127.0.0.1 -c fsync=off -c max_connections=60"
        subprocess.run(runas + [str(bindir / "pg_ctl"), "-D", str(data), "-o", options, "-l", str(base / "log"),
                                "-w", "-t", "60", "start"], **run)
    except subprocess.CalledProcessError as err:
        shutil.rmtree(base, ignore_errors=True)
        pytest.fail(f"could not start PostgreSQL: {err.stderr or err.stdout}")
    server = Server(base, port)
    server.admin(f"CREATE ROLE {PASSWORD_ROLE} LOGIN PASSWORD '{PASSWORD}'")
    try:
        yield server
    finally:
        subprocess.run(runas + [str(bindir / "pg_ctl"), "-D", str(data), "-m", "immediate", "-w", "stop"],
                       capture_output=True, env=env, cwd=base)
        shutil.rmtree(base, ignore_errors=True)


def _has_user(name: str) -> bool:
    try:
        pwd.getpwnam(name)
    except KeyError:
        return False
    return True


_numbers = itertools.count()


def fresh_database(server: Server, owner: str = ADMIN) -> str:
    """A new empty database; returns its name."""
    name = f"lib_{os.getpid()}_{next(_numbers)}"
    server.admin(f"CREATE DATABASE {name} OWNER {owner} TEMPLATE template0")
    return name


@pytest.fixture(scope="session")
def postgres_server():
    """The session's throw-away PostgreSQL server (see the module docstring)."""
    yield from start_server()


@pytest.fixture
def pg_url(postgres_server) -> str:
    """The URL of a new, empty database on the test server (one per test)."""
    return postgres_server.url(fresh_database(postgres_server))
