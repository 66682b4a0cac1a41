"""Tests marked ``slow`` are opt-in: skipped unless the marker expression names them
(``scripts/test -m slow tests/hard``), so the CI command (``scripts/test -q``, no marker
expression) runs the CI subset. Slow here: the full hard-case suite (tests/hard), the fault
campaign and disk filling up mid-run (tests/sweeps), the dask sweeps of Fig. 14
(tests/gallery)."""
from __future__ import annotations

import pathlib

import pytest

HERE = pathlib.Path(__file__).parent


def pytest_collection_modifyitems(config, items):
    if "slow" in (config.getoption("markexpr") or ""):
        return
    for item in items:
        if "slow" in item.keywords:
            folder = pathlib.Path(str(item.fspath)).parent.relative_to(HERE).as_posix()
            item.add_marker(pytest.mark.skip(
                reason=f"slow ({folder}): run with -m slow tests/{folder}"))
