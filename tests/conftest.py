"""Two kinds of tests are opt-in, named by their marker in ``-m``:

- ``long``: tests that take long but guard what users rely on (sweeps on a real dask
  cluster, kills and disk faults, the browser, Slurm, whole gallery figures and their
  wrong-model checks, the promise check over every shipped spec). Deselected
  unless ``-m`` names them, so ``scripts/test`` stays a few minutes; ``.ci/run`` runs
  ``scripts/test`` and then ``scripts/test -m long``, so CI runs every one of them.
- ``slow``: the studies (the full hard-case suite, the fault campaign): skipped with the
  command that runs them (``scripts/test -m slow tests/hard``); CI does not run them.
"""
from __future__ import annotations

import pathlib

import pytest

HERE = pathlib.Path(__file__).parent


def pytest_collection_modifyitems(config, items):
    markexpr = config.getoption("markexpr") or ""
    if "long" not in markexpr:
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
    if "long" not in (config.getoption("markexpr") or ""):
        return "long tests deselected: `scripts/test -m long` runs them (.ci/run does)"
