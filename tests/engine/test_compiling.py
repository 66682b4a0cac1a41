"""engine.compiling.compile_lock: one holder at a time until what it makes is ready, then
holders that only load from the cache share the lock (issue 37: 16 workers loading a
kernel one after another waited ~1 s for the last).

The lock's mode is read with a second open file of the lock (``flock`` with ``LOCK_NB``):
a shared probe fails against an exclusive holder, an exclusive one against any holder. No
kernel is compiled: the lock guards whatever runs inside it; ``scene`` is any object with
a ``repr``."""
import contextlib
import fcntl
import os
import threading

import pytest

from engine import compiling
from engine.jit import cache_dir

SCENE = ("a scene", 1)
JOIN_S = 60   # only a failure waits this long (a holder that never gets in)


@pytest.fixture(autouse=True)
def own_cache(tmp_path, monkeypatch):
    monkeypatch.setenv("DITHERLAB_CACHE_DIR", str(tmp_path))


def _lock_file():
    (path,) = (cache_dir() / "compiling").glob("*.lock")
    return path


def _mode() -> str:
    """How the scene's lock is held now, seen from another open file of it."""
    fd = os.open(_lock_file(), os.O_RDWR)
    try:
        try:
            fcntl.flock(fd, fcntl.LOCK_SH | fcntl.LOCK_NB)
        except BlockingIOError:
            return "exclusive"
        fcntl.flock(fd, fcntl.LOCK_UN)
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            return "shared"
        return "free"
    finally:
        os.close(fd)


def _ready_files():
    return sorted(p.name for p in (cache_dir() / "compiling").glob("*.ready"))


def test_the_first_holder_is_alone_and_later_ones_share():
    with compiling.compile_lock(SCENE, ready="warm-up"):
        assert _mode() == "exclusive"
        assert _ready_files() == []
    assert len(_ready_files()) == 1 and _mode() == "free"
    with compiling.compile_lock(SCENE, ready="warm-up"):
        assert _mode() == "shared"
    # another name, or none, is not ready: alone again
    with compiling.compile_lock(SCENE, ready="warm-up at another rtol"):
        assert _mode() == "exclusive"
    with compiling.compile_lock(SCENE):
        assert _mode() == "exclusive"


def test_holders_of_a_ready_name_are_inside_at_once():
    """Four threads (each its own open file, as four worker processes) inside together:
    taken in turn, the barrier would never fill."""
    with compiling.compile_lock(SCENE, ready="warm-up"):
        pass
    inside = threading.Barrier(4, timeout=JOIN_S)
    modes = []

    def hold():
        with compiling.compile_lock(SCENE, ready="warm-up"):
            inside.wait()
            modes.append(_mode())

    threads = [threading.Thread(target=hold) for _ in range(4)]
    for t in threads:
        t.start()
    for t in threads:
        t.join(JOIN_S)
    assert modes == ["shared"] * 4


@pytest.mark.parametrize("first_fails", [False, True])
def test_a_holder_waiting_for_a_compile_shares_once_it_is_ready(monkeypatch, first_fails):
    """A second holder arrives while the first compiles (exclusive, nothing ready yet): it
    waits sharing, and is then in shared, or alone if the first one failed (nothing is
    ready: it compiles itself)."""
    real_flock = fcntl.flock
    waiting = threading.Event()

    def flock(fd, op):
        if threading.current_thread().name == "second" and op == fcntl.LOCK_SH:
            waiting.set()   # about to wait for the first holder, sharing
        return real_flock(fd, op)

    monkeypatch.setattr(fcntl, "flock", flock)
    seen = {}

    def second():
        with compiling.compile_lock(SCENE, ready="warm-up"):
            seen["mode"] = _mode()
            seen["ready"] = _ready_files()

    with pytest.raises(RuntimeError, match="compile failed") if first_fails else \
            contextlib.nullcontext():
        with compiling.compile_lock(SCENE, ready="warm-up"):
            t = threading.Thread(target=second, name="second")
            t.start()
            assert waiting.wait(JOIN_S)
            assert _mode() == "exclusive" and "mode" not in seen
            if first_fails:
                raise RuntimeError("compile failed")
    t.join(JOIN_S)
    if first_fails:   # the second compiled alone, and made it ready
        assert seen == {"mode": "exclusive", "ready": []} and len(_ready_files()) == 1
    else:
        assert seen["mode"] == "shared" and len(seen["ready"]) == 1


def test_the_lock_is_reentrant_in_a_thread_whatever_the_name():
    with compiling.compile_lock(SCENE, ready="warm-up"):
        with compiling.compile_lock(SCENE):   # engine.blocks.run_block inside a warm-up
            assert _mode() == "exclusive"
    assert _mode() == "free"
