"""The kernel cache's files are checked (engine.kernel_cache): a damaged file or index is
compiled again and written anew, and a folder that cannot be written costs a compile in
each process with one warning, never a wrong kernel or a failed point.

Each case runs a small kernel of the engine's ``njit`` in fresh processes (a module in
the test's folder, cached in ``$DITHERLAB_CACHE_DIR`` as the engine's own kernels are).
Before: a flipped bit in a cached block kernel changed every point of a sweep without a
word; truncated files or a garbage index failed every block at every submit; a full
folder failed every block with ``OSError: [Errno 28]``; a read-only one sent the kernels
into the source tree's ``__pycache__``, which no engine fingerprint names."""
from __future__ import annotations

import json
import os
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

pytestmark = pytest.mark.subprocess

KERNEL = '''
from engine.jit import njit


@njit(error_model="numpy", entry=True)   # (called from Python: cached with its wrapper)
def scaled(x):
    return x * 1.2345678901234567 + 0.5
'''
RUN = '''
import json, logging, sys
logging.basicConfig(format="%(message)s")
import smallkernel
value = smallkernel.scaled(2.0)
print(json.dumps({"value": value, "hits": sum(smallkernel.scaled.stats.cache_hits.values()),
                  "misses": sum(smallkernel.scaled.stats.cache_misses.values())}))
'''
EXPECTED = 2.0 * 1.2345678901234567 + 0.5


@pytest.fixture
def kernel(tmp_path):
    (tmp_path / "smallkernel.py").write_text(textwrap.dedent(KERNEL))
    return tmp_path


def run(folder: Path, cache: Path) -> tuple[dict, str]:
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(folder), os.getcwd()]),
           "DITHERLAB_CACHE_DIR": str(cache)}
    proc = subprocess.run([sys.executable, "-c", RUN], capture_output=True, text=True,
                          env=env, cwd=folder, timeout=300)
    assert proc.returncode == 0, proc.stderr
    return json.loads(proc.stdout.strip().splitlines()[-1]), proc.stderr


def cache_files(cache: Path, suffix: str) -> list[Path]:
    return [p for p in cache.rglob(f"smallkernel.scaled*{suffix}")]


@pytest.mark.parametrize("damage", ["flip a bit", "truncate", "zeros", "garbage index"])
def test_a_damaged_cache_file_is_compiled_again_not_loaded(kernel, tmp_path, damage):
    cache = tmp_path / "kernel-cache"
    first, _ = run(kernel, cache)
    assert first == {"value": EXPECTED, "hits": 0, "misses": 1}
    [data] = cache_files(cache, ".nbc")
    [index] = cache_files(cache, ".nbi")
    raw = bytearray(data.read_bytes())
    if damage == "flip a bit":
        raw[len(raw) // 2] ^= 0x10
        data.write_bytes(raw)
    elif damage == "truncate":
        data.write_bytes(raw[:len(raw) // 2])
    elif damage == "zeros":
        raw[len(raw) // 4:len(raw) // 2] = bytes(len(raw) // 2 - len(raw) // 4)
        data.write_bytes(raw)
    else:
        index.write_bytes(os.urandom(300))
    again, err = run(kernel, cache)
    assert again == {"value": EXPECTED, "hits": 0, "misses": 1}, err
    assert err.count("is damaged") == 1 and "compiling what it held again" in err, err
    third, err = run(kernel, cache)   # written anew: loaded, unsaid
    assert third == {"value": EXPECTED, "hits": 1, "misses": 0} and err == "", err


def test_a_cache_folder_that_cannot_be_written_compiles_in_each_process(kernel, tmp_path):
    """Here a folder under a file (no folder can be made there); a full or read-only disk
    is the same case (checked by hand: a 64 KiB tmpfs, a read-only bind mount)."""
    blocker = tmp_path / "a-file"
    blocker.write_text("")
    for _ in range(2):
        out, err = run(kernel, blocker / "kernel-cache")
        assert out["value"] == EXPECTED and out["hits"] == 0, err   # (uncached)
        assert err.count("cannot be written") == 1 and "DITHERLAB_CACHE_DIR" in err, err
    assert not list(kernel.rglob("*.nbi")) and not list(kernel.rglob("*.nbc"))  # not in-tree


def test_a_full_cache_folder_costs_a_compile_not_the_kernel(kernel, tmpfs):
    """A disk filled to the last byte: the folders and the probe (empty files) are made,
    the kernel's files are not."""
    disk = tmpfs("1M")
    fd = os.open(disk / "filler", os.O_CREAT | os.O_WRONLY)
    try:
        while os.write(fd, bytes(4096)):
            pass
    except OSError:
        pass
    finally:
        os.close(fd)
    for _ in range(2):
        out, err = run(kernel, disk)
        assert out["value"] == EXPECTED and out["hits"] == 0, err
        assert err.count("cannot be written (No space left on device)") == 1, err


def test_a_kernel_numba_would_cache_outside_the_engine_folder_is_left_uncached(tmp_path):
    """numba falls back to the source folder's ``__pycache__`` when it cannot make its
    subfolder of the engine's cache (a review): such a kernel gets no disk cache at all,
    never one that no engine fingerprint names; one in the engine's folder keeps its own."""
    from numba.core.caching import NullCache

    from engine import kernel_cache
    from engine.jit import njit

    @njit
    def plus_one(x):
        return x + 1.0

    kernel_cache.uncached_elsewhere(plus_one)
    assert not isinstance(plus_one._cache, NullCache)   # (the engine's folder)
    plus_one._cache._cache_path = str(tmp_path / "__pycache__")   # numba's fallback
    kernel_cache.uncached_elsewhere(plus_one)
    assert isinstance(plus_one._cache, NullCache) and plus_one(1.0) == 2.0
