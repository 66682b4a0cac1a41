"""numba's registries load without its BLAS probe's import of scipy.linalg
(engine.jit.load_numba_registries) on every way into the engine -- a sweep's block kernel
(tests/engine/test_disk_cache.py), one trajectory (engine.api.simulate), the analysis
path -- and the linear algebra numba offers still works."""
import json
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]

# the probe's decisions after the load, printed as JSON by each child
REPORT = """
import json, sys, numba.np.arraymath as am, numba.np.linalg as la
print(json.dumps({**got, "scipy.linalg": "scipy.linalg" in sys.modules,
                  "blas": am._HAVE_BLAS, "probe": la.ensure_blas.__module__,
                  "arraymath's probe": am.ensure_blas.__module__}))
"""

ENTRIES = {
    # one trajectory of test_engine_sampling's (and test_engine_vs_scipy's) point kernel
    # (before, simulate's first compile was numba's own, of the kernel's allocator: the
    # probe ran)
    "simulate": """
from engine import params as P
from engine.api import simulate
from tests.engine.common import scene
got = {"value": simulate(scene("lugre", "none", outputs=("F_mean",)),
                         P.pack(t_end=0.5)).outputs["F_mean"]}
""",
    # the averaged path of the tests' averaged spec (its kernels are module-level functions)
    "analysis": """
import tomllib
from engine.blocks import run_block
from sweeps.planning.plan import make_plan
from sweeps.spec import parse_spec
from tests.helpers import AVERAGED_SPEC
plan = make_plan(parse_spec(tomllib.loads(AVERAGED_SPEC)))
res = run_block(plan.scene, plan.block_points(0)[:2], plan.params, plan.numerics.settings)
got = {"value": float(res.outputs["F_eff"][1])}   # (the effective friction)
""",
    # a brought law may call numba's linear algebra: np.dot, np.vdot and np.linalg.solve
    # import scipy.linalg at their compile; np.correlate reads the probe's answer
    # (arraymath._HAVE_BLAS: BLAS's dot or numba's own loop)
    "linear algebra": """
import numba, numpy as np
from engine.jit import load_numba_registries
load_numba_registries()
before = "scipy.linalg" in sys.modules
load_numba_registries()   # (a no-op now)
a, b = np.arange(1.0, 4.0), np.array([0.5, -2.0, 4.0])
got = {"before": before,
       "dot": numba.njit(lambda a, b: np.dot(a, b))(a, b),
       "vdot": numba.njit(lambda a, b: np.vdot(a, b))(a, b),
       "correlate": numba.njit(lambda a, b: np.correlate(a, b))(a, b).tolist(),
       "solve": numba.njit(lambda m, v: np.linalg.solve(m, v))(np.diag(a), b).tolist(),
       "numpy": [float(a @ b), np.correlate(a, b).tolist()]}
""",
}


def run_child(entry: str) -> dict:
    code = "import sys\n" + ENTRIES[entry] + REPORT
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         cwd=ROOT, check=True)   # (cwd: the tests package importable)
    return json.loads(out.stdout.strip().splitlines()[-1])


@pytest.mark.parametrize("entry", ["simulate", "analysis"])
def test_a_first_kernel_loads_without_importing_scipy_linalg(entry):
    got = run_child(entry)
    assert got["value"] == got["value"]   # (a number, not NaN: the kernel ran)
    assert got["scipy.linalg"] is False and got["blas"] is True
    assert got["probe"] == got["arraymath's probe"] == "numba.np.linalg"   # numba's, back


def test_brought_linear_algebra_still_finds_scipys_blas():
    """A law a user brings may call ``np.dot`` or ``np.linalg``: after the registries load
    without the import, numba's compile of such a call imports scipy.linalg and calls its
    BLAS and LAPACK, as before."""
    got = run_child("linear algebra")
    assert got["before"] is False and got["scipy.linalg"] is True
    assert got["dot"] == got["vdot"] == got["numpy"][0] == 8.5   # 0.5 - 4 + 12
    assert got["correlate"] == got["numpy"][1] == [8.5]
    assert got["solve"] == [0.5, -1.0, 4.0 / 3.0]   # diag(a) x = b: x = b / a
    assert got["blas"] is True and got["probe"] == got["arraymath's probe"] == "numba.np.linalg"
