"""Markers (pyproject.toml) say what a test starts, and two of them what it costs:

- by kind: ``cluster`` (a dask cluster: LocalCluster, a scheduler and workers by hand),
  ``subprocess`` (the ``ditherlab`` command or another Python process), ``browser`` (a
  real browser through selenium), ``slurm`` (a single-node Slurm): ``scripts/test -m slurm``
  runs the Slurm tests, ``-m "not browser"`` all but the browser's.
- ``long``: tests that take long but guard what users rely on (sweeps on a real dask
  cluster, kills and disk faults, the browser, Slurm, whole gallery figures and their
  wrong-model checks, the promise check over every shipped spec). Deselected when ``-m``
  is not given, so ``scripts/test`` stays a few minutes; any ``-m`` expression chooses for
  itself (``-m long``: the long set; ``-m slurm``: the Slurm tests, all long).
  ``.ci/run`` runs ``scripts/test -m "long or not long"``: CI runs every one.
- ``slow``: the studies (the full hard-case suite, the fault campaign): skipped with the
  command that runs them (``scripts/test -m slow tests/hard``) unless ``-m`` names them;
  CI does not run them.

Order: ``scripts/test`` runs the tests on one pytest-xdist worker per core, a module's tests
on one worker (``--dist loadscope``), handing out modules in collection order. The costliest
modules (:data:`COSTLIEST`; in the quick set :data:`QUICK_COSTLIEST`) and then those with a
long test are collected first, so that a worker never starts a 6-minute module when the rest
of the suite is done (the longest-first rule of scheduling).
"""
from __future__ import annotations

import pathlib
import subprocess
from pathlib import Path

import pytest

from .guarantee import skip_unless_ci

HERE = pathlib.Path(__file__).parent

# the modules that cost most, costliest first: in CI (.ci/run's test-cost table on a fresh
# clone, this 2-core machine, cold kernel cache, 2026-11-28: the promise check 339 s, DOP853
# comparisons 205 s, wrong models 171 s, the GPU simulator 161 s, the gallery's figures
# 138 s, a crashing model 110 s), and in the quick set alone (`scripts/test -q`, the same
# day: brought models 55 s, hard cases 31 s, contact switches 31 s, convergence orders 26 s,
# web pages 22 s, the batch API 17 s); each module's cost is mostly compiling its scenes
COSTLIEST = ("accuracy/test_promises.py", "engine/test_engine_vs_scipy.py",
             "sweeps/gallery/test_wrong_models.py", "engine/test_gpu.py",
             "e2e/test_gallery_figures.py", "e2e/test_crashing_model.py")
QUICK_COSTLIEST = ("engine/test_models_brought.py", "hard/test_hard_cases.py",
                   "engine/test_engine_contact_switches.py", "engine/test_engine_convergence.py",
                   "sweeps/web/test_web_pages.py", "engine/test_engine_batch_api.py")


def _cost_rank(item, costliest: tuple[str, ...]) -> tuple[int, int]:
    where = pathlib.Path(str(item.fspath)).relative_to(HERE).as_posix()
    if where in costliest:
        return 0, costliest.index(where)
    return 1, 0


def pytest_collection_modifyitems(config, items):
    markexpr = config.getoption("markexpr") or ""
    if not markexpr.strip():
        long = [item for item in items if item.get_closest_marker("long")]
        if long:
            config.hook.pytest_deselected(items=long)
            items[:] = [item for item in items if not item.get_closest_marker("long")]
    long_modules = {item.fspath for item in items if item.get_closest_marker("long")}
    costliest = COSTLIEST if long_modules else QUICK_COSTLIEST
    items.sort(key=lambda item: (*_cost_rank(item, costliest), item.fspath not in long_modules))
    if "slow" in markexpr:
        return
    for item in items:
        if "slow" in item.keywords:
            folder = pathlib.Path(str(item.fspath)).parent.relative_to(HERE).as_posix()
            item.add_marker(pytest.mark.skip(
                reason=f"slow ({folder}): run with -m slow tests/{folder}"))


def pytest_report_header(config):
    if not (config.getoption("markexpr") or "").strip():
        return "long tests deselected: `scripts/test -m long` runs them (.ci/run does)"


# --- one HDF5 library per pytest worker ---------------------------------------------------

@pytest.fixture(autouse=True, scope="module")
def _one_hdf5_library(request):
    """A test module must not load netCDF4 into a pytest worker: its wheel brings an HDF5
    library of its own beside h5py's (HDF5 2.2.0 and 2.0.0 here), and two in one process
    are a known hazard (netcdf4-python #653, h5py #2171; once a pytest worker here died of
    a segmentation fault in a garbage collection with both loaded, cause not established).
    ``xr.open_dataset`` without ``engine=`` picks netCDF4 when it is installed;
    tests/test_cf.py reads with netCDF4 in a child process."""
    import sys

    before = "netCDF4" in sys.modules
    yield
    if not before and "netCDF4" in sys.modules:
        pytest.fail(f"{request.module.__name__} loaded netCDF4 into this pytest worker (a second "
                    "HDF5 library beside h5py's): open cubes with engine='h5netcdf', or use "
                    "netCDF4 in a child process (tests/test_cf.py)", pytrace=False)


# --- mounts: a small disk and a read-only store (root only; tests/guarantee.py) ----------

def _mount(args: list[str], where: Path) -> None:
    where.mkdir(parents=True, exist_ok=True)
    proc = subprocess.run(["mount", *args, str(where)], capture_output=True, text=True)
    if proc.returncode != 0:
        skip_unless_ci(f"cannot mount here ({' '.join(args)}): "
                       f"{proc.stderr.strip() or 'not root'}")


def _umount(where: Path) -> None:
    # lazy: this process may still hold the catalogue open
    subprocess.run(["umount", "--lazy", str(where)], capture_output=True)


@pytest.fixture
def tmpfs(tmp_path):
    """A tmpfs of a given size: ``mount("1M") -> its folder`` (a disk to fill)."""
    mounted = []

    def mount(size: str) -> Path:
        where = tmp_path / f"disk-{size}"
        _mount(["-t", "tmpfs", "-o", f"size={size}", "tmpfs"], where)
        mounted.append(where)
        return where

    yield mount
    for where in mounted:
        _umount(where)


@pytest.fixture
def read_only(tmp_path):
    """A read-only bind mount of a folder: ``mount(folder) -> the mounted path``."""
    mounted = []

    def mount(folder: Path) -> Path:
        where = tmp_path / f"ro-{folder.name}"
        where.mkdir()
        proc = subprocess.run(["mount", "--bind", str(folder), str(where)], capture_output=True,
                              text=True)
        if proc.returncode != 0:
            skip_unless_ci(f"cannot bind-mount here: {proc.stderr.strip()}")
        mounted.append(where)
        proc = subprocess.run(["mount", "-o", "remount,bind,ro", str(where)],
                              capture_output=True, text=True)
        if proc.returncode != 0:
            skip_unless_ci(f"cannot remount read-only here: {proc.stderr.strip()}")
        return where

    yield mount
    for where in mounted:
        _umount(where)
