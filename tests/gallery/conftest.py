from pathlib import Path

import pytest


def pytest_collection_modifyitems(config, items):
    """Tests marked ``slow`` here (the dask sweeps of Fig. 14, ~1 min) are opt-in, as in
    tests/sweeps: ``scripts/test -m slow tests/gallery``."""
    if "slow" in (config.getoption("markexpr") or ""):
        return
    here = Path(__file__).parent
    skip = pytest.mark.skip(reason="slow gallery sweep: run with -m slow")
    for item in items:
        if "slow" in item.keywords and here in Path(str(item.fspath)).parents:
            item.add_marker(skip)
