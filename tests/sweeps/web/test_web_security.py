"""The web view's promises of safety (issue 28), one test each: it only reads (GET and
HEAD; a read-only store works; nothing in the store changes), no address becomes a path,
a token beyond loopback (constant-time, never logged), every value escaped under a CSP
that forbids inline scripts, bounded work per request, and a cube republished during a
read is read whole."""
from __future__ import annotations

import gc
import logging
import os
import shutil

import pytest

from .conftest import HOSTILE, request


def _files(root):
    """Every file of a store with its size and mtime (what a write would change)."""
    out = {}
    for folder, _, names in os.walk(root):
        for n in names:
            st = os.stat(os.path.join(folder, n))
            out[os.path.join(folder, n)] = (st.st_size, st.st_mtime_ns)
    return out


@pytest.mark.parametrize("method", ["POST", "PUT", "DELETE", "PATCH", "OPTIONS"])
def test_only_get_and_head_are_answered(server, web_store, method):
    base, _ = server
    for path in ("/", f"/sweep/{web_store['avg']}", f"/sweep/{web_store['avg']}/cube.nc",
                 "/explorer", "/no/such/page"):
        status, _, body = request(base, path, method, body=b"x=1")
        assert status == 405, (method, path, status)
        assert b"only reads" in body


def test_head_answers_like_get_without_a_body(server, web_store):
    base, _ = server
    status, headers, body = request(base, f"/sweep/{web_store['avg']}/cube.nc", "HEAD")
    assert status == 200 and body == b""
    assert headers["Content-Type"] == "application/x-netcdf"


HOSTILE_PATHS = [
    "/sweep/../../etc/passwd", "/sweep/..%2F..%2Fetc%2Fpasswd", "/sweep/%2Fetc%2Fpasswd",
    "/sweep/%2e%2e%2fcatalogue.sqlite", "/sweep/000000000000", "/sweep/web-avg",
    "/static/..%2Fapp.py", "/static/%2e%2e/app.py", "/static/app.py", "/static//etc/passwd",
    "/gallery/..%2F..%2Fcatalogue.sqlite", "/gallery/%2Fetc%2Fpasswd", "//etc/passwd",
    "/etc/passwd", "/catalogue.sqlite", "/sweep/{avg}/..%2F..%2Fcatalogue.sqlite",
    "/sweep/{avg}/map/..%2F..%2Fx.png", "/sweep/{avg}/cube.nc%2F..%2F..%2Fcatalogue.sqlite",
    "/sweep/{prefix}", "/sweep/{avg}/journal", "/sweep/{avg}/spec.json",
]


@pytest.mark.parametrize("path", HOSTILE_PATHS)
def test_no_address_becomes_a_path(server, web_store, path):
    base, _ = server
    path = path.format(avg=web_store["avg"], prefix=web_store["avg"][:6])
    status, _, body = request(base, path)
    assert status == 404, (path, status, body[:200])
    assert b"root:" not in body and b"SQLite" not in body


def test_a_read_only_store_is_served_and_no_request_writes(web_store, serve_ctx, read_only):
    from sweeps.web.app import ServerState

    ro = read_only(web_store["root"])
    # earlier tests' catalogue connections, left to the garbage collector, close now: the
    # last one to close checkpoints the WAL into catalogue.sqlite and removes -wal/-shm,
    # which once happened mid-test (the comparison below failed on that, not on a request)
    gc.collect()
    before = _files(web_store["root"])
    base = serve_ctx(ServerState(ro))
    sid = web_store["avg"]
    for path in ("/", "/api/sweeps?after=0", f"/sweep/{sid}", f"/api/sweep/{sid}",
                 f"/sweep/{sid}/cube.nc", f"/sweep/{sid}/query.csv?sel.v_d=0.1",
                 f"/sweep/{sid}/query.json?var=stable&sel.v_d=0.01",
                 f"/sweep/{sid}/map/stability.png?sel.v_d=0.1",
                 f"/sweep/{sid}/map/friction.svg?sel.v_d=0.1&pick=3"):
        status, _, body = request(base, path)
        assert status == 200, (path, status, body[:300])
    assert _files(web_store["root"]) == before


def test_a_sweep_named_like_a_script_shows_as_text_under_a_strict_csp(server, web_store):
    base, _ = server
    for path in ("/", f"/sweep/{web_store['tiny']}", f"/?q={HOSTILE[:7]}"):
        status, headers, body = request(base, path.replace("<", "%3C"))
        assert status == 200
        assert HOSTILE.encode() not in body
        assert b"&lt;script&gt;alert(1)&lt;/script&gt;" in body
        csp = headers["Content-Security-Policy"]
        script_src = next(p for p in csp.split(";") if "script-src" in p)
        assert script_src.split() == ["script-src", "'self'"]   # no inline, no other origin
        assert "default-src 'none'" in csp and "http" not in csp
        assert b"<script>" not in body.replace(b'<script src="/static/', b"")


def test_oversized_work_is_refused_in_one_sentence(server, web_store, monkeypatch):
    from sweeps.web import downloads

    base, _ = server
    sid = web_store["avg"]
    status, _, body = request(base, "/explorer/stability.png?W_num=401&v_ref_num=10")
    assert status == 400 and body.count(b"\n") == 1 and b"400" in body
    monkeypatch.setattr(downloads, "MAX_CELLS", 100)
    status, _, body = request(base, f"/sweep/{sid}/query.csv")
    assert status == 413 and body.count(b"\n") == 1 and b"cells" in body
    status, _, body = request(base, f"/sweep/{sid}/query.csv?sel.v_d=nan")
    assert status == 400 and b"NaN" in body
    status, _, body = request(base, f"/sweep/{sid}/map/friction.png?pick=100000")
    assert status == 400 and body.count(b"\n") == 1


def test_a_refusal_echoes_what_was_sent_exactly(server, web_store):
    """An HTTPError's sentence is the body as written (tornado stores a bare '%' doubled)."""
    base, _ = server
    status, _, body = request(base, f"/sweep/{web_store['avg']}/query.csv?var=50%25")
    assert status == 400 and body == b"var: the cube has no variable '50%'\n", body


def test_map_renders_beyond_the_cap_are_refused_not_queued(server, web_store):
    """The render queue is full (its slots held by the test, not by timing): 503."""
    from concurrent.futures import Future

    base, ctx = server
    held = Future()
    for i in range(ctx.maps.max_waiting):
        ctx.maps._pending[("held", i)] = held
    try:
        status, _, body = request(base, f"/sweep/{web_store['avg']}/map/stability.png"
                                        "?sel.v_d=0.01")
        assert status == 503 and b"try again" in body
    finally:
        ctx.maps._pending.clear()


def test_explorer_images_beyond_the_render_cap_are_refused_not_queued(server):
    """The explorer's chart goes through the same render queue as the sweep maps: full,
    it is the same 503 (it was a 500: the queue's refusal was another class of the same
    name than the one the explorer's handler caught)."""
    from concurrent.futures import Future

    base, ctx = server
    held = Future()
    for i in range(ctx.maps.max_waiting):
        ctx.maps._pending[("held", i)] = held
    try:
        status, _, body = request(base, "/explorer/stability.png?W_num=3&v_ref_num=3")
        assert status == 503 and b"try again" in body, (status, body[:300])
    finally:
        ctx.maps._pending.clear()


def test_a_second_explorer_computation_is_refused_while_one_runs(server):
    base, ctx = server
    ctx.explorer._running = "someone else's"
    try:
        status, _, body = request(base, "/explorer/stability.png?W_num=5&v_ref_num=5")
        assert status == 503 and b"another explorer computation" in body
    finally:
        ctx.explorer._running = None


def test_a_cube_republished_during_a_read_is_read_whole(web_store, tmp_path):
    """The publish (a rename over cube.nc) happens between the open and the read: the
    read returns the old cube whole; the next read finds the new one."""
    from sweeps.web.snapshot import CubeSnapshot, Cubes, read_cube_bytes

    old = web_store["root"] / web_store["avg"] / "cube.nc"
    new = web_store["root"] / web_store["tiny"] / "cube.nc"
    path = tmp_path / "cube.nc"
    shutil.copy(old, path)

    def publish():
        shutil.copy(new, tmp_path / "tmp.nc")
        os.replace(tmp_path / "tmp.nc", path)

    key, data = read_cube_bytes(path, after_open=publish)
    assert data == old.read_bytes()
    assert CubeSnapshot(key, data).ds.attrs["sweep_id"] == web_store["avg"]
    assert Cubes().get(path).ds.attrs["sweep_id"] == web_store["tiny"]


TOKEN = "t0k3n-" + "x" * 40


def test_a_token_is_needed_compared_and_never_logged(web_store, serve_ctx, caplog):
    from sweeps.web.app import ServerState

    base = serve_ctx(ServerState(web_store["root"], token=TOKEN))
    caplog.set_level(logging.DEBUG, logger="ditherlab")   # the access log's logger
    assert request(base, "/")[0] == 401
    assert request(base, "/", headers={"Authorization": "Bearer " + "y" * len(TOKEN)})[0] == 401
    assert request(base, "/", headers={"Authorization": f"Bearer {TOKEN}"})[0] == 200
    status, headers, _ = request(base, f"/sweep/{web_store['avg']}?token={TOKEN}")
    assert status == 302 and headers["Location"] == f"/sweep/{web_store['avg']}"
    cookie = headers["Set-Cookie"].split(";")[0]
    assert "HttpOnly" in headers["Set-Cookie"] and "SameSite=Strict" in headers["Set-Cookie"]
    assert request(base, "/api/sweeps", headers={"Cookie": cookie})[0] == 200
    assert request(base, f"/?token={TOKEN[:-1]}Z")[0] == 401
    logged = "\n".join(r.getMessage() for r in caplog.records)
    assert "GET /sweep/" in logged   # the access log was on
    assert TOKEN not in logged and TOKEN[:-1] not in logged


def test_the_token_rules(tmp_path):
    from sweeps.errors import RefusedError
    from sweeps.web import security

    assert security.server_token("127.0.0.1", None) == (None, False)
    assert security.server_token("::1", None) == (None, False)
    token, generated = security.server_token("0.0.0.0", None)
    assert generated and len(token) >= 32
    assert security.server_token("10.1.2.3", None)[0] != token
    f = tmp_path / "token"
    f.write_text(TOKEN + "\n")
    assert security.server_token("0.0.0.0", str(f)) == (TOKEN, False)
    f.write_text("short")
    with pytest.raises(RefusedError, match="at least 16"):
        security.server_token("0.0.0.0", str(f))
    assert security.parse_bind(":8700") == ("127.0.0.1", 8700)
    assert security.parse_bind("[::1]:9") == ("::1", 9)
    with pytest.raises(RefusedError, match="HOST:PORT"):
        security.parse_bind("8700")


def test_a_cube_of_another_sweep_is_refused_without_the_servers_folders(web_store, serve_ctx,
                                                                         tmp_path):
    """A sweep folder holding another sweep's cube (copied by hand) is a 409 that names
    both sweeps and the folder inside the store, not where the store lives (it did:
    'the cube at /tmp/.../store/<id>/cube.nc is sweep ...')."""
    from sweeps.web.app import ServerState

    root = tmp_path / "copy"
    shutil.copytree(web_store["root"], root)
    avg, tiny = web_store["avg"], web_store["tiny"]
    shutil.copyfile(root / tiny / "cube.nc", root / avg / "cube.nc")
    base = serve_ctx(ServerState(root))
    for path in (f"/sweep/{avg}", f"/sweep/{avg}/cube.nc"):
        status, _, body = request(base, path)
        text = body.decode()
        assert status == 409, (path, status, text)
        assert f"the cube at {avg}/cube.nc is sweep {tiny}'s, not {avg}'s" in text, text
        assert str(tmp_path) not in text, text


def test_a_torn_cube_is_a_409_saying_how_to_republish_and_its_page_still_shows(
        web_store, serve_ctx, tmp_path):
    """A truncated cube.nc (found by review, 2026-11-28): every page of the sweep answered a
    bare 500 and logged a traceback, while `ditherlab status` names the fault and the repair.
    Now its downloads are a 409 with that sentence, and its page shows the state, the spec
    and the sentence, without the server's folders."""
    from sweeps.web.app import ServerState

    root = tmp_path / "copy"
    shutil.copytree(web_store["root"], root)
    avg = web_store["avg"]
    cube = root / avg / "cube.nc"
    cube.write_bytes(cube.read_bytes()[:1000])
    base = serve_ctx(ServerState(root))
    for path in (f"/sweep/{avg}/cube.nc", f"/sweep/{avg}/query.csv"):
        status, _, body = request(base, path)
        text = body.decode()
        assert status == 409, (path, status, text)
        assert text.startswith(f"the cube at {avg}/cube.nc is unreadable (") and \
            f"ditherlab submit {avg}/spec.json --store the store" in text, text
        assert str(tmp_path) not in text, text
    status, _, body = request(base, f"/sweep/{avg}")
    page = body.decode()
    assert status == 200, page
    [line] = [ln for ln in page.splitlines() if "unreadable</span>: the cube at " in ln]
    assert f"the cube at {avg}/cube.nc is unreadable (" in line and str(tmp_path) not in line
    assert "Grid and variables" not in page    # nothing drawn from the torn file


def test_the_one_cache_keeps_the_most_recent_entries_within_its_weight():
    from sweeps.web.lru import LRU

    counted = LRU(2)
    for k in "abc":
        counted.put(k, k.upper())
    assert "a" not in counted and counted.get("b") == "B"   # b is now the most recent
    counted.put("d", "D")
    assert "c" not in counted and len(counted) == 2
    weighed = LRU(10, weight=len)
    weighed.put("x", b"12345678")
    weighed.put("y", b"123")      # 11 bytes: the older goes
    assert "x" not in weighed and weighed.get("y") == b"123"
    weighed.put("big", b"0" * 50)   # over the budget alone: kept, being the last
    assert len(weighed) == 1 and weighed.pop("big") == b"0" * 50 and len(weighed) == 0


def test_no_page_names_the_servers_folders(server, web_store):
    """The sweep page's "folder" row and its JSON showed the server's full path of the store
    (found by review, 2026-11-28), while the view's error sentences left it out: now the
    folder inside the store."""
    base, _ = server
    avg = web_store["avg"]
    root = str(web_store["root"])
    for path in ("/", "/api/sweeps", f"/api/sweep/{avg}", f"/sweep/{avg}"):
        status, _, body = request(base, path)
        assert status == 200, (path, status)
        assert root not in body.decode(), path
    status, _, body = request(base, f"/sweep/{avg}")
    assert f"<tr><th>folder</th><td><code>{avg}</code></td></tr>" in body.decode()


def test_catalogue_reads_run_off_the_event_loop(web_store, serve_ctx):
    """A sweep's pages looked it up in the catalogue on the event loop: a read that takes
    long (a queued sweep's spec loaded, a brought model probed in a child: seconds) stalled
    every other request meanwhile (found by review, 2026-11-28)."""
    import asyncio

    from sweeps.web.app import ServerState

    ctx = ServerState(web_store["root"])
    find, calls, on_loop = ctx.live.find, [], []

    def spy(sweep_id):
        calls.append(sweep_id)
        try:
            asyncio.get_running_loop()
            on_loop.append(sweep_id)
        except RuntimeError:   # (a pool thread runs no loop)
            pass
        return find(sweep_id)

    ctx.live.find = spy
    base = serve_ctx(ctx)
    avg = web_store["avg"]
    for path in (f"/sweep/{avg}", f"/api/sweep/{avg}", f"/sweep/{avg}/query.csv?var=F_eff",
                 "/sweep/0123456789ab"):
        request(base, path)
    assert len(calls) == 4 and on_loop == []


def test_a_stale_sweeps_page_names_no_server_folder(web_store, serve_ctx, monkeypatch):
    """The sweep page's stale note says where the sweep's spec is, to resubmit it: that was
    the server's full path (`(e.g. /srv/.../store/<id>/spec.json)`), while the page's other
    paths are inside the store. The page and its JSON now read it inside the store too."""
    import sweeps.lookup
    from sweeps.web.app import ServerState

    root, avg = web_store["root"], web_store["avg"]
    note = f"made by engine x; `ditherlab submit SPEC` (e.g. {root / avg / 'spec.json'})"
    monkeypatch.setattr(sweeps.lookup, "stale_note", lambda row, ds=None, root=None: note)
    base = serve_ctx(ServerState(root))
    for path in (f"/sweep/{avg}", f"/api/sweep/{avg}"):
        status, _, body = request(base, path)
        assert status == 200 and str(root) not in body.decode(), path
        assert f"(e.g. {avg}/spec.json)" in body.decode(), path
