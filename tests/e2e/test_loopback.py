"""Nothing listens beyond loopback unless the user names an address (issue 28).

``ditherlab submit`` on the default local cluster used to listen on 0.0.0.0 at a random
port: the dask scheduler's own HTTP server (``/health`` answered "ok"). Every listening
socket of ``submit`` and ``serve`` and of their worker processes is listed (psutil) while
their blocks are held at ``$DITHERLAB_BLOCK_GATE`` (so the cluster is certainly up), and
each must be bound to 127.0.0.1.
"""
from __future__ import annotations

import os
import subprocess
from pathlib import Path

import psutil
import pytest

from ..helpers import BIN, SIMULATE_SPEC, ditherlab, gated, wait_for

pytestmark = [pytest.mark.long, pytest.mark.cluster, pytest.mark.subprocess]
# every socket of submit and serve

# priced at seconds of work a worker (sweeps.planning.plan.work_s), so submit starts a local
# cluster: the 8-point e2e spec is priced below a cluster's start and runs on threads of
# the submitter, which listens on nothing
CLUSTER_SPEC = SIMULATE_SPEC.replace("t_end = 12.0", "t_end = 300.0").replace(
    'accuracy = "draft"', 'accuracy = "standard"')


def _listening(pid: int) -> list[tuple[int, str, int]]:
    found = []
    root = psutil.Process(pid)
    for proc in [root, *root.children(recursive=True)]:
        try:
            found += [(proc.pid, c.laddr.ip, c.laddr.port) for c in proc.net_connections("inet")
                      if c.status == psutil.CONN_LISTEN]
        except psutil.NoSuchProcess:
            continue
    return found


def _held_sockets(proc, gate: Path) -> list:
    """The listening sockets once a worker waits at the gate (``waiting-<pid>``): the
    cluster is up (a LocalCluster starts all its workers before the first block)."""
    wait_for(lambda: list(gate.glob("waiting-*")), "a worker at the gate", 600, process=proc)
    return _listening(proc.pid)


@pytest.mark.parametrize("command", ["submit", "serve"])
def test_every_socket_binds_loopback(command, tmp_path):
    gate = tmp_path / "gate"
    gate.mkdir()
    spec = tmp_path / "sim.toml"
    spec.write_text(CLUSTER_SPEC)
    env = gated(dict(os.environ), gate)
    store = str(tmp_path / "store")
    if command == "serve":
        subprocess.run([BIN, "submit", str(spec), "--store", store, "--detach", "-q"],
                       check=True, env=env, timeout=300, capture_output=True)
        args = [BIN, "serve", "--store", store, "-q"]
    else:
        args = [BIN, "submit", str(spec), "--store", store, "-q"]
    proc = subprocess.Popen(args, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            text=True, cwd=tmp_path)
    try:
        sockets = _held_sockets(proc, gate)
    finally:
        (gate / "open").touch()
        if command == "serve":
            _wait_done(store)
            proc.terminate()
        out, err = proc.communicate(timeout=600)
    assert sockets, "no listening socket found: the listing does not work"
    wide = [s for s in sockets if s[1] != "127.0.0.1"]
    assert not wide, f"listening beyond loopback: {wide}"


def _wait_done(store: str) -> None:
    wait_for(lambda: " done " in f" {ditherlab('status', store=store).stdout} ",
             "the sweep done", 600, poll=0.5)
