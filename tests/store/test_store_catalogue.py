"""The SQLite catalogue: register / update / find / list, adoption of cubes without a row,
and several processes writing at once (DESIGN.md §6, service mode)."""

import os
import sqlite3
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from storetest_cubes import make_cube

import store

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
    cat = store.Catalogue(tmp_path)
    cat.register("aaaa1111", "demo", "{}", 1, 1, "x")
    time.sleep(0.01)
    cat.register("aaaa2222", "demo", "{}", 1, 1, "y")  # same name, newer
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


WORKER = """
import sys, time
sys.path.insert(0, {root!r})
import store
cat = store.Catalogue(sys.argv[1], timeout_s=60)
me = sys.argv[2]
cat.register(me, me, "{{}}", {n}, {n}, me)
print("ready", flush=True)
sys.stdin.readline()  # start together
t0 = time.time()
for k in range({n}):
    cat.update(me, state="running", done_points=k + 1)
    cat.update("shared", message=f"{{me}} {{k}}")
    if k % 50 == 0:
        assert any(r["sweep_id"] == me for r in cat.list())
cat.update(me, state="done")
print(t0, time.time(), flush=True)
"""


def test_two_processes_update_concurrently(tmp_path):
    n = 400
    cat = store.Catalogue(tmp_path)
    cat.register("shared", "shared", "{}", 1, 1, "x")
    code = WORKER.format(root=str(ROOT), n=n)
    procs = [
        subprocess.Popen(
            [sys.executable, "-c", code, str(tmp_path), f"writer{i}"],
            stdin=subprocess.PIPE,
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
        )
        for i in range(2)
    ]
    assert [p.stdout.readline().strip() for p in procs] == ["ready", "ready"]
    for p in procs:
        p.stdin.write("go\n")
        p.stdin.flush()
    outs = [p.communicate(timeout=120) for p in procs]
    assert [p.returncode for p in procs] == [0, 0], [err for _, err in outs]
    (start0, end0), (start1, end1) = [map(float, out.split()) for out, _ in outs]
    print(
        f"writer windows: {end0 - start0:.3f} s, {end1 - start1:.3f} s, overlap {min(end0, end1) - max(start0, start1):.3f} s"
    )
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
    import time

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
        time.sleep(0.5)                       # dead, not reaped: a zombie
        assert cat.live_state(row) == STALLED
    finally:
        child.kill()
        child.wait()
