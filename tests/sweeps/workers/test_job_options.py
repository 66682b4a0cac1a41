"""The batch job ditherlab asks for, without a batch system (as dask-jobqueue tests its job
headers): the options of sweeps.workers.batch.job_options from the dask configuration, and
the job script dask-jobqueue writes from them (docs/BATCH.md)."""
from __future__ import annotations

import shlex

import dask
import pytest

from sweeps.errors import RefusedError
from sweeps.workers.batch import BATCH_KINDS, job_options, jobqueue

SLURM = {"jobqueue.slurm.memory": "2GB"}


def _script(kind: str, options: dict) -> str:
    """The job script of one worker job, as the cluster would submit it (no scheduler, no
    queue: the job class alone)."""
    module = jobqueue()
    job = getattr(module, BATCH_KINDS[kind]).job_cls   # SLURMJob for SLURMCluster, ...
    kw = {k: v for k, v in options.items() if k != "scheduler_options"}
    return job(scheduler="tcp://127.0.0.1:8786", name="w", **kw).job_script()


def test_a_slurm_job_is_one_single_threaded_worker_on_loopback_sharing_the_cache(
        monkeypatch, tmp_path):
    pytest.importorskip("dask_jobqueue")   # an optional extra (ditherlab[hpc])
    cache = tmp_path / "kernel cache"
    monkeypatch.setenv("DITHERLAB_CACHE_DIR", str(cache))
    with dask.config.set(SLURM):
        options = job_options("slurm")
        script = _script("slurm", options)
    assert (options["cores"], options["processes"]) == (1, 1)
    assert options["scheduler_options"] == {"dashboard_address": "127.0.0.1:0"}
    lines = script.splitlines()
    assert "#SBATCH --mem=2G" in lines and "#SBATCH --cpus-per-task=1" in lines
    assert f"export DITHERLAB_CACHE_DIR={shlex.quote(str(cache))}" in lines
    assert "export PYTHONSAFEPATH=1" in lines
    worker = lines[-1]
    assert "--nthreads 1" in worker and "--no-dashboard" in worker
    assert "--interface lo" in worker   # nothing listens beyond loopback unless named


def test_the_site_configuration_wins_where_it_speaks(monkeypatch):
    pytest.importorskip("dask_jobqueue")
    site = {**SLURM, "jobqueue.slurm.cores": 4, "jobqueue.slurm.interface": "ib0",
            "jobqueue.slurm.worker-extra-args": ["--dashboard-address", ":0"],
            "jobqueue.slurm.job-script-prologue": ["module load python"]}
    with dask.config.set(site):
        options = job_options("slurm", dashboard=":8787")
        script = _script("slurm", options)
    assert (options["cores"], options["processes"]) == (4, 4)   # one thread per worker
    assert "interface" not in options                            # the site's ib0 stays
    assert options["worker_extra_args"] == ["--dashboard-address", ":0"]
    assert options["scheduler_options"]["dashboard_address"] == ":8787"
    prologue = options["job_script_prologue"]
    assert prologue[-1] == "module load python"   # after ours: the site may override
    assert "--interface ib0" in script and "--nworkers 4" in script


@pytest.mark.parametrize("kind", sorted(BATCH_KINDS))
def test_a_job_without_its_memory_is_refused_saying_how_to_set_it(kind):
    with dask.config.set({f"jobqueue.{kind}.memory": None}):
        with pytest.raises(RefusedError, match=rf"jobqueue\.{kind}\.memory .* "
                           rf"DASK_JOBQUEUE__{kind.upper()}__MEMORY=2GB"):
            job_options(kind)
