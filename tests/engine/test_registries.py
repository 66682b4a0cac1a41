"""numba's registries load without its BLAS probe's import of scipy.linalg
(engine.jit.load_numba_registries; the compile and cache-load paths:
tests/engine/test_disk_cache.py), and the linear algebra numba offers still works."""
import json
import subprocess
import sys

CHILD = """
import json, sys
import numba, numpy as np
from engine.jit import load_numba_registries
load_numba_registries()
before = "scipy.linalg" in sys.modules
load_numba_registries()   # (a no-op now)
dot = numba.njit(lambda a, b: np.dot(a, b))
vdot = numba.njit(lambda a, b: np.vdot(a, b))   # (arraymath's BLAS branch)
solve = numba.njit(lambda m, v: np.linalg.solve(m, v))
a, b = np.arange(1.0, 4.0), np.array([0.5, -2.0, 4.0])
got = {"dot": dot(a, b), "vdot": vdot(a, b), "numpy": float(a @ b),
       "solve": solve(np.diag(a), b).tolist()}
print(json.dumps({**got, "before": before, "after": "scipy.linalg" in sys.modules,
                  "probe": numba.np.linalg.ensure_blas.__module__}))
"""


def test_brought_linear_algebra_still_finds_scipys_blas():
    """A law a user brings may call ``np.dot`` or ``np.linalg``: after the registries load
    without the import, numba's compile of such a call imports scipy.linalg and calls its
    BLAS and LAPACK, as before."""
    out = subprocess.run([sys.executable, "-c", CHILD], capture_output=True, text=True,
                         check=True)
    got = json.loads(out.stdout.strip().splitlines()[-1])
    assert got["before"] is False and got["after"] is True
    assert got["dot"] == got["vdot"] == got["numpy"] == 8.5   # 0.5 - 4 + 12
    assert got["solve"] == [0.5, -1.0, 4.0 / 3.0]
    assert got["probe"] == "numba.np.linalg"
