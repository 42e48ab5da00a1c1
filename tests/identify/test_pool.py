"""A warm spawn pool (the app's workers) gives the result of one process, and can cancel."""

import glob
import os
import tempfile
import threading

import pytest

from taptune.identify import Cancelled, GAOptions, IdentifyOptions, identify
from taptune.identify import search

from .helpers import model_analysis
from .test_identify import HOLDER_A

SMALL = dict(islands=2, ga=GAOptions(population=24, generations=8, patience=4), polish_evaluations=40,
             polish_starts=2, extreme_axes=(0, 4), extreme_evaluations=40, near_candidates=40)


@pytest.fixture
def problem(reference_assembly):
    return reference_assembly, model_analysis(reference_assembly, HOLDER_A)


@pytest.fixture(scope="module")
def warm_pool():
    pool = search.WarmPool(2)
    yield pool
    pool.close()


def _same(a, b):
    a, b = a.to_dict(), b.to_dict()
    a.pop("seconds"), b.pop("seconds")
    assert a == b


@pytest.mark.slow
def test_the_warm_pool_gives_the_single_process_result_from_a_thread(problem, warm_pool):
    """From a non-main thread (as in the app), identically to jobs=1, twice on the same workers."""
    asm, analysis = problem
    alone = identify([analysis], [asm], IdentifyOptions(seed=4, jobs=1, **SMALL))
    results = []

    def work():
        for _ in range(2):
            results.append(identify([analysis], [asm], IdentifyOptions(seed=4, jobs=2, **SMALL)))

    def shared_files():
        return set(glob.glob(os.path.join("/dev/shm", "taptune-objective-*"))
                   + glob.glob(os.path.join(tempfile.gettempdir(), "taptune-objective-*")))

    before = shared_files()
    search.set_shared_pool(warm_pool)
    try:
        thread = threading.Thread(target=work)
        thread.start()
        thread.join(120)
    finally:
        search.set_shared_pool(None)
    assert len(results) == 2
    for r in results:
        _same(alone, r)
    # The objective went to the workers through one temporary file, removed afterwards
    # (files of other taptune processes running meanwhile aside).
    assert shared_files() <= before


@pytest.mark.slow
def test_the_warm_pool_can_cancel_and_is_reusable(problem, warm_pool):
    asm, analysis = problem
    calls = []
    search.set_shared_pool(warm_pool)
    try:
        with pytest.raises(Cancelled):
            identify([analysis], [asm], IdentifyOptions(seed=1, jobs=2, **SMALL),
                     progress=lambda f, m: calls.append(f) or len(calls) < 3)
        again = identify([analysis], [asm], IdentifyOptions(seed=1, jobs=2, **SMALL))
    finally:
        search.set_shared_pool(None)
    _same(identify([analysis], [asm], IdentifyOptions(seed=1, jobs=1, **SMALL)), again)


def test_without_a_pool_a_thread_does_not_fork():
    """Forking while other threads run is unsafe: from a thread, jobs > 1 runs in-process."""
    seen = []

    def work():
        # The objective is only stored for the tasks: none is needed to see where they would run.
        with search.Workers(None, IdentifyOptions(jobs=2, **SMALL)) as w:
            seen.append((w.pool, w.warm))

    thread = threading.Thread(target=work)
    thread.start()
    thread.join(30)
    assert seen == [(None, None)]


def test_a_shared_file_that_cannot_be_written_is_removed(monkeypatch, tmp_path):
    import errno

    made, real_fdopen, real_mkstemp = [], os.fdopen, tempfile.mkstemp

    def mkstemp(**kw):
        fd, path = real_mkstemp(**{**kw, "dir": str(tmp_path)})  # shared memory or not: here
        made.append(path)
        return fd, path

    def full(fd, mode):
        f = real_fdopen(fd, mode)
        f.close()
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(search.tempfile, "mkstemp", mkstemp)
    monkeypatch.setattr(search.os, "fdopen", full)
    with pytest.raises(OSError, match="No space"):
        search._shared_file(b"x" * 100)
    assert made and not any(os.path.exists(p) for p in made)
    if not (os.path.isdir("/dev/shm") and os.access("/dev/shm", os.W_OK)):
        return  # one place only: the fall-back below does not apply
    # With room in the second place the blob lands there and nothing else is left.
    calls = []

    def first_full(fd, mode):
        calls.append(fd)
        return full(fd, mode) if len(calls) == 1 else real_fdopen(fd, mode)

    monkeypatch.setattr(search.os, "fdopen", first_full)
    made.clear()
    path = search._shared_file(b"blob")
    assert open(path, "rb").read() == b"blob"
    assert [p for p in made if os.path.exists(p)] == [path]


def test_shared_memory_that_cannot_even_make_the_file_falls_back(monkeypatch, tmp_path):
    import errno

    if not (os.path.isdir("/dev/shm") and os.access("/dev/shm", os.W_OK)):
        pytest.skip("no shared memory here: one place only")
    real_mkstemp = tempfile.mkstemp

    def mkstemp(**kw):
        if kw.get("dir") == "/dev/shm":  # out of inodes (or open files) there
            raise OSError(errno.ENOSPC, "No space left on device")
        return real_mkstemp(**{**kw, "dir": str(tmp_path)})

    monkeypatch.setattr(search.tempfile, "mkstemp", mkstemp)
    path = search._shared_file(b"blob")
    assert os.path.dirname(path) == str(tmp_path) and open(path, "rb").read() == b"blob"


def test_workers_leave_ctrl_c_to_the_parent(warm_pool):
    """A worker that took SIGINT too printed its own KeyboardInterrupt traceback on Ctrl-C."""
    import signal
    from types import SimpleNamespace

    options = SimpleNamespace(jobs=2, islands=2, ga=SimpleNamespace(generations=1))
    with search.Workers(None, options) as forked:  # the CLI's pool, forked per identification
        assert forked.pool.apply(signal.getsignal, (signal.SIGINT,)) == signal.SIG_IGN
    assert warm_pool.pool.apply(signal.getsignal, (signal.SIGINT,)) == signal.SIG_IGN


def _until_cancelled(_):
    """A task that runs until the identification is cancelled (a GA island checks each generation)."""
    import time

    deadline = time.monotonic() + 20
    while not search.STATE["cancel"].is_set() and time.monotonic() < deadline:
        time.sleep(0.01)
    return search.STATE["cancel"].is_set()


@pytest.mark.parametrize("kind", ["forked", "warm"])
def test_leaving_mid_phase_cancels_the_tasks_and_lets_them_return(kind, request):
    """Ctrl-C (or an error) while tasks run: they are cancelled and return before the workers
    are stopped or handed on. Stopping a worker while it writes its result can hang the pool
    for good."""
    from types import SimpleNamespace

    def interrupt(fraction, message):
        raise KeyboardInterrupt

    warm = request.getfixturevalue("warm_pool") if kind == "warm" else None
    options = SimpleNamespace(jobs=2, islands=2, ga=SimpleNamespace(generations=1))
    search.set_shared_pool(warm)
    try:
        with pytest.raises(KeyboardInterrupt):
            with search.Workers(None, options, progress=interrupt) as workers:
                assert (workers.warm is warm) and ((workers.pool is None) == (kind == "warm"))
                workers.map(_until_cancelled, range(2))
    finally:
        search.set_shared_pool(None)
    assert workers.pending.ready() and workers.pending.get() == [True, True]
    if warm is not None:  # handed on: the next identification may start
        assert warm.lock.acquire(timeout=1)
        warm.lock.release()
