"""Local workers are forked from a server that imported the engine once (issue 37;
sweeps.workers.local_start.start_method), not spawned each on its own, where that gives them
the environment they would have been spawned with; and nothing is left running when the
process that started them is killed.

Each case runs in a fresh Python, so what an earlier test started in the test process
cannot decide the outcome."""
from __future__ import annotations

import json
import os
import signal
import subprocess
import sys

import psutil
import pytest

from ..helpers import wait_for

pytestmark = [pytest.mark.long, pytest.mark.cluster, pytest.mark.subprocess]

WHAT_WORKERS_SEE = """
import json, os, sys
from sweeps.workers.cluster import dask_client


def seen():
    import os, sys
    import dask
    return {"forked": "sweeps.workers.preload" in sys.modules,
            "mark": os.environ.get("DITHERLAB_TEST_MARK"),
            "profiler": dask.config.get("distributed.worker.profile.enabled")}


if __name__ == "__main__":
    for mark in sys.argv[1:]:
        os.environ["DITHERLAB_TEST_MARK"] = mark
        with dask_client(workers=2) as client:
            print(json.dumps(sorted(map(json.dumps, client.run(seen).values()))), flush=True)
            if os.environ.get("HOLD"):   # the workers up until killed
                sys.stdin.readline()
"""


AFTER_OURS = """
import json, os
from distributed import Client, LocalCluster
from sweeps.workers.cluster import dask_client

if __name__ == "__main__":
    with dask_client(workers=1):
        pass
    os.environ["DITHERLAB_TEST_MARK"] = "theirs"
    with LocalCluster(n_workers=1, processes=True, dashboard_address=None,
                      scheduler_kwargs={"dashboard_address": "127.0.0.1:0"}) as cluster, \\
            Client(cluster) as client:
        print(json.dumps(list(client.run(
            lambda: ("sweeps.workers.preload" in __import__("sys").modules,
                     os.environ.get("DITHERLAB_TEST_MARK"),
                     __import__("dask").config.get("distributed.worker.profile.enabled"))
        ).values())))
"""


def _script(tmp_path):
    path = tmp_path / "workers.py"
    path.write_text(WHAT_WORKERS_SEE)
    return path


def test_workers_forked_while_the_environment_holds_spawned_when_it_changed(tmp_path):
    out = subprocess.run([sys.executable, str(_script(tmp_path)), "a", "a", "b"],
                         capture_output=True, text=True, timeout=600, cwd=tmp_path)
    assert out.returncode == 0, out.stderr[-3000:]
    runs = [[json.loads(w) for w in json.loads(line)] for line in out.stdout.splitlines()]
    # dask's profiler off in every worker of ours, forked or spawned (local_start.QUIET)
    assert runs == [[{"forked": True, "mark": "a", "profiler": False}] * 2,   # the server's first two
                    [{"forked": True, "mark": "a", "profiler": False}] * 2,   # ... its next two
                    [{"forked": False, "mark": "b", "profiler": False}] * 2], out.stderr[-3000:]


def test_kill_9_of_the_starter_leaves_no_worker_and_no_fork_server(tmp_path):
    proc = subprocess.Popen([sys.executable, str(_script(tmp_path)), "a"], cwd=tmp_path,
                            env={**os.environ, "HOLD": "1"}, stdin=subprocess.PIPE,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        line = proc.stdout.readline()
        assert json.loads(line) == [json.dumps({"forked": True, "mark": "a",
                                                "profiler": False})] * 2, \
            proc.stderr.read()[-3000:] if not line else line
        left = psutil.Process(proc.pid).children(recursive=True)
        # the fork server and the two workers forked from it (a fork keeps its command line)
        assert sum("forkserver" in " ".join(p.cmdline()) for p in left) >= 3, left
        proc.send_signal(signal.SIGKILL)
        proc.wait(timeout=60)

        def gone():
            return not [p for p in left if p.is_running() and p.status() != "zombie"]
        wait_for(gone, "the workers and the fork server to exit", seconds=60)
    finally:
        if proc.poll() is None:
            proc.kill()


def test_a_cluster_the_caller_makes_afterwards_is_started_as_dask_would(tmp_path):
    """The start method and QUIET are set for our workers alone: a LocalCluster a script
    makes after a sweep is spawned with its environment of then, not forked from our older
    server, and keeps dask's profiler."""
    path = tmp_path / "after.py"
    path.write_text(AFTER_OURS)
    out = subprocess.run([sys.executable, str(path)], capture_output=True, text=True,
                         timeout=600, cwd=tmp_path)
    assert out.returncode == 0, out.stderr[-3000:]
    assert json.loads(out.stdout.strip().splitlines()[-1]) == [[False, "theirs", True]]


WHERE_WORKERS_IMPORT = """
import json
import sweeps
from sweeps.workers.cluster import dask_client


def where():
    import sys
    import sweeps
    return [sweeps.__file__, "sweeps.workers.preload" in sys.modules]


if __name__ == "__main__":
    with dask_client(workers=1) as client:
        print(json.dumps([sweeps.__file__, *client.run(where).values()]))
"""


def test_a_folder_named_sweeps_in_the_current_directory_does_not_reach_the_workers(tmp_path):
    """Python 3.11's fork server drops the ``sys.path`` it is given and imports from its
    current directory first: started in a folder with another ``sweeps`` (another checkout,
    a worktree: scripts/bit_identical.py's recipe), its workers imported that one and the
    sweep failed ("no worker runs this engine"). Now such a process gets spawned workers."""
    (tmp_path / "elsewhere" / "sweeps").mkdir(parents=True)
    (tmp_path / "elsewhere" / "sweeps" / "__init__.py").write_text("WRONG = True\n")
    script = tmp_path / "where.py"
    script.write_text(WHERE_WORKERS_IMPORT)
    out = subprocess.run([sys.executable, str(script)], capture_output=True, text=True,
                         timeout=600, cwd=tmp_path / "elsewhere")
    assert out.returncode == 0, out.stderr[-3000:]
    ours, (theirs, forked) = json.loads(out.stdout.splitlines()[-1])
    assert "elsewhere" not in ours and theirs == ours and not forked


PRESTARTED = """
import json, multiprocessing.forkserver, os, sys
from sweeps.workers import local_start


def seen():
    import os, sys
    return {"forked": "sweeps.workers.preload" in sys.modules,
            "env": {k: os.environ.get(k) for k in sorted(ENV)},
            "hash": hash("ditherlab"), "parent": os.getppid()}


ENV = ("OMP_NUM_THREADS", "MKL_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MALLOC_TRIM_THRESHOLD_",
       "PYTHONHASHSEED")

if __name__ == "__main__":
    if sys.argv[1] == "prestart":
        local_start.prestart().join()
        server = multiprocessing.forkserver._forkserver._forkserver_pid
        assert "distributed" not in sys.modules   # (its import stays off that thread)
    from sweeps.workers.cluster import dask_client
    with dask_client(workers=2) as client:
        workers = list(client.run(seen).values())
    if sys.argv[1] == "prestart":
        assert {w.pop("parent") for w in workers} == {server}, (workers, server)
    else:
        for w in workers:
            w.pop("parent")
    print(json.dumps(workers))
"""


@pytest.mark.parametrize("inherited", [{}, {"MKL_NUM_THREADS": "1", "PYTHONHASHSEED": "6640"}])
def test_a_prestarted_fork_server_gives_the_workers_the_nannys_environment(tmp_path,
                                                                         inherited):
    """``ditherlab submit --workers 4`` or more starts the fork server first thing
    (local_start.prestart), before dask's nanny has put its pre-spawn environment into the
    process: its workers are forked from that server and see what workers forked from a
    server the nanny started see (OMP_NUM_THREADS=1, dask's hash seed 6640: the same
    ``hash`` of a string). Also in a process that inherited part of that environment from
    a parent that ran a cluster (a CI run's test process): prestart, which does not import
    distributed, once read no pre-spawn environment, took the inherited part for the
    workers' own, and the cluster then spawned its workers instead."""
    script = tmp_path / "prestarted.py"
    script.write_text(PRESTARTED)
    env = {k: v for k, v in os.environ.items()
           if k not in ("PYTHONHASHSEED", "OMP_NUM_THREADS", "MKL_NUM_THREADS",
                        "OPENBLAS_NUM_THREADS", "MALLOC_TRIM_THRESHOLD_")}
    env.update(inherited)
    seen = {}
    for how in ("prestart", "nanny"):
        out = subprocess.run([sys.executable, str(script), how], capture_output=True,
                             text=True, timeout=600, cwd=tmp_path, env=env)
        assert out.returncode == 0, out.stderr[-3000:]
        seen[how] = json.loads(out.stdout.splitlines()[-1])
    assert seen["prestart"] == seen["nanny"], seen
    first = seen["nanny"][0]
    assert first["forked"] and first["env"]["OMP_NUM_THREADS"] == "1" and \
        first["env"]["PYTHONHASHSEED"] == "6640", first
    assert len({w["hash"] for w in seen["nanny"]}) == 1



def test_the_current_folder_joining_sys_path_keeps_the_fork_server(tmp_path):
    """The spec load appends the current folder to ``sys.path`` for a brought model found
    there (engine.user_code), after prestart has decided on the fork server: that server
    (``python -c`` in this folder) imports from it first anyway, so its workers stay
    forked (a review found them spawned). Another folder joining still means spawned
    workers: the server would not import from it."""
    script = ("import os, sys\n"
              "from sweeps.workers import local_start as ls\n"
              "a = ls.start_method()\n"
              "sys.path.append(os.getcwd())\n"
              "b = ls.start_method()\n"
              "sys.path.append(os.path.join(os.getcwd(), 'elsewhere'))\n"
              "print(a, b, ls.start_method())\n")
    out = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True,
                         timeout=300, cwd=tmp_path)
    assert out.returncode == 0, out.stderr[-3000:]
    assert out.stdout.split() == ["forkserver", "forkserver", "spawn"], out.stdout
