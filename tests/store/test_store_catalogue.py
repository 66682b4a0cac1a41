"""The SQLite catalogue: register / update / find / list, adoption of cubes without a row,
and several processes writing at once (DESIGN.md §6, service mode)."""

import os
import sqlite3
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from storetest_cubes import make_cube

import store
from tests.helpers import ticking_clock

ROOT = Path(__file__).resolve().parents[2]


def test_register_update_get(tmp_path):
    cat = store.Catalogue(tmp_path)
    row = cat.register("a1b2c3", "fig14", '{"name":"fig14"}', 961, 61, tmp_path / "a1b2c3")
    assert (row["state"], row["n_points"], row["n_blocks"], row["done_points"]) == (
        "queued",
        961,
        61,
        0,
    )
    row = cat.update("a1b2c3", state="running", done_points=16, failed_points=1, done_blocks=1)
    assert (row["state"], row["done_points"], row["failed_points"], row["done_blocks"]) == (
        "running",
        16,
        1,
        1,
    )
    assert row["updated"] >= row["created"]
    again = cat.register(
        "a1b2c3", "fig14-renamed", '{"name":"fig14"}', 961, 61, tmp_path / "a1b2c3"
    )
    assert (again["state"], again["done_points"], again["created"]) == (
        "running",
        16,
        row["created"],
    )
    assert again["name"] == "fig14-renamed"
    assert cat.get("a1b2c3") == again
    with sqlite3.connect(cat.path) as con:
        assert con.execute("PRAGMA journal_mode").fetchone()[0] == "wal"


def test_find_by_id_name_and_prefix(tmp_path):
    cat = store.Catalogue(tmp_path, clock=ticking_clock())
    cat.register("aaaa1111", "demo", "{}", 1, 1, "x")
    cat.register("aaaa2222", "demo", "{}", 1, 1, "y")  # same name, a millisecond newer
    cat.register("bbbb3333", "other", "{}", 1, 1, "z")
    assert cat.find("aaaa1111")["sweep_id"] == "aaaa1111"
    assert cat.find("bbb")["sweep_id"] == "bbbb3333"
    assert cat.find("nothing") is None
    # a name given to two sweeps, or a short prefix: every candidate, newest first, and
    # find() refuses to guess (sweeps.lookup then prefers the one current sweep, if any)
    assert [r["sweep_id"] for r in cat.matches("demo")] == ["aaaa2222", "aaaa1111"]
    for key in ("demo", "aaaa"):
        with pytest.raises(LookupError, match=f"'{key}' is ambiguous: it matches "
                           "aaaa2222, aaaa1111; pass a sweep id"):
            cat.find(key)
    assert [r["sweep_id"] for r in cat.list()] == ["aaaa1111", "aaaa2222", "bbbb3333"]


@pytest.mark.parametrize(
    "fields, error, message",
    [
        (dict(stat="done"), ValueError, r"unknown field\(s\) \['stat'\]; updatable"),
        (
            dict(state="finished"),
            ValueError,
            r"state must be one of \('queued', 'running', 'done', 'partial', 'failed', "
            r"'cancelled'\)",
        ),
        (dict(done_points=-1), ValueError, r"done_points must be a non-negative integer, got -1"),
    ],
)
def test_update_error_messages(tmp_path, fields, error, message):
    cat = store.Catalogue(tmp_path)
    cat.register("abc", "n", "{}", 1, 1, "x")
    with pytest.raises(error, match=message):
        cat.update("abc", **fields)


def test_unknown_sweep_errors(tmp_path):
    cat = store.Catalogue(tmp_path)
    with pytest.raises(LookupError, match="no sweep with id 'zzz'.*register it first"):
        cat.update("zzz", state="done")
    with pytest.raises(LookupError, match="no sweep with id 'zzz'"):
        cat.get("zzz")


def test_cube_without_row_is_adopted(tmp_path):
    ds = make_cube(attrs={"sweep_id": "feed01", "name": "orphan", "spec": '{"name":"orphan"}'})
    status = np.zeros(ds["status"].size, np.int8)
    status[:3], status[3], status[4] = 1, 2, 3
    ds["status"].values[...] = status.reshape(ds["status"].shape)
    store.publish(ds, store.SweepDir(tmp_path, "feed01").cube)
    (tmp_path / "not-a-sweep").mkdir()
    cat = store.Catalogue(tmp_path)
    row = cat.find("orphan")
    # points never computed: it stopped before finishing, submitting again resumes it
    assert (row["sweep_id"], row["state"], row["spec_json"]) == (
        "feed01",
        "cancelled",
        '{"name":"orphan"}',
    )
    assert "3 points not computed" in row["message"]
    assert row["path"] == str(tmp_path / "feed01")
    assert (row["n_points"], row["done_points"], row["failed_points"]) == (
        status.size,
        status.size - 3,
        2,
    )
    assert [r["sweep_id"] for r in cat.list()] == ["feed01"]
    # its last update is the cube's last publish, not the time it was adopted
    cube = store.SweepDir(tmp_path, "feed01").cube
    os.utime(cube, (1_700_000_000, 1_700_000_000))
    cat.close()
    (tmp_path / "catalogue.sqlite").unlink()
    for extra in tmp_path.glob("catalogue.sqlite-*"):
        extra.unlink()
    assert store.Catalogue(tmp_path).find("orphan")["updated"] == "2023-11-14T22:13:20.000+00:00"


# Each writer updates its own row and a shared one in ROUNDS rounds; between rounds it waits
# on stdin until the test has heard both finish the round (a barrier). So both writers are
# certainly inside their update loops at once (each has begun before the first barrier
# opens and ends after the last), however the machine schedules them, and at each barrier
# each must read the other's finished rounds from the catalogue.
WORKER = """
import sys, time
sys.path.insert(0, {root!r})
import store
cat = store.Catalogue(sys.argv[1], timeout_s=60)
me, other = sys.argv[2], sys.argv[3]
cat.register(me, me, "{{}}", {n}, {n}, me)
print("ready", flush=True)
sys.stdin.readline()  # barrier: both registered
t0 = time.monotonic()
chunk = {n} // {rounds}
for r in range({rounds}):
    if r:
        sys.stdin.readline()  # barrier: both finished round r - 1
        seen = cat.get(other)["done_points"]
        assert seen >= r * chunk, f"{{me}} saw {{other}} at {{seen}} < {{r * chunk}}"
    for k in range(r * chunk, (r + 1) * chunk):
        cat.update(me, state="running", done_points=k + 1)
        cat.update("shared", message=f"{{me}} {{k}}")
        if k % 50 == 0:
            assert any(row["sweep_id"] == me for row in cat.list())
    print("round", r, flush=True)
cat.update(me, state="done")
print(t0, time.monotonic(), flush=True)
"""


def _release(procs) -> None:
    for p in procs:
        p.stdin.write("go\n")
        p.stdin.flush()


def test_two_processes_update_concurrently(tmp_path):
    n, rounds = 400, 4
    cat = store.Catalogue(tmp_path)
    cat.register("shared", "shared", "{}", 1, 1, "x")
    code = WORKER.format(root=str(ROOT), n=n, rounds=rounds)
    procs = [
        subprocess.Popen(
            [sys.executable, "-c", code, str(tmp_path), f"writer{i}", f"writer{1 - i}"],
            stdin=subprocess.PIPE,
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
        )
        for i in range(2)
    ]
    try:
        assert [p.stdout.readline().strip() for p in procs] == ["ready", "ready"]
        for r in range(rounds):
            _release(procs)
            assert [p.stdout.readline().strip() for p in procs] == [f"round {r}"] * 2, \
                [p.stderr.read() for p in procs if p.poll() is not None]
        windows = [p.stdout.readline() for p in procs]   # (not communicate: readline buffers)
        codes = [p.wait(timeout=120) for p in procs]
        assert codes == [0, 0], [p.stderr.read() for p in procs]
    finally:
        for p in procs:
            if p.poll() is None:
                p.kill()
    (start0, end0), (start1, end1) = [map(float, line.split()) for line in windows]
    # certain by the barriers: a failure here means the barrier protocol broke
    assert max(start0, start1) < min(end0, end1), "the two writers did not overlap in time"
    rows = {r["sweep_id"]: r for r in cat.list()}
    for i in range(2):
        assert (rows[f"writer{i}"]["state"], rows[f"writer{i}"]["done_points"]) == ("done", n)
    assert rows["shared"]["message"] in {f"writer0 {n - 1}", f"writer1 {n - 1}"}


def test_running_row_of_a_dead_owner_reads_stalled_and_old_catalogues_migrate(tmp_path):
    import sqlite3
    import subprocess
    import sys

    from store.catalogue import Catalogue
    from store.lease import STALLED, owner_tag

    # a catalogue written before the owner column existed gains it on open
    con = sqlite3.connect(tmp_path / "catalogue.sqlite")
    con.execute("CREATE TABLE sweeps (sweep_id TEXT PRIMARY KEY, name TEXT NOT NULL, "
                "state TEXT NOT NULL, spec_json TEXT NOT NULL, n_points INTEGER NOT NULL, "
                "n_blocks INTEGER NOT NULL, done_points INTEGER NOT NULL DEFAULT 0, "
                "failed_points INTEGER NOT NULL DEFAULT 0, done_blocks INTEGER NOT NULL "
                "DEFAULT 0, path TEXT NOT NULL, message TEXT NOT NULL DEFAULT '', "
                "created TEXT NOT NULL, updated TEXT NOT NULL)")
    con.commit()
    con.close()
    cat = Catalogue(tmp_path)
    cat.register("abc", "s", "{}", 4, 1, tmp_path / "abc")
    dead = subprocess.run([sys.executable, "-c", "import os; print(os.getpid())"],
                          capture_output=True, text=True, check=True).stdout.strip()
    host = owner_tag().rpartition(":")[0]
    row = cat.update("abc", state="running", owner=f"{host}:{dead}")
    assert row["state"] == "running" and cat.live_state(row) == STALLED
    assert cat.live_state(cat.update("abc", owner=owner_tag())) == "running"   # alive: us
    assert cat.live_state(cat.update("abc", owner=f"elsewhere:{dead}")) == "running"
    assert cat.live_state(cat.update("abc", state="done", owner="")) == "done"


def test_a_killed_unreaped_submitter_reads_stalled(tmp_path):
    """A submitter killed while its parent has not yet reaped it is a zombie: still in the
    process table (os.kill(pid, 0) succeeds), but gone."""
    import signal
    import subprocess
    import sys

    from store.catalogue import Catalogue
    from store.lease import STALLED, owner_tag

    child = subprocess.Popen([sys.executable, "-c", "import time; time.sleep(60)"])
    try:
        cat = Catalogue(tmp_path)
        cat.register("z", "s", "{}", 1, 1, tmp_path / "z")
        host = owner_tag().rpartition(":")[0]
        row = cat.update("z", state="running", owner=f"{host}:{child.pid}")
        assert cat.live_state(row) == "running"
        child.send_signal(signal.SIGKILL)
        os.waitid(os.P_PID, child.pid, os.WEXITED | os.WNOWAIT)   # dead, not reaped: a zombie
        assert cat.live_state(row) == STALLED
    finally:
        child.kill()
        child.wait()
