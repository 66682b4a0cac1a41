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
  ``.ci/run`` runs ``scripts/test`` and then ``scripts/test -m long``: CI runs every one.
- ``slow``: the studies (the full hard-case suite, the fault campaign): skipped with the
  command that runs them (``scripts/test -m slow tests/hard``) unless ``-m`` names them;
  CI does not run them.
"""
from __future__ import annotations

import pathlib

import pytest

HERE = pathlib.Path(__file__).parent


def pytest_collection_modifyitems(config, items):
    markexpr = config.getoption("markexpr") or ""
    if not markexpr.strip():
        long = [item for item in items if item.get_closest_marker("long")]
        if long:
            config.hook.pytest_deselected(items=long)
            items[:] = [item for item in items if not item.get_closest_marker("long")]
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
