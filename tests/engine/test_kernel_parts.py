"""Kernel parts compile without a CPython wrapper; Python can still call them
(engine.kernel_parts).

Each case runs in a process of its own: numba's own call of a wrapper-less function from
Python is a segmentation fault, which must fail the test, not the test run.
"""
import json
import os
import subprocess
import sys

import pytest

pytestmark = pytest.mark.subprocess

MODULE = '''
from engine.jit import njit


@njit(error_model="numpy")
def part(x):
    return x * 1.2345678901234567 + 0.5


@njit(error_model="numpy", entry=True)
def kernel(a):
    s = 0.0
    for v in a:
        s += part(v)
    return s
'''
RUN = '''
import json, sys
import numpy as np
import parts
from engine.kernel_parts import KernelPart
from numba import float64
kernel_value = parts.kernel(np.arange(3.0))
if not parts.part.signatures:   # (the kernel came from the disk cache: the part was not needed)
    parts.part.compile((float64,))
sig = parts.part.signatures[0]
cres = parts.part.overloads[sig]
part_ir = cres.library.get_llvm_str()
entry_ir = parts.kernel.overloads[parts.kernel.signatures[0]].library.get_llvm_str()
report = {
    "kernel": kernel_value,
    "part_is_a_part": isinstance(parts.part, KernelPart),
    "kernel_is_a_part": isinstance(parts.kernel, KernelPart),
    "part_wrapper": cres.fndesc.llvm_cpython_wrapper_name in part_ir,
    "kernel_wrapper": parts.kernel.overloads[parts.kernel.signatures[0]]
                      .fndesc.llvm_cpython_wrapper_name in entry_ir,
    "part_hits": sum(parts.part.stats.cache_hits.values()),
    "kernel_hits": sum(parts.kernel.stats.cache_hits.values()),
}
report["part_from_python"] = parts.part(2.0)   # (last: a wrong wrapper would crash here)
print(json.dumps(report))
'''
PART = 1.2345678901234567


def _run(tmp_path, cache) -> dict:
    (tmp_path / "parts.py").write_text(MODULE)
    env = {**os.environ, "DITHERLAB_CACHE_DIR": str(cache),
           "PYTHONPATH": os.pathsep.join([str(tmp_path), os.getcwd()])}
    out = subprocess.run([sys.executable, "-c", RUN], env=env, capture_output=True, text=True,
                         cwd=tmp_path, timeout=600)
    assert out.returncode == 0, (out.returncode, out.stderr[-3000:])
    return json.loads(out.stdout.strip().splitlines()[-1])


def test_a_part_has_no_wrapper_and_python_still_gets_its_value(tmp_path):
    r = _run(tmp_path, tmp_path / "cache")
    assert r["kernel"] == sum(v * PART + 0.5 for v in (0.0, 1.0, 2.0))
    assert r["part_is_a_part"] and not r["kernel_is_a_part"]
    assert not r["part_wrapper"] and r["kernel_wrapper"]
    assert r["part_from_python"] == 2.0 * PART + 0.5


def test_a_part_loaded_from_the_disk_cache_links_into_a_new_kernel(tmp_path):
    """A second process loads the part (no wrapper) and compiles the kernel anew around
    it; a third loads both. Python's call of the part goes to its twin every time."""
    cache = tmp_path / "cache"
    first = _run(tmp_path, cache)
    kernels = [p for p in cache.rglob("*.nb[ic]") if ".kernel-" in p.name]
    assert kernels, sorted(p.name for p in cache.rglob("*"))
    for p in kernels:
        p.unlink()
    second = _run(tmp_path, cache)
    third = _run(tmp_path, cache)
    assert (first["part_hits"], second["part_hits"], third["part_hits"]) == (0, 1, 1)
    assert (second["kernel_hits"], third["kernel_hits"]) == (0, 1)
    for r in (second, third):
        assert r["kernel"] == first["kernel"]
        assert r["part_from_python"] == first["part_from_python"]


FACTORY = '''
import os
from engine.jit import njit
ENTRY = os.environ.get("ENTRY") == "1"


def make(a):
    @njit(error_model="numpy", entry=ENTRY)
    def scaled(x):   # a closure
        return x * a

    @njit(error_model="numpy", entry=ENTRY)
    def first(y):    # none: cached by its qualified name alone
        y[0] = 1.5
    return scaled, first


scaled, first = make(2.0)


@njit(error_model="numpy", entry=True)
def kernel(y):
    first(y)
    return scaled(y[0])
'''
CALLS = '''
import json, os
import numpy as np
import factory
y = np.zeros(2)
if os.environ.get("ENTRY") == "1":
    factory.first(y)
    print(json.dumps({"value": factory.scaled(y[0]),
                      "loaded": sum(factory.scaled.stats.cache_hits.values())
                      + sum(factory.first.stats.cache_hits.values())}))
else:
    print(json.dumps({"value": factory.kernel(y)}))
'''


def test_a_factory_s_entry_never_loads_the_same_function_cached_as_a_part(tmp_path):
    """One factory function can be a part in one scene and an entry in another
    (engine.systems.probed). numba's cache index does not tell them apart, so an entry
    called from Python loaded the part's machine code, which has no wrapper: a
    segmentation fault (a review of 33cdc22). An entry made by a factory is named apart."""
    (tmp_path / "factory.py").write_text(FACTORY)
    env = {**os.environ, "DITHERLAB_CACHE_DIR": str(tmp_path / "cache"),
           "PYTHONPATH": os.pathsep.join([str(tmp_path), os.getcwd()])}
    runs = []
    for entry in ("0", "1", "1"):   # the parts cached; the entries compiled, then loaded
        out = subprocess.run([sys.executable, "-c", CALLS], env={**env, "ENTRY": entry},
                             capture_output=True, text=True, cwd=tmp_path, timeout=600)
        assert out.returncode == 0, (entry, out.returncode, out.stderr[-3000:])
        runs.append(json.loads(out.stdout.strip().splitlines()[-1]))
    assert [r["value"] for r in runs] == [3.0, 3.0, 3.0]
    assert (runs[1]["loaded"], runs[2]["loaded"]) == (0, 2)


def test_the_engine_imports_and_runs_with_numba_s_jit_off(tmp_path):
    """``NUMBA_DISABLE_JIT=1`` (numba's debugging switch) makes njit return the function
    itself, which is no dispatcher to make a KernelPart of (a review of 33cdc22)."""
    code = ("from engine.dither import fixed_step, CODE\n"
            "print(fixed_step(CODE['square-velocity'], 10.0, 8, 0.01))")
    env = {**os.environ, "NUMBA_DISABLE_JIT": "1", "DITHERLAB_CACHE_DIR": str(tmp_path)}
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True,
                         text=True, timeout=600)
    assert out.returncode == 0, out.stderr[-3000:]
    assert float(out.stdout.split()[-1]) > 0.0
