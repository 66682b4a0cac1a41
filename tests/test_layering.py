"""The three rooms keep their one-way doors (STYLE.md 'The house', docs/ARCHITECTURE.md):
engine imports no dask/xarray/matplotlib/store/sweeps; store imports no numba/engine/
sweeps/dask. Each package is imported in a fresh interpreter with the others blocked."""
import subprocess
import sys

import pytest

# A None entry in sys.modules makes `import x` raise ImportError while letting
# `importlib.util.find_spec(x)` answer None: xarray probes for dask that way at import
# ("is it available?") without importing it, which is allowed.
BLOCKER = """
import sys
for name in {blocked!r}:
    sys.modules[name] = None
import {package}
import pkgutil, importlib
for mod in pkgutil.walk_packages({package}.__path__, '{package}.'):
    importlib.import_module(mod.name)
"""

RULES = {
    "engine": ["dask", "distributed", "xarray", "h5py", "h5netcdf", "matplotlib", "store",
               "sweeps"],
    "store": ["numba", "engine", "sweeps", "dask", "distributed"],
}


@pytest.mark.parametrize("package", sorted(RULES))
def test_package_imports_with_others_blocked(package):
    code = BLOCKER.format(blocked=RULES[package], package=package)
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr[-2000:]
