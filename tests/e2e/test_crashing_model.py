"""A brought law that crashes its process (a write far outside its arrays: numba checks no
bounds) at one point of a sweep (sweeps.workers.deaths). Before, the sweep hung with its
progress bar ticking (a 164-point sweep: 0 points after 5 minutes), because its tasks may
run only on the workers that matched when they were submitted and a restarted worker has a
new address; a small sweep ran in the submitter, which died with a segmentation fault. Now
the crash costs workers, not the submitter: the block is given up as FAILED in one warning
line once its tasks killed more workers than dask allows, the other points are kept, the
error estimate says why it has no number, and a second submit computes only those blocks.
A brought law that loops for ever at some points is given up the same way, after
$DITHERLAB_BLOCK_TIMEOUT_S (sweeps.workers.task.watched)."""
from __future__ import annotations

import os
import textwrap

import numpy as np
import pytest
import xarray as xr

from tests.helpers import ditherlab

pytestmark = [pytest.mark.long, pytest.mark.subprocess, pytest.mark.cluster]

LAW = '''
from engine.contract import FrictionLaw, LawKernels, Param


class Crasher(FrictionLaw):
    """Dahl-like; writes far outside its states at W > crash_at (a segmentation fault)."""
    name = "crasher"
    params = {"crash_at": Param(0.5, "1", "W above which it crashes", lo=-1.0)}
    phases = "band"

    def n_states(self, size):
        return 1

    def build(self, b):
        Z = b.z0
        fc, s0, iw, ic = b.ix["fc"], b.ix["sigma0"], b.ix["W"], b.ix["crash_at"]

        @b.jit(inline="always")
        def rates(u, y, dy, hold, p):
            dy[Z] = u * (1.0 - p[s0] * y[Z] * (1.0 if u >= 0 else -1.0) / p[fc])
            if p[iw] > p[ic]:
                dy[Z + 100000000000] = 1.0
            return p[s0] * y[Z]

        @b.jit(inline="always")
        def force(u, y, hold, p):
            return p[s0] * y[Z], 1.0

        @b.jit(inline="always")
        def switches(u, y, hold, p, g):
            g[0] = u

        @b.jit(inline="always")
        def init(p, y):
            y[Z] = 0.0

        @b.jit(inline="always")
        def scales(p, out):
            out[Z] = p[fc] / p[s0]

        return LawKernels(rates, force, 1, switches, init, scales)
'''

SPEC = '''
name = "crash"
friction = "crashlab:Crasher"
dither = "sine-velocity"
accuracy = "draft"
outputs = ["v_mean"]
[grid]
W = [0.0, 0.2, 1.0]
omega = [100.0]
'''


@pytest.fixture(scope="module")
def crashlab(tmp_path_factory):
    """The crashing law's module, in one folder for the module's tests: its kernels are
    cached by their file's path, so the tests compile it once, not once each."""
    folder = tmp_path_factory.mktemp("crashlab")
    (folder / "crashlab.py").write_text(textwrap.dedent(LAW))
    return folder


def test_a_law_that_crashes_its_worker_fails_its_block_in_one_line_and_keeps_the_rest(
        tmp_path, crashlab):
    spec = tmp_path / "crash.toml"
    spec.write_text(SPEC)
    store = tmp_path / "cubes"
    # dask's allowed-failures 1 (default 3): a crashing block is given up after 2 worker
    # deaths, not 4 -- the same counting (sweeps.workers.deaths reads the setting), half the
    # worker restarts (85 s of this test in CI before)
    env = {**os.environ, "PYTHONPATH": str(crashlab), "MPLBACKEND": "Agg",
           "DASK_DISTRIBUTED__SCHEDULER__ALLOWED_FAILURES": "1"}
    # crashes at W = 0.2 and 1, and would at the workers' warm-up point (W = 0.1): the
    # kernel of a brought model is compiled there on no point at all
    spec.write_text(SPEC + "[params]\ncrash_at = 0.05\n")

    out = ditherlab("submit", spec, "-q", store=store, env=env, timeout=300)
    assert out.returncode == 1, (out.returncode, out.stdout, out.stderr[-3000:])
    assert "Traceback" not in out.stderr and "Segmentation" not in out.stderr, out.stderr
    crashed = [ln for ln in out.stderr.splitlines() if "worker processes died" in ln
               and ln.startswith("ditherlab: warning: block ")]   # (not the estimate's)
    assert len(crashed) == 2 and all(" failed: " in ln for ln in crashed), out.stderr
    assert "2 of 3 points failed" in out.stderr

    [cube_file] = store.glob("*/cube.nc")
    with xr.open_dataset(cube_file, engine="h5netcdf") as cube:
        status = cube["status"].values.ravel()
        v_mean = cube["v_mean"].values.ravel()
        W = np.broadcast_to(cube["W"].values[:, None, None, None], cube["status"].shape).ravel()
    assert list(status[W > 0.05]) == [2, 2] and np.isnan(v_mean[W > 0.05]).all()   # FAILED
    assert list(status[W < 0.05]) == [0] and np.isfinite(v_mean[W < 0.05]).all()

    query = ditherlab("query", "crash", "--var", "v_mean", "--format", "csv", store=store,
                      env=env)
    assert query.returncode == 0, query.stderr
    assert "the error estimate could not be computed" in query.stderr   # its sample has W = 1
    assert "worker processes died" in query.stderr

    again = ditherlab("submit", spec, "-q", store=store, env=env, timeout=300)
    assert again.returncode == 1 and "ran 2 blocks" in again.stdout, (again.stdout, again.stderr)


LOOPING = LAW.replace("dy[Z + 100000000000] = 1.0", """k = 0.0
                while k >= 0.0:   # for ever (k stops growing at 2**53)
                    k += 1.0""")


def test_a_law_that_loops_for_ever_fails_its_block_in_one_line_and_keeps_the_rest(tmp_path):
    """A brought law that never returns at W > 0.05 (the spec's first-step check ran another
    point). Before, its workers computed for ever and the sweep's progress stood still;
    now each such block is given up after $DITHERLAB_BLOCK_TIMEOUT_S (6 s here) in one
    warning line, its worker ends and is started again, and the other points are kept.

    The worker leaves once the results it holds are taken, starting no other task. It
    exited 5 s after the hung block instead: the task it had started by then died with it,
    counted as a crash, and the error estimate's re-runs it held were computed again; a
    6-point sweep hung at 2 points took 85 s, not 35, its blocks given up as "4 worker
    processes died computing it". Here every block and re-run is computed once."""
    (tmp_path / "crashlab.py").write_text(textwrap.dedent(LOOPING))
    assert "while k >= 0.0" in LOOPING
    spec = tmp_path / "loop.toml"
    spec.write_text(SPEC.replace('"crash"', '"loop"') + "[params]\ncrash_at = 0.05\n")
    store = tmp_path / "cubes"
    env = {**os.environ, "PYTHONPATH": str(tmp_path), "MPLBACKEND": "Agg",
           "DITHERLAB_BLOCK_TIMEOUT_S": "6", "DITHERLAB_BLOCK_LOG": str(tmp_path / "blocks")}
    out = ditherlab("submit", spec, "-q", store=store, env=env, timeout=300)
    assert out.returncode == 1, (out.returncode, out.stdout, out.stderr[-3000:])
    assert "Traceback" not in out.stderr and "died" not in out.stderr, out.stderr
    computed = [line.split()[1] for line in (tmp_path / "blocks").read_text().splitlines()]
    assert len(computed) == 6 and len(set(computed)) == 6, computed   # 3 blocks, 3 re-runs
    hung = [ln for ln in out.stderr.splitlines() if "no result after 6 s" in ln]
    assert len(hung) == 2 and all(ln.startswith("ditherlab: warning: block ") and
                                  "DITHERLAB_BLOCK_TIMEOUT_S" in ln for ln in hung), out.stderr
    assert "2 of 3 points failed" in out.stderr
    [cube_file] = store.glob("*/cube.nc")
    with xr.open_dataset(cube_file, engine="h5netcdf") as cube:
        status = cube["status"].values.ravel()
        W = np.broadcast_to(cube["W"].values[:, None, None, None], cube["status"].shape).ravel()
        assert list(status[W > 0.05]) == [2, 2]   # FAILED
        assert list(status[W < 0.05]) == [0]
        assert np.isfinite(cube["v_mean"].values.ravel()[W < 0.05]).all()

    bad = ditherlab("submit", spec, "-q", store=store,
                    env={**env, "DITHERLAB_BLOCK_TIMEOUT_S": "soon"})
    assert bad.returncode == 2 and bad.stderr.strip().splitlines() == [
        "ditherlab: DITHERLAB_BLOCK_TIMEOUT_S='soon': expected a number of seconds"], \
        bad.stderr


@pytest.mark.parametrize("crash_at, where", [
    (-1.0, "friction 'crashlab:Crasher' on system 'slider': the process running it died"),
    (0.5, "crashlab:Crasher (the time estimate's sample points): the process running it died"),
])
def test_plan_of_a_law_that_crashes_is_one_line_exit_2(tmp_path, crashlab, crash_at, where):
    """At the spec's first-step check (crash_at < 0: every point crashes) and at the time
    estimate's sample points (W = 1 is one of them): before, ``ditherlab plan`` died with a
    segmentation fault (exit 139, not a line); now the user code runs in a child process."""
    spec = tmp_path / "crash.toml"
    spec.write_text(SPEC + f"[params]\ncrash_at = {crash_at}\n")
    env = {**os.environ, "PYTHONPATH": str(crashlab), "MPLBACKEND": "Agg"}
    out = ditherlab("plan", spec, env=env, timeout=300)
    assert out.returncode == 2, (out.returncode, out.stdout, out.stderr[-3000:])
    lines = [ln for ln in out.stderr.splitlines() if ln.strip()]
    assert len(lines) == 1 + (crash_at < 0), out.stderr   # (a spec refusal has a heading)
    assert where in lines[-1] and "(SIGSEGV): a crash in compiled code" in lines[-1], out.stderr
