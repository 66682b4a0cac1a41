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


def test_fig14_reads_inferred_points_quietly_but_passes_on_every_other_warning():
    """Fig. 14's refined cubes are read for their classes only: their InferredPointsWarning
    is silenced, but an accuracy warning of the same read still reaches the user (a blanket
    ``simplefilter("ignore")`` hid it: the gallery said "holds" over a broken promise)."""
    import warnings

    from sweeps.errors import InferredPointsWarning
    from sweeps.gallery.fig_zone import classes_of

    def read():
        warnings.warn("4 inferred points", InferredPointsWarning, stacklevel=2)
        warnings.warn("F_mean moved 3e-3, over standard's promise", UserWarning, stacklevel=2)
        return "cube"

    with warnings.catch_warnings(record=True) as seen:
        warnings.simplefilter("always")
        assert classes_of(read) == "cube"
    assert [str(w.message) for w in seen] == ["F_mean moved 3e-3, over standard's promise"]
