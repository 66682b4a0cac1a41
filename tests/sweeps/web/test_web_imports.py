"""The web server's threads make their first imports one at a time (sweeps.web.first_imports):
a page reading its first cube while the explorer's warm-up imported dask got a partially
initialized ``dask.base`` and answered 500 (CI 11-29; 5 server starts in 9 here before).
Whether two imports collide is timing luck, so the test does not wait for one: in a fresh
process, an import hook records where every first import of the packages that collided
(and their neighbours) was made, and each must have been made under ``ready()``."""
from __future__ import annotations

import json
import os
import subprocess
import sys

from sweeps.web.first_imports import MODULES

WATCHED = ("xarray", "dask", "h5netcdf", "numba", "pandas")

PROGRAM = r"""
import json, sys, threading
WATCHED = set(sys.argv[2].split(","))
records = []

class Recorder:
    def find_spec(self, name, path=None, target=None):
        if name.split(".")[0] in WATCHED:
            frame, inside = sys._getframe(1), False
            while frame is not None:
                code = frame.f_code
                inside |= code.co_name == "ready" and code.co_filename.endswith(
                    "first_imports.py")
                frame = frame.f_back
            records.append([name, threading.current_thread().name, inside])
        return None

sys.meta_path.insert(0, Recorder())
from sweeps.web.app import ServerState, start_in_thread
from tests.sweeps.web.conftest import request

ctx = ServerState(sys.argv[1])
port, stop = start_in_thread(ctx, "127.0.0.1", 0)
warm = ctx.explorer.warm_up()
base = f"http://127.0.0.1:{port}"
sid = sys.argv[3]
answers = [request(base, f"/sweep/{sid}/query.csv?sel.v_d=0.1")[0],
           request(base, f"/sweep/{sid}/map/stability.png?sel.v_d=0.1")[0]]
warm.result()
stop()
ctx.maps.draw.stop()
print(json.dumps({"answers": answers, "records": records}))
"""


def test_every_first_import_of_the_server_threads_is_made_under_the_lock(web_store):
    out = subprocess.run([sys.executable, "-c", PROGRAM, str(web_store["root"]),
                          ",".join(WATCHED), web_store["avg"]],
                         capture_output=True, text=True, timeout=300,
                         env={**os.environ, "MPLBACKEND": "Agg"})
    assert out.returncode == 0, out.stderr[-3000:]
    seen = json.loads(out.stdout.splitlines()[-1])
    assert seen["answers"] == [200, 200]
    first = {name: inside for name, _, inside in reversed(seen["records"])}
    assert {"xarray", "dask", "dask.base", "numba"} <= set(first)   # the hook saw them
    # the hook records the WATCHED packages only, so this holds MODULES' entries from them
    # (a package's own later imports, numba's while it compiles on the explorer's one
    # thread, are the package's)
    outside = [name for name in MODULES if not first.get(name, True)]
    assert not outside, outside
