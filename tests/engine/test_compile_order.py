"""A kernel's machine code, hence its bits, must not depend on what its process compiled
before it or loaded from the disk cache.

numba compiles helpers such as float ``x ** 2`` once per process and keeps them in
``BaseContext.cached_internal_func``, keyed without the fastmath flags. DP5's ``attempt``
(``fastmath={'contract'}``) then gets the helper with or without ``contract`` depending on
whether a function without fastmath that uses ``** 2`` was compiled first in that process. So
the same kernel comes out with or without an FMA in ``err += (ei / sc) ** 2``, depending
on which other kernels the process found in the disk cache. Measured on the e2e-sim spec:
v_mean, v_slow_p2p and F_mean differ at 2 of 8 points (up to 3e-13 relative), the same
variables that test_external_cluster_gives_the_local_cube saw differ.

Both tests failed before engine/jit.py gave each fastmath setting its own helper cache.
"""
import os
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest

from ..sweeps.conftest import SIMULATE_SPEC as SPEC   # 8 points, LuGre, square dither, draft

BLOCKS = """
import sys, numpy as np
from sweeps.spec import load_spec
from sweeps.planning.plan import make_plan
from engine.blocks import run_block
plan = make_plan(load_spec(sys.argv[1]))
res = {}
for b in range(len(plan.blocks)):
    r = run_block(plan.scene, plan.block_points(b), plan.params, plan.numerics.settings)
    for k, v in r.outputs.items():
        res.setdefault(k, np.full(plan.n_points, np.nan))[plan.blocks[b]] = v
np.savez(sys.argv[2], **res)
"""

# the kernels that call DP5's attempt (and attempt itself): deleted from the cache so that
# the next process loads everything else and compiles these
CALLERS = ("dopri5._make_attempt.locals.attempt__", "driver.make_solve.locals.solve__",
           "kernels.point_kernel.locals.run_point__", "kernels.block_kernel.locals.run__")


def _blocks(tmp_path, cache, out) -> dict:
    spec = tmp_path / "spec.toml"
    spec.write_text(SPEC)
    script = tmp_path / "blocks.py"
    script.write_text(BLOCKS)
    env = {**os.environ, "DITHERLAB_CACHE_DIR": str(cache)}
    subprocess.run([sys.executable, str(script), str(spec), str(out)], env=env, check=True,
                   timeout=900)
    with np.load(out) as z:
        return {k: z[k] for k in z.files}


@pytest.mark.long
def test_block_bits_do_not_depend_on_what_the_disk_cache_held(tmp_path):
    cache = tmp_path / "cache"
    fresh = _blocks(tmp_path, cache, tmp_path / "fresh.npz")      # everything compiled here
    removed = [p for p in cache.rglob("*.nb[ic]") if p.name.startswith(CALLERS)]
    assert removed, "no cached DP5 kernels found: the cache layout changed"
    for p in removed:
        p.unlink()
    partial = _blocks(tmp_path, cache, tmp_path / "partial.npz")  # the rest loaded from disk
    for name in fresh:
        np.testing.assert_array_equal(partial[name], fresh[name], err_msg=name)


MINI = """
import sys
import engine.jit  # noqa: F401 -- the fix lives here (it must be in effect before compiling)
import numpy as np
from numba import njit

@njit
def plain(x):
    return x ** 2

@njit(fastmath={"contract"})
def norm2(v):
    err = 0.0
    for i in range(v.size):
        err += (v[i] / 3.0) ** 2
    return err

if sys.argv[1] == "plain-first":
    plain(1.5)
print(norm2(np.random.default_rng(0).random(1000)).hex())
"""


@pytest.mark.long
def test_a_contracted_function_does_not_depend_on_compilation_order(tmp_path):
    """The numba-level mechanism, in isolation (no disk cache involved)."""
    script = tmp_path / "mini.py"
    script.write_text(textwrap.dedent(MINI))
    env = {**os.environ, "DITHERLAB_CACHE_DIR": str(tmp_path / "cache")}
    out = [subprocess.run([sys.executable, str(script), order], env=env, check=True,
                          capture_output=True, text=True, timeout=300).stdout.strip()
           for order in ("contract-first", "plain-first")]
    assert out[0] == out[1], out
