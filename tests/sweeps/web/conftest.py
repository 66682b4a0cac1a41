"""A small store for the web view's tests, built once: two averaged sweeps (computed in this
process, seconds), one of them named like an attack, and one sweep "running" under a lease
this process holds, whose progress the tests advance themselves (a runner's beat, no
timing luck). Servers run in a thread of the test process on a free loopback port."""
from __future__ import annotations

import http.client
import json
import os
from pathlib import Path

import pytest

os.environ.setdefault("MPLBACKEND", "Agg")

HOSTILE = "<script>alert(1)</script>"
AVERAGED = {"name": "web-avg", "friction": "lugre", "dither": "square-velocity",
            "method": "averaged",
            "grid": {"W": {"start": 0.0, "stop": 1.0, "num": 21},
                     "v_ref": {"start": 0.02, "stop": 1.0, "num": 25}, "v_d": [0.1, 0.01]}}
TINY = {**AVERAGED, "name": HOSTILE,
        "grid": {"W": [0.0, 0.5, 1.0], "v_ref": [0.1, 0.5, 0.9], "v_d": [0.1]}}
RUNNING_ID = "0123456789ab"


@pytest.fixture(scope="session")
def web_store(tmp_path_factory) -> dict:
    import sweeps

    root = tmp_path_factory.mktemp("webstore") / "store"
    avg = sweeps.run_sweep(AVERAGED, root, progress=False)
    tiny = sweeps.run_sweep(TINY, root, progress=False)
    return {"root": root, "avg": avg.sweep_id, "tiny": tiny.sweep_id}


class Running:
    """A sweep in state running under this process's lease; :meth:`advance` reports
    progress as a runner's heartbeat does."""

    def __init__(self, root: Path):
        import store
        from sweeps.version import results_fingerprint

        self.cat = store.Catalogue(root)
        spec = {**AVERAGED, "name": "web-running"}
        self.cat.register(RUNNING_ID, "web-running", json.dumps(spec), 1000, 100,
                          root / RUNNING_ID, engine_fingerprint=results_fingerprint())
        ok, _ = self.cat.acquire(RUNNING_ID)
        assert ok
        self.done = 0

    def advance(self, points: int = 10) -> int:
        self.done += points
        assert self.cat.beat(RUNNING_ID, done_points=self.done, done_blocks=self.done // 10)
        return self.done

    def close(self) -> None:
        self.cat.finish(RUNNING_ID, "cancelled", message="test over")


@pytest.fixture
def running(web_store):
    run = Running(web_store["root"])
    yield run
    run.close()


@pytest.fixture
def serve_ctx():
    """Start a server on a free loopback port for a ServerState; returns its base URL."""
    from sweeps.web.app import start_in_thread

    stops = []

    def start(ctx) -> str:
        port, stop = start_in_thread(ctx, "127.0.0.1", 0)
        stops.append(stop)
        return f"http://127.0.0.1:{port}"

    yield start
    for stop in stops:
        stop()


@pytest.fixture
def server(web_store, serve_ctx):
    from sweeps.web.app import ServerState

    ctx = ServerState(web_store["root"])
    return serve_ctx(ctx), ctx


def request(base: str, path: str, method: str = "GET", headers=None, body=None):
    """``(status, headers, body bytes)`` of one request, the path sent exactly as given."""
    host, port = base.removeprefix("http://").split(":")
    con = http.client.HTTPConnection(host, int(port), timeout=120)
    try:
        con.putrequest(method, path, skip_accept_encoding=True)
        for k, v in (headers or {}).items():
            con.putheader(k, v)
        if body is not None:
            con.putheader("Content-Length", str(len(body)))
        con.endheaders(body)
        resp = con.getresponse()
        return resp.status, dict(resp.getheaders()), resp.read()
    finally:
        con.close()
