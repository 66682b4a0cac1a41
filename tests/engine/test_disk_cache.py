"""Kernels compile once per machine, not once per process (engine/jit.py): a second
process loads the factory-built block kernel from numba's disk cache."""
import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

PROBE = """
import json, time, numpy as np
from engine import params as P
from engine.blocks import run_block
from engine.kernels import block_kernel
from engine.scene import Scene
from engine.settings import Settings
scene = Scene(friction="lugre", dither="square-velocity", integrator="rk4", slow_force=False,
              outputs=("v_mean",))
t0 = time.perf_counter()
res = run_block(scene, np.array([[0.4, 1000.0, 0.4, 0.1]]), P.pack(t_end=0.5), Settings())
kernel = block_kernel(scene)
import sys, numba.np.arraymath, numba.np.linalg
print(json.dumps({"hits": sum(kernel.stats.cache_hits.values()),
                  "misses": sum(kernel.stats.cache_misses.values()),
                  "v_mean": float(res.outputs["v_mean"][0]),
                  "seconds": time.perf_counter() - t0,
                  "scipy.linalg": "scipy.linalg" in sys.modules,
                  "blas": numba.np.arraymath._HAVE_BLAS,
                  "probe": numba.np.linalg.ensure_blas.__module__}))
"""


def run_probe(cache_dir) -> dict:
    env = {**os.environ, "DITHERLAB_CACHE_DIR": str(cache_dir)}
    out = subprocess.run([sys.executable, "-c", PROBE], env=env, capture_output=True,
                         text=True, check=True)
    return json.loads(out.stdout.strip().splitlines()[-1])


@pytest.mark.long
def test_second_process_loads_the_kernel_from_disk(tmp_path):
    first = run_probe(tmp_path)
    second = run_probe(tmp_path)
    assert first["misses"] == 1 and first["hits"] == 0
    assert second["hits"] == 1 and second["misses"] == 0
    assert second["v_mean"] == first["v_mean"]          # the same machine code, bit for bit
    assert list(tmp_path.glob("numba-*"))               # the cache lives where we said
    for run in (first, second):   # compiled, then loaded: numba's BLAS probe answered, not
        # run (engine.jit.load_numba_registries), and numba's own probe back in place
        assert (run["scipy.linalg"], run["blas"], run["probe"]) == (False, True, "numba.np.linalg")


def test_distinct_closures_get_distinct_uuids():
    """numba maps a pickled dispatcher's UUID to the live dispatcher registered under it, so
    two kernels that differ only in a compile-time constant (here the order of the outputs)
    must not share a UUID -- else a cache load could link the wrong one (engine/jit.py)."""
    from engine.kernels import block_kernel
    from engine.scene import Scene

    a = Scene(friction="lugre", dither="none", integrator="rk4", outputs=("v_mean", "F_mean"))
    b = a.with_(outputs=("F_mean", "v_mean"))
    ua, ub = block_kernel(a)._ditherlab_uuid, block_kernel(b)._ditherlab_uuid
    assert ua.startswith("ditherlab-") and ub.startswith("ditherlab-") and ua != ub
    assert block_kernel(a.with_())._ditherlab_uuid == ua   # deterministic


PAIR = """
import json, sys, numpy as np
from engine import params as P
from engine.blocks import run_block
from engine.scene import Scene
from engine.settings import Settings
base = Scene(friction="lugre", dither="none", integrator="rk4", outputs=("v_mean", "F_mean"))
res = {}
for order in sys.argv[1:]:
    scene = base.with_(outputs=tuple(order.split(",")))
    out = run_block(scene, np.array([[0.0, 1.0, 0.4, 0.1]]), P.pack(t_end=2.0), Settings())
    res[order] = {k: float(v[0]) for k, v in out.outputs.items()}
print(json.dumps(res))
"""


def run_pair(cache_dir, *orders) -> dict:
    env = {**os.environ, "DITHERLAB_CACHE_DIR": str(cache_dir)}
    out = subprocess.run([sys.executable, "-c", PAIR, *orders], env=env, capture_output=True,
                         text=True, check=True)
    return json.loads(out.stdout.strip().splitlines()[-1])


@pytest.mark.long
def test_kernels_cached_by_different_processes_do_not_collide(tmp_path):
    """Two closures of one factory compiled in two processes get the same per-process
    function counter; numba names machine code by qualified name + counter, so without
    unique names a third process loading both from the disk cache linked the first one's
    code for both (found: a block kernel returned another scene's output columns). Each
    closure's name now carries its UUID (engine/jit.py)."""
    a, b = "v_mean,F_mean", "F_mean,v_mean"
    fresh = {**run_pair(tmp_path, a),     # process 1 compiles a (the cache is empty) and caches it
             **run_pair(tmp_path, b)}     # process 2 compiles b (another closure) and caches it
    loaded = run_pair(tmp_path, a, b)     # process 3 loads both
    assert loaded == fresh


# a factory in a module of its own folder: numba's fallback cache is that folder's __pycache__
FACTORY = """
from engine.jit import njit

def make(a):
    @njit(entry=True)   # (called from Python: a kernel, cached with its wrapper)
    def scale(x):
        return x * a
    return scale
"""
RELOAD = """
import os, sys
import numba
from engine.jit import cache_dir
os.environ["NUMBA_CUDA_LOW_OCCUPANCY_WARNINGS"] = "0"   # as engine.gpu sets it
numba.njit(lambda x: x + 1.0)(1.0)   # a compile: numba re-reads its configuration here
sys.path.insert(0, sys.argv[1])
import factory
factory.make(2.0)(1.0)   # a kernel made after the reload
print(cache_dir())
"""


def test_a_numba_config_reload_keeps_new_kernels_in_the_engine_cache(tmp_path):
    """numba re-reads its configuration from the environment at the first compile after any
    NUMBA_* variable changed (engine.gpu sets one), which put CACHE_DIR back to "": every
    kernel made after that in the process was cached in its source folder's __pycache__ (the
    checkout's engine/, a cache no engine fingerprint names) and missed the engine's cache --
    in CI the GPU simulator's child compiled 11 of its 13 scenes so, 13-22 s each, although
    test_engine_vs_scipy had put five of them in the engine's cache."""
    (tmp_path / "src").mkdir()
    (tmp_path / "src" / "factory.py").write_text(FACTORY)
    env = {**os.environ, "DITHERLAB_CACHE_DIR": str(tmp_path / "cache")}
    out = subprocess.run([sys.executable, "-c", RELOAD, str(tmp_path / "src")], env=env,
                         capture_output=True, text=True)
    assert out.returncode == 0, out.stderr[-2000:]
    engine_cache = out.stdout.strip().splitlines()[-1]
    assert not list((tmp_path / "src").rglob("*.nbi")), "cached in the source folder"
    assert list(Path(engine_cache).rglob("factory.make.locals.scale*.nbi"))
