"""``ditherlab submit --workers N`` with N >= PRESTART_MIN_WORKERS starts the local workers'
fork server before it loads the spec (sweeps.workers.local_start.prestart); not with fewer
workers, nor when the workers are not ours to start. What the workers of such a server
see: tests/e2e/test_worker_start.py."""
from __future__ import annotations

import pytest

from sweeps.cli import running
from sweeps.cli.main import main
from sweeps.workers import local_start


@pytest.mark.parametrize("extra, prestarted", [
    (["--workers", "4"], True),
    (["--workers", "16"], True),
    (["--workers", "2"], False),
    ([], False),                                           # (2 by default)
    (["--workers", "4", "--detach"], False),               # the detached run starts its own
    (["--scheduler", "tcp://127.0.0.1:1"], False),         # not our workers
])
def test_the_fork_server_starts_before_the_spec_is_loaded(tmp_path, monkeypatch, extra,
                                                          prestarted):
    calls = []
    monkeypatch.setattr(local_start, "prestart", lambda: calls.append("prestart"))

    def load(args):
        calls.append("load")
        raise SystemExit(0)   # (what follows is the usual submit)

    monkeypatch.setattr(running, "_load", load)
    with pytest.raises(SystemExit):
        main(["submit", str(tmp_path / "spec.toml"), "--store", str(tmp_path / "s"), *extra])
    assert calls == (["prestart", "load"] if prestarted else ["load"])
