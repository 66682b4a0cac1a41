"""Adaptive refinement of map boundaries (issue 11, sweeps.planning.refine): a synthetic class with a
known boundary is recovered exactly; on real maps the refined and the full cube agree cell
for cell; a refined sweep killed part-way resumes to the same cube.

Here simulated maps, a kill and the command line; the synthetic classes and the averaged
charts: tests/sweeps/planning/test_refine.py."""
from __future__ import annotations

import json
import os
import signal
import subprocess
import time

import numpy as np
import pytest

import store
import sweeps

from ..helpers import BIN, assert_same_results, ditherlab, results
from ..sweeps.planning.test_refine import _pair

pytestmark = pytest.mark.subprocess   # what it starts (tests/conftest.py)


ZONES = {"name": "refine-zones", "friction": "elastoplastic", "dither": "sine-velocity",
         "outputs": ["long_stick_fraction"], "accuracy": "draft",
         "params": {"lam": 0.8, "slow_force": {"amplitude": 1.7, "omega": 0.3}},
         "time": {"t_end": 20.0, "t_transient": 5.0},
         "grid": {"W": {"start": 0.0, "stop": 3.0, "num": 13},
                  "omega": {"start": 10.0, "stop": 1000.0, "num": 13, "scale": "log"},
                  "v_ref": [0.1]}}


@pytest.mark.long
def test_refined_zone_map_equals_the_full_grid(tmp_path):
    full, ref = _pair(ZONES, tmp_path)
    np.testing.assert_array_equal(store.zone_map(ref).values, store.zone_map(full).values)
    assert 0 < store.zone_map(full).values.mean() < 1         # a real boundary
    assert "provenance" in store.table(ref).columns


@pytest.mark.long
def test_killed_refined_sweep_resumes_to_the_same_cube(tmp_path, env, gate):
    """Killed (SIGKILL) once a block of its first level is journaled, with three tasks let
    through the gate (blocks, or the error sample's re-runs that fill idle workers) and the
    rest held: certainly mid-run. Resumed, it gives the cube of a run never killed."""
    spec = {**ZONES, "refine": True, "block_size": 1,
            "time": {"t_end": 60.0, "t_transient": 5.0}}
    path = tmp_path / "zones.json"
    path.write_text(json.dumps(spec))
    sid = sweeps.load_spec(spec).sweep_id
    crashed, clean = tmp_path / "crashed", tmp_path / "clean"
    journal = crashed / sid / "journal"
    proc = subprocess.Popen([str(BIN), "submit", str(path), "-q", "--store", str(crashed)],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, env=env,
                            start_new_session=True)
    gate.let(3)   # fewer tasks than are in flight (2 workers x 2): a block among them
    t0 = time.monotonic()
    while len(store.Journal(journal).files()) < 1:
        assert proc.poll() is None and time.monotonic() - t0 < 300, "no blocks journaled"
        time.sleep(0.02)
    os.killpg(proc.pid, signal.SIGKILL)
    proc.wait()
    gate.open()
    assert 1 <= len(store.Journal(journal).files()) <= 3
    resumed = subprocess.run([str(BIN), "submit", str(path), "-q", "--store", str(crashed)],
                             capture_output=True, text=True, timeout=600)
    assert resumed.returncode == 0 and "done" in resumed.stdout, resumed.stderr
    subprocess.run([str(BIN), "submit", str(path), "-q", "--store", str(clean)], check=True,
                   capture_output=True, timeout=600)
    a, b = (results(root / sid / "cube.nc") for root in (crashed, clean))
    assert_same_results(a, b)   # provenance, steps and every output included


@pytest.mark.long
def test_values_read_from_inferred_points_carry_a_warning(tmp_path):
    """A refined cube's inferred points hold a computed neighbour's outputs (right class,
    not a computed value): ``query`` and ``map --kind friction`` say so in one warning
    line; the class maps do not, nor does a query of computed points only."""
    from ..helpers import AVERAGED_SPEC

    spec = tmp_path / "chart.toml"
    spec.write_text(AVERAGED_SPEC.replace('name = "e2e-avg"', 'name = "chart"\nrefine = true'))
    root = tmp_path / "store"
    ditherlab("submit", str(spec), "-q", store=root, check=True)
    query = ditherlab("query", "chart", "--var", "F_eff", "--format", "csv", store=root,
                      check=True)
    with pytest.warns(sweeps.InferredPointsWarning, match=r"sweep \w+: \d+ of \d+ points are "
                      "inferred") as caught:
        ds = sweeps.open_sweep("chart", root)
    n_inferred = int((ds["provenance"].values == 1).sum())
    assert 0 < n_inferred < ds["provenance"].size
    assert f": {n_inferred} of {ds['provenance'].size} points" in str(caught[0].message)
    assert f"warning: {n_inferred} of {ds['provenance'].size} points are inferred" \
        in query.stderr
    friction = ditherlab("map", "chart", "--kind", "friction", "-o", str(tmp_path / "f.png"),
                         store=root, check=True)
    assert "points are inferred" in friction.stderr
    chart = ditherlab("map", "chart", "--kind", "stability", "-o", str(tmp_path / "s.png"),
                      store=root, check=True)
    assert "inferred" not in chart.stderr
    # a selection of computed points only: no warning (the corner W = 0, v_ref = 0.02)
    corner = ditherlab("query", "chart", "--sel", "W=0", "--sel", "v_ref=0.02", store=root,
                       check=True)
    assert "inferred" not in corner.stderr
