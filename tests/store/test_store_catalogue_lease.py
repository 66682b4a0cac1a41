"""The catalogue as the service's shared state (DESIGN.md §5-6, issue 10): states changed in
transactions, the per-sweep lease (one writer per sweep), heartbeats and stalled owners,
the queue served oldest first and claimed by exactly one server, cancel, and old
catalogues gaining the new columns."""

import os
import sqlite3
import subprocess
import sys
import time
from pathlib import Path

import pytest

import store
from tests.helpers import ticking_clock
from store.catalogue import Catalogue
from store.lease import STALE_S, STALLED, owner_tag

ROOT = Path(__file__).resolve().parents[2]
HOST = owner_tag().rpartition(":")[0]


def _dead_pid() -> int:
    return int(subprocess.run([sys.executable, "-c", "import os; print(os.getpid())"],
                              capture_output=True, text=True, check=True).stdout)


@pytest.fixture
def cat(tmp_path):
    cat = Catalogue(tmp_path)
    cat.register("s1", "one", "{}", 8, 4, tmp_path / "s1")
    return cat


def test_queue_claim_cancel_and_finish(cat):
    me = owner_tag()
    assert cat.get("s1")["state"] == "queued"
    row = cat.claim_next(me)
    assert (row["sweep_id"], row["state"], row["owner"]) == ("s1", "running", me)
    assert row["heartbeat"] > 0
    assert cat.claim_next(me) is None                      # nothing else queued
    row = cat.request_cancel("s1")                         # running: flagged, not stopped
    assert (row["state"], row["cancel_requested"]) == ("running", 1)
    assert cat.cancel_requested("s1")
    assert cat.finish("s1", "cancelled", owner="elsewhere:1")[0] is False   # not the holder
    changed, row = cat.finish("s1", "cancelled", owner=me, message="stopped", done_blocks=2)
    assert changed and (row["state"], row["owner"], row["cancel_requested"],
                        row["done_blocks"]) == ("cancelled", "", 0, 2)
    assert cat.enqueue("s1")["state"] == "queued"          # submit --detach again resumes
    row = cat.request_cancel("s1")                         # queued: cancelled at once
    assert (row["state"], row["message"]) == ("cancelled", "cancelled while queued")
    assert cat.request_cancel("s1")["state"] == "cancelled"   # idempotent
    with pytest.raises(ValueError, match="state must be one of"):
        cat.finish("s1", "running")


def test_done_and_running_sweeps_are_not_requeued(cat):
    me = owner_tag()
    cat.acquire("s1", me)
    assert cat.enqueue("s1")["state"] == "running"         # a live run keeps going
    cat.finish("s1", "done", owner=me)
    assert cat.enqueue("s1")["state"] == "done"
    assert cat.request_cancel("s1")["state"] == "done"     # nothing to cancel


def test_lease_is_exclusive_until_its_owner_is_gone(cat):
    alive_other = f"{HOST}:{os.getppid()}"                 # a live process, not us
    me = owner_tag()
    got, row = cat.acquire("s1", alive_other)
    assert got and row["owner"] == alive_other
    got, row = cat.acquire("s1", me)
    assert not got and row["owner"] == alive_other         # held: the caller attaches
    assert cat.live_state(row) == "running"
    # the holder stops beating: after STALE_S it reads stalled and can be taken over
    cat.update("s1", heartbeat=time.time() - STALE_S - 1)
    assert cat.live_state(cat.get("s1")) == STALLED
    got, row = cat.acquire("s1", me)
    assert got and row["owner"] == me
    assert cat.beat("s1", alive_other) is False            # the old holder learns it lost it
    assert cat.finish("s1", "done", owner=alive_other)[0] is False
    assert cat.beat("s1", me, done_blocks=3) is True
    assert cat.get("s1")["done_blocks"] == 3


def test_a_dead_holder_on_this_host_is_taken_over_at_once(cat):
    dead = f"{HOST}:{_dead_pid()}"
    cat.acquire("s1", dead)
    assert cat.live_state(cat.get("s1")) == STALLED
    assert cat.acquire("s1")[0] is True
    # a stalled sweep cancelled: cancelled at once (nobody would see the flag)
    cat.register("s2", "two", "{}", 1, 1, "x")
    cat.acquire("s2", dead)
    assert cat.request_cancel("s2")["state"] == "cancelled"


def test_other_hosts_are_judged_by_their_heartbeat(cat):
    cat.acquire("s1", "elsewhere:1")
    assert cat.live_state(cat.get("s1")) == "running"
    cat.update("s1", heartbeat=time.time() - STALE_S - 5)
    assert cat.live_state(cat.get("s1")) == STALLED


def test_finish_without_owner_leaves_a_live_run_alone(cat):
    """A submitter that found nothing left to compute settles the row only when nobody is
    running the sweep."""
    cat.acquire("s1", f"{HOST}:{os.getppid()}")
    assert cat.finish("s1", "done")[0] is False
    cat.update("s1", owner=f"{HOST}:{_dead_pid()}")
    assert cat.finish("s1", "done")[0] is True


def test_servers_table(cat):
    cat.server_beat("elsewhere:1", cluster="tcp://x")
    cat.server_beat(sweep_id="s1", cluster="local")
    assert {s["owner"]: s["sweep_id"] for s in cat.servers()} == {"elsewhere:1": "",
                                                                  owner_tag(): "s1"}
    cat.server_gone()
    cat.server_beat(f"{HOST}:{_dead_pid()}")                # killed -9: not listed
    assert [s["owner"] for s in cat.servers()] == ["elsewhere:1"]


def test_a_serve_claims_only_the_devices_it_runs(tmp_path):
    """``serve`` without a GPU leaves the sweeps queued for one (spec ``device = "cuda"``);
    a spec without the key (written before it existed) is the CPU's."""
    cat = Catalogue(tmp_path, clock=ticking_clock())
    for sid, spec in (("gpu", '{"device": "cuda"}'), ("old", "{}"), ("cpu", '{"device": "cpu"}')):
        cat.register(sid, sid, spec, 1, 1, tmp_path / sid)
    me = owner_tag()
    assert [cat.claim_next(me, devices=("cpu",))["sweep_id"] for _ in range(2)] == ["old", "cpu"]
    assert cat.claim_next(me, devices=("cpu",)) is None
    assert cat.get("gpu")["state"] == "queued"
    assert cat.claim_next(me, devices=("cpu", "cuda"))["sweep_id"] == "gpu"
    cat.server_beat(cluster="local", device="cuda")
    assert [s["device"] for s in cat.servers()] == ["cuda"]


def test_a_queued_spec_that_does_not_parse_is_claimed_not_a_stopped_queue(tmp_path):
    """A damaged row is handed to serve, whose planning fails it with its reason; with
    SQLite's json_extract every claim raised 'malformed JSON' and the queue stood still."""
    cat = Catalogue(tmp_path, clock=ticking_clock())
    cat.register("bad", "bad", "not json", 1, 1, tmp_path / "bad")
    cat.register("next", "next", '{"device": "cpu"}', 1, 1, tmp_path / "next")
    assert [cat.claim_next(owner_tag(), devices=("cpu",))["sweep_id"]
            for _ in range(2)] == ["bad", "next"]


CLAIMER = """
import sys
sys.path.insert(0, {root!r})
from store.catalogue import Catalogue
cat = Catalogue(sys.argv[1], timeout_s=60)
me = "claimer-" + sys.argv[2] + ":1"
print("ready", flush=True)
sys.stdin.readline()
while True:
    row = cat.claim_next(me)
    if row is None:
        break
    print(row["sweep_id"], flush=True)
"""


def test_two_servers_never_claim_the_same_sweep_and_oldest_goes_first(tmp_path):
    cat = Catalogue(tmp_path, clock=ticking_clock())   # distinct queue times, in order
    ids = [f"q{i:02d}" for i in range(40)]
    for sid in ids:
        cat.register(sid, sid, "{}", 1, 1, tmp_path / sid)
    procs = [subprocess.Popen([sys.executable, "-c", CLAIMER.format(root=str(ROOT)),
                               str(tmp_path), str(i)], stdin=subprocess.PIPE,
                              stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
             for i in range(2)]
    assert [p.stdout.readline().strip() for p in procs] == ["ready", "ready"]
    for p in procs:
        p.stdin.write("go\n")
        p.stdin.flush()
    outs = [p.communicate(timeout=120) for p in procs]
    assert [p.returncode for p in procs] == [0, 0], [err for _, err in outs]
    claimed = [out.split() for out, _ in outs]
    assert sorted(claimed[0] + claimed[1]) == ids          # every sweep exactly once
    for mine in claimed:
        assert mine == sorted(mine)                        # each server: oldest first
    owners = {r["sweep_id"]: r["owner"] for r in cat.list()}
    assert all(owners[s] == "claimer-0:1" for s in claimed[0])


def test_old_catalogue_gains_the_service_columns(tmp_path):
    con = sqlite3.connect(tmp_path / "catalogue.sqlite")
    con.execute("CREATE TABLE sweeps (sweep_id TEXT PRIMARY KEY, name TEXT NOT NULL, "
                "state TEXT NOT NULL, spec_json TEXT NOT NULL, n_points INTEGER NOT NULL, "
                "n_blocks INTEGER NOT NULL, done_points INTEGER NOT NULL DEFAULT 0, "
                "failed_points INTEGER NOT NULL DEFAULT 0, done_blocks INTEGER NOT NULL "
                "DEFAULT 0, path TEXT NOT NULL, message TEXT NOT NULL DEFAULT '', "
                "created TEXT NOT NULL, updated TEXT NOT NULL)")
    con.execute("INSERT INTO sweeps VALUES ('old', 'old', 'running', '{}', 4, 2, 0, 0, 0, "
                "'x', '', '2020-01-01T00:00:00+00:00', '2020-01-01T00:00:00+00:00')")
    con.commit()
    con.close()
    cat = Catalogue(tmp_path)
    row = cat.get("old")
    for column in ("owner", "heartbeat", "cancel_requested", "run_started", "queued_at"):
        assert column in row
    cat.server_beat(cluster="local")   # the servers table of an old catalogue gains 'device'
    assert [s["device"] for s in cat.servers()] == ["cpu"]
    assert cat.live_state(row) == "running"   # no owner recorded: trusted as before
    assert cat.acquire("old", "elsewhere:1")[0] is True
    assert Catalogue(tmp_path).get("old")["owner"] == "elsewhere:1"   # reopening is a no-op


def test_store_exports_the_states():
    assert store.STATES == ("queued", "running", "done", "partial", "failed", "cancelled")


def test_a_ctrl_c_as_begin_returns_leaves_no_transaction_open(cat):
    """KeyboardInterrupt raised just after ``BEGIN IMMEDIATE`` returned (Python runs the
    signal handler then; the BEGIN may have waited for another writer): the connection,
    shared by every later call of this catalogue, was left inside the transaction, and the
    run's final state then failed ("cannot start a transaction within a transaction")."""
    with cat._connection() as con:
        real = con

    class InterruptedOnce:   # the connection, with the signal arriving after one BEGIN
        armed = True

        def execute(self, sql, *args):
            out = real.execute(sql, *args)
            if self.armed and sql == "BEGIN IMMEDIATE":
                InterruptedOnce.armed = False
                raise KeyboardInterrupt
            return out

        def __getattr__(self, name):
            return getattr(real, name)

    cat._con = InterruptedOnce()
    me = owner_tag()
    with pytest.raises(KeyboardInterrupt):
        cat.acquire("s1", me)
    assert not real.in_transaction
    assert cat.acquire("s1", me)[0]
    assert cat.finish("s1", "cancelled", owner=me)[0]
