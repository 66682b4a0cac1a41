"""The gallery's sweeps share one LocalCluster (Context.shared_cluster, issue 30: Fig. 14
and its lam = 0.5 twin each started one, with its workers' imports and kernel load), an
analysis sweep starts none, and the cluster is closed on leaving."""
from contextlib import contextmanager
from types import SimpleNamespace

import sweeps.api
import sweeps.workers.cluster
from sweeps.gallery.context import Context


def test_simulated_sweeps_share_one_cluster_and_analysis_starts_none(monkeypatch, tmp_path):
    started, closed, used = [], [], []

    @contextmanager
    def fake_cluster(scheduler=None, workers=2, dashboard=None):
        client = object()
        started.append((scheduler, workers))
        yield client
        closed.append(client)

    def fake_run(spec, store, *, client=None, **kw):
        used.append((spec["name"], client))
        return SimpleNamespace(state="done", sweep_id=spec["name"])

    monkeypatch.setattr(sweeps.workers.cluster, "dask_client", fake_cluster)
    monkeypatch.setattr(sweeps.api, "run_sweep", fake_run)
    monkeypatch.setattr(sweeps.api, "open_sweep", lambda sweep_id, store: sweep_id)
    ctx = Context(size="small", outdir=tmp_path, store=tmp_path / "store", workers=2)
    with ctx.shared_cluster():
        ctx.sweep("fig09")                 # the averaged chart: in-process, no cluster
        assert started == []
        ctx.sweep("fig14")
        ctx.sweep("fig14-lam0.5")
    assert started == [(None, 2)]
    clients = dict(used)
    assert clients["fig09-small"] is None
    assert clients["fig14-small"] is clients["fig14-lam0.5-small"] is closed[0]
    assert ctx.client is None              # closed and forgotten on leaving
    ctx.sweep("fig14")                     # outside: each sweep starts its own again
    assert used[-1][1] is None and len(started) == 1
