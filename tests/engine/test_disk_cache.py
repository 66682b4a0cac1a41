"""Kernels compile once per machine, not once per process (engine/jit.py): a second
process loads the factory-built block kernel from numba's disk cache."""
import json
import os
import subprocess
import sys

PROBE = """
import json, time, numpy as np
from engine import params as P
from engine.batch import run_block
from engine.kernels import block_kernel
from engine.scene import Scene
from engine.settings import Settings
scene = Scene(friction="lugre", dither="square-velocity", method="rk4", slow_force=False,
              outputs=("v_mean",))
t0 = time.perf_counter()
res = run_block(scene, np.array([[0.4, 1000.0, 0.4, 0.1]]), P.pack(t_end=0.5), Settings())
kernel = block_kernel(scene)
print(json.dumps({"hits": sum(kernel.stats.cache_hits.values()),
                  "misses": sum(kernel.stats.cache_misses.values()),
                  "v_mean": float(res.outputs["v_mean"][0]),
                  "seconds": time.perf_counter() - t0}))
"""


def run_probe(cache_dir) -> dict:
    env = {**os.environ, "DITHERLAB_CACHE_DIR": str(cache_dir)}
    out = subprocess.run([sys.executable, "-c", PROBE], env=env, capture_output=True,
                         text=True, check=True)
    return json.loads(out.stdout.strip().splitlines()[-1])


def test_second_process_loads_the_kernel_from_disk(tmp_path):
    first = run_probe(tmp_path)
    second = run_probe(tmp_path)
    assert first["misses"] == 1 and first["hits"] == 0
    assert second["hits"] == 1 and second["misses"] == 0
    assert second["v_mean"] == first["v_mean"]          # the same machine code, bit for bit
    assert list(tmp_path.glob("numba-*"))               # the cache lives where we said


def test_distinct_closures_get_distinct_uuids():
    """numba maps a pickled dispatcher's UUID to the live dispatcher registered under it, so
    two kernels that differ only in a compile-time constant (here the order of the outputs)
    must not share a UUID -- else a cache load could link the wrong one (engine/jit.py)."""
    from engine.kernels import block_kernel
    from engine.scene import Scene

    a = Scene(friction="lugre", dither="none", method="rk4", outputs=("v_mean", "F_mean"))
    b = a.with_(outputs=("F_mean", "v_mean"))
    ua, ub = block_kernel(a)._ditherlab_uuid, block_kernel(b)._ditherlab_uuid
    assert ua.startswith("ditherlab-") and ub.startswith("ditherlab-") and ua != ub
    assert block_kernel(a.with_())._ditherlab_uuid == ua   # deterministic
