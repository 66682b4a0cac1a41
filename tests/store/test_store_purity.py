"""store/ never imports numba, dask, engine or sweeps (ARCHITECTURE.md) — not at import
time (tests/test_layering.py) and not while it works: a whole build / journal /
publish / open / catalogue / query / map cycle runs here with those packages blocked."""

import subprocess
import sys
from pathlib import Path

import pytest

pytestmark = pytest.mark.subprocess   # what it starts (tests/conftest.py)

ROOT = Path(__file__).resolve().parents[2]
CYCLE = """
import sys
for name in ("numba", "dask", "distributed", "engine", "sweeps"):
    sys.modules[name] = None  # import fails; importlib.util.find_spec answers None
sys.path.insert(0, {root!r})
sys.path.insert(0, {here!r})
import numpy as np
import store
from storetest_cubes import averaged_cube

root = sys.argv[1]
sweep = store.SweepDir(root, "c0ffee")
empty = averaged_cube()
journal = store.Journal(sweep.journal)
index = np.arange(10)
journal.write(0, store.BlockRecord(index, np.zeros(10), np.ones(10), np.ones(10), np.ones(10),
                                   {{n: np.ones(10) for n in store.output_names(empty)}}))
store.publish(store.rebuild(empty, journal), sweep.cube)
ds = store.open_cube(sweep.cube)
store.Catalogue(root).list()
store.table(ds, sel={{"v_d": 0.1}})
store.stability_map(ds, root + "/map.png", sel={{"v_d": 0.1}})
store.friction_curves(ds, root + "/curves.png", sel={{"v_d": 0.1}})
"""


@pytest.mark.long
def test_store_cycle_runs_with_numba_dask_engine_sweeps_blocked(tmp_path):
    code = CYCLE.format(root=str(ROOT), here=str(Path(__file__).parent))
    proc = subprocess.run(
        [sys.executable, "-c", code, str(tmp_path)], capture_output=True, text=True
    )
    assert proc.returncode == 0, proc.stderr[-3000:]
    assert (tmp_path / "map.png").stat().st_size > 10_000
