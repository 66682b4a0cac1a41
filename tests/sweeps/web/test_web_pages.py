"""The web view against the command line: downloads byte-equal to ``ditherlab query``, maps
from the code of ``ditherlab map`` drawn once per cube publish, the catalogue's JSON equal
to ``status --format json`` with a cursor that returns only what changed, and every socket
of ``web`` and ``serve --web`` on loopback by default."""
from __future__ import annotations

import json
import os
import signal
import subprocess
from pathlib import Path

import psutil
import pytest

from ...helpers import BIN, ditherlab
from .conftest import RUNNING_ID, request

pytestmark = pytest.mark.subprocess   # what it starts (tests/conftest.py)


@pytest.mark.parametrize("fmt,args,query", [
    ("csv", ["--sel", "v_d=0.1"], "sel.v_d=0.1"),
    ("json", ["--var", "stable", "--sel", "v_d=0.01"], "var=stable&sel.v_d=0.01"),
    ("csv", [], ""),
])
def test_query_downloads_are_the_bytes_of_ditherlab_query(server, web_store, fmt, args, query):
    base, _ = server
    sid = web_store["avg"]
    cli = ditherlab("query", sid, "--format", fmt, *args, store=web_store["root"], text=False)
    assert cli.returncode == 0, cli.stderr
    status, headers, body = request(base, f"/sweep/{sid}/query.{fmt}?{query}")
    assert status == 200
    assert body == cli.stdout
    assert "attachment" in headers["Content-Disposition"]


def test_maps_are_ditherlab_maps_drawn_once_per_publish(server, web_store, tmp_path):
    base, ctx = server
    sid = web_store["avg"]
    out = tmp_path / "cli.png"
    cli = ditherlab("map", sid, "--kind", "stability", "--sel", "v_d=0.1", "-o", str(out),
                    "--store", str(web_store["root"]))
    assert cli.returncode == 0, cli.stderr
    url = f"/sweep/{sid}/map/stability.png?sel.v_d=0.1"
    drawn = ctx.maps.drawn
    status, headers, body = request(base, url)
    assert status == 200 and headers["Content-Type"] == "image/png"
    assert body == out.read_bytes()
    assert request(base, url)[2] == body
    assert ctx.maps.drawn == drawn + 1          # the second answer came from the cache
    for fmt, magic in (("svg", b"<?xml"), ("pdf", b"%PDF")):
        status, _, data = request(base, f"/sweep/{sid}/map/stability.{fmt}?sel.v_d=0.1")
        assert status == 200 and data.startswith(magic)
    cube = web_store["root"] / sid / "cube.nc"
    os.utime(cube)                               # a new publish (new mtime): drawn again
    assert request(base, url)[2] == body
    assert ctx.maps.drawn == drawn + 4


def test_a_map_axis_given_as_a_selection_is_refused_like_the_cli(server, web_store):
    base, _ = server
    status, _, body = request(base, f"/sweep/{web_store['avg']}/map/stability.png?sel.W=0.5")
    assert status == 400 and b"is an axis of the stability map" in body


def test_the_catalogue_json_is_status_json_and_the_cursor_returns_changes(server, web_store,
                                                                         running):
    base, ctx = server
    ctx.live.refresh_s = 0   # read the catalogue on every request (default: at most 4/s)
    cli = ditherlab("status", "--format", "json", "--store", str(web_store["root"]))
    assert cli.returncode == 0, cli.stderr
    root = web_store["root"]
    inside = lambda r: {**r, "folder": Path(r["folder"]).relative_to(root).as_posix()}  # noqa: E731
    listed = [inside(r) for r in json.loads(cli.stdout)["sweeps"]]   # (the web names no
    #                                                                   server folder)
    status, _, body = request(base, "/api/sweeps?after=0")
    page = json.loads(body)
    strip = [{k: v for k, v in r.items() if k != "seq"} for r in page["sweeps"]]
    assert strip == listed
    cursor = page["cursor"]
    assert json.loads(request(base, f"/api/sweeps?after={cursor}")[2])["sweeps"] == []
    running.advance(25)
    changed = json.loads(request(base, f"/api/sweeps?after={cursor}")[2])
    assert [r["sweep_id"] for r in changed["sweeps"]] == [RUNNING_ID]
    assert changed["sweeps"][0]["done_points"] == 25 and changed["cursor"] > cursor
    status, _, body = request(base, f"/api/sweep/{web_store['avg']}")
    one = json.loads(body)
    cli_one = json.loads(ditherlab("status", web_store["avg"], "--format", "json", "--store",
                                   str(web_store["root"])).stdout)
    assert one == inside(cli_one)


def test_catalogue_filters_and_sorts(server, web_store):
    base, _ = server
    body = request(base, "/?q=web-avg")[2].decode()
    assert web_store["avg"] in body and web_store["tiny"] not in body
    body = request(base, "/?state=done&sort=name&desc=0")[2].decode()
    assert body.index(web_store["tiny"]) < body.index(web_store["avg"])   # '<' before 'w'
    assert request(base, "/?sort=evil")[0] == 400


def _listening(pid: int) -> list[str]:
    proc = psutil.Process(pid)
    found = []
    for p in [proc, *proc.children(recursive=True)]:
        for c in p.net_connections(kind="inet"):
            if c.status == psutil.CONN_LISTEN:
                found.append(c.laddr.ip)
    return found


def _started(cmd: list[str], marker: bytes) -> tuple[subprocess.Popen, bytes]:
    proc = subprocess.Popen(cmd, stderr=subprocess.PIPE, stdout=subprocess.DEVNULL,
                            env={**os.environ, "MPLBACKEND": "Agg"})
    line = b""
    while marker not in line:   # the server says where it listens once it does
        line = proc.stderr.readline()
        if not line:
            raise AssertionError(f"{cmd} ended: {proc.wait()}")
    return proc, line


@pytest.mark.parametrize("cmd,marker", [
    (["web"], b"ditherlab web:"),
    (["serve", "--web", "127.0.0.1:0"], b"web pages at"),
])
def test_every_socket_of_web_and_serve_web_is_on_loopback(web_store, cmd, marker):
    proc, line = _started([str(BIN), *cmd, "--store", str(web_store["root"])], marker)
    try:
        ips = _listening(proc.pid)
        assert ips and all(ip in ("127.0.0.1", "::1") for ip in ips), ips
        port = line.decode().split("127.0.0.1:")[1].split("/")[0]
        assert request(f"http://127.0.0.1:{port}", "/")[0] == 200
    finally:
        proc.send_signal(signal.SIGTERM)
        proc.wait(timeout=60)


def test_a_gallery_folder_is_served_by_name_only(web_store, serve_ctx, tmp_path):
    from sweeps.web.app import ServerState

    gallery = tmp_path / "gallery"
    gallery.mkdir()
    (gallery / "index.html").write_text("<style>p{}</style><p>gallery</p><img src='fig09.png'>")
    (gallery / "fig09.png").write_bytes(b"\x89PNG fake")
    (gallery / "leak.png").symlink_to(web_store["root"] / "catalogue.sqlite")
    base = serve_ctx(ServerState(web_store["root"], gallery=str(gallery)))
    status, headers, body = request(base, "/gallery/")
    assert status == 200 and b"<p>gallery</p>" in body
    assert "script-src 'self';" in headers["Content-Security-Policy"]   # its styles only
    assert request(base, "/gallery/fig09.png")[2] == b"\x89PNG fake"
    assert request(base, "/gallery/leak.png")[0] == 404
    assert request(base, "/gallery/missing.png")[0] == 404
    assert request(serve_ctx(ServerState(web_store["root"])), "/gallery/")[0] == 404


@pytest.mark.long
@pytest.mark.parametrize("drawn", [True, False])
def test_the_drawing_process_ends_with_a_killed_server(web_store, drawn):
    """Killed after drawing a map, or at once (the drawing process still starting: it
    left orphans that way, seen after the socket tests)."""
    proc, line = _started([str(BIN), "web", "--bind", "127.0.0.1:0", "--store",
                           str(web_store["root"])], b"ditherlab web:")
    port = line.decode().split("127.0.0.1:")[1].split("/")[0]
    if drawn:
        status, _, _ = request(f"http://127.0.0.1:{port}",
                               f"/sweep/{web_store['avg']}/map/stability.png?sel.v_d=0.1")
        if status != 200:   # the server's log says why
            proc.kill()
            raise AssertionError(f"{status}: {proc.communicate()[1].decode()[-3000:]}")
    children = psutil.Process(proc.pid).children(recursive=True)
    assert children   # the drawing process (and multiprocessing's resource tracker)
    proc.kill()
    proc.wait()
    gone, alive = psutil.wait_procs(children, timeout=60)
    assert not alive, [p.cmdline() for p in alive]


def test_the_sweep_page_shows_the_recorded_time_estimate(server, web_store):
    """The plan's cost per level, as ``ditherlab plan --record`` kept it in the store, and
    the time the run took; without a record the page says how to make one."""
    from sweeps.estimates import time_history

    base, _ = server
    sid, root = web_store["avg"], web_store["root"]
    status, _, body = request(base, f"/sweep/{sid}")
    assert status == 200 and b"none recorded" in body and b"plan SPEC --record" in body
    saved = (root / time_history.FILE).read_bytes() if (root / time_history.FILE).exists() \
        else None
    try:
        time_history.record_estimate(root, sid, {"draft": 12.25, "standard": 31.5})
        time_history.record_actual(root, sid, "standard", 29.75)
        status, _, body = request(base, f"/sweep/{sid}")
        assert status == 200
        assert b"draft 12.2 s, standard 31.5 s" in body and b"took 29.8 s at standard" in body
    finally:
        if saved is None:
            (root / time_history.FILE).unlink()
        else:
            (root / time_history.FILE).write_bytes(saved)
