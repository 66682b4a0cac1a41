"""The command line and API fit the ecosystem (issue 14): fast start, nothing written by
read-only commands, figures in the format their name asks for, names never guessed, an API
that takes a Spec and an existing dask client and opens cubes lazily."""
from __future__ import annotations

import re
import subprocess
import sys
import tomllib
from pathlib import Path

import numpy as np
import pytest

import sweeps
from sweeps import cli
from sweeps.errors import AmbiguousSweepError

from ..helpers import LOOPBACK_CLUSTER, SIMULATE_SPEC

pytestmark = pytest.mark.subprocess   # what it starts (tests/conftest.py)

AVERAGED = {"name": "eco-avg", "friction": "lugre", "method": "averaged",
            "grid": {"W": [0.0, 0.4], "v_ref": [0.1, 0.2, 0.3]}}
HEAVY = ("numba", "dask", "distributed", "xarray", "matplotlib", "scipy", "pydantic")


def run_cli(*args, cwd=None) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "sweeps.cli", *args], cwd=cwd,
                          capture_output=True, text=True, timeout=300)


def _status_in_a_child(*argv) -> tuple[str, str]:
    """``ditherlab *argv`` (exit 0) in a fresh process: what it printed, and the heavy
    packages it imported (``"[]"``: none)."""
    code = (f"import sys; from sweeps.cli import main\n"
            f"assert main({list(argv)!r}) == 0\n"
            f"print(sorted(m for m in {HEAVY!r} if m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         timeout=120)
    assert out.returncode == 0, out.stderr
    return out.stdout, out.stdout.strip().splitlines()[-1]


@pytest.fixture(scope="module")
def avg_store(tmp_path_factory):
    root = tmp_path_factory.mktemp("eco") / "store"
    res = sweeps.run_sweep(sweeps.load_spec(AVERAGED), store=root, progress=False)
    assert res.state == "done"
    return root


def test_help_and_status_import_no_numerics(tmp_path):
    """Start-up time is import time: `--help` and `status` load none of the heavy packages
    (measured: 0.12 s and 0.3 s, against 3.6-5.5 s before)."""
    code = (f"import sys; from sweeps.cli import main\n"
            f"for argv in (['status', '--store', {str(tmp_path / 's')!r}],):\n"
            f"    assert main(argv) == 0\n"
            f"try:\n    main(['--help'])\nexcept SystemExit:\n    pass\n"
            f"print(sorted(m for m in {HEAVY!r} if m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         timeout=120)
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip().splitlines()[-1] == "[]"


def test_status_of_a_store_with_a_queued_sweep_imports_no_numerics(tmp_path):
    """A sweep queued by `submit --detach` was registered without its engine's fingerprint,
    so every `status` (and every refresh of the web view, on its event loop) loaded its spec
    again to judge it stale, a brought model probed in a child: 1.9 s for one queued sweep
    (found by review, 2026-11-28). The row now names its engine."""
    from sweeps.planning.plan import make_plan
    from sweeps.service import enqueue
    from sweeps.version import results_fingerprint

    root = tmp_path / "s"
    row = enqueue(make_plan(sweeps.load_spec(AVERAGED)), root)
    assert row["state"] == "queued" and row["engine_fingerprint"] == results_fingerprint()
    said, heavy = _status_in_a_child("status", "--store", str(root))
    assert "queued" in said and heavy == "[]", said


def test_version_flag():
    out = run_cli("--version")
    assert out.returncode == 0 and out.stdout.startswith(f"ditherlab {sweeps.__version__}")


@pytest.mark.parametrize("argv", [
    ["status"], ["status", "ghost"], ["query", "ghost"],
    ["map", "ghost", "--kind", "stability", "-o", "{tmp}/x.png"],
])
def test_read_only_commands_leave_a_fresh_store_path_absent(tmp_path, argv):
    root = tmp_path / "never-made"
    out = run_cli(*[a.format(tmp=tmp_path) for a in argv], "--store", str(root))
    assert out.returncode in (0, 1), out.stderr
    assert not root.exists(), f"{argv} created {sorted(root.rglob('*'))}"


def test_plan_writes_nothing_unless_asked(tmp_path):
    spec = tmp_path / "a.json"
    spec.write_text(sweeps.load_spec(AVERAGED).to_json())
    root = tmp_path / "store"
    assert run_cli("plan", str(spec), "--store", str(root)).returncode == 0
    assert not root.exists()
    assert run_cli("plan", str(spec), "--store", str(root), "--record").returncode == 0
    assert (root / "estimates.json").exists()


@pytest.mark.parametrize("suffix, magic", [(".pdf", b"%PDF"), (".svg", b"<?xml"),
                                           (".png", b"\x89PNG")])
def test_map_writes_the_format_its_suffix_asks_for(avg_store, tmp_path, suffix, magic):
    path = tmp_path / f"chart{suffix}"
    code = cli.main(["map", "eco-avg", "--kind", "stability", "--store", str(avg_store),
                     "-o", str(path)])
    assert code == 0 and path.read_bytes().startswith(magic)


@pytest.mark.parametrize("name, message", [
    ("missing/x.png", "the folder .*missing does not exist"),
    ("x.jpg", r"must end in \.png, \.pdf, \.svg \(got \.jpg\)"),
])
def test_map_refuses_other_suffixes_and_missing_folders(avg_store, tmp_path, capsys, name,
                                                        message):
    code = cli.main(["map", "eco-avg", "--kind", "stability", "--store", str(avg_store),
                     "-o", str(tmp_path / name)])
    err = capsys.readouterr().err
    assert code == 2 and len(err.strip().splitlines()) == 1
    assert re.search(message, err), err
    assert not (tmp_path / "missing").exists() and not (tmp_path / "x.jpg").exists()


def test_a_name_of_two_current_sweeps_is_refused_with_the_candidates(avg_store, capsys):
    other = {**AVERAGED, "grid": {"W": [0.0, 0.5], "v_ref": [0.1, 0.2]}}   # same name
    second = sweeps.run_sweep(other, store=avg_store, progress=False).sweep_id
    first = sweeps.load_spec(AVERAGED).sweep_id
    with pytest.raises(AmbiguousSweepError, match=f"'eco-avg' names 2 sweeps: .*{second}"):
        sweeps.open_sweep("eco-avg", store=avg_store)
    code = cli.main(["query", "eco-avg", "--store", str(avg_store)])
    err = capsys.readouterr().err
    assert code == 2 and first in err and second in err and "pass the sweep id" in err
    assert sweeps.open_sweep(first, store=avg_store)["F_eff"].shape == (2, 1, 3, 1)


def test_open_sweep_is_lazy_with_chunks(avg_store):
    key = sweeps.load_spec(AVERAGED).sweep_id
    with sweeps.open_sweep(key, store=avg_store, chunks={}) as lazy:
        assert lazy["F_eff"].chunks is not None          # dask-backed: nothing read yet
        eager = sweeps.open_sweep(key, store=avg_store)
        np.testing.assert_array_equal(lazy["F_eff"].values, eager["F_eff"].values)


@pytest.mark.long
def test_run_sweep_takes_a_spec_and_an_existing_client(tmp_path):
    """A Spec object and a caller's dask.distributed.Client (left open after the run)."""
    from distributed import Client, LocalCluster

    # the scene of tests.helpers.SIMULATE_SPEC: its kernels are compiled once for both
    spec = sweeps.load_spec({**tomllib.loads(SIMULATE_SPEC), "name": "eco-sim",
                             "time": {"t_end": 5.0, "t_transient": 1.0},
                             "grid": {"W": [0.0, 0.2], "omega": [300.0], "v_ref": [0.4],
                                      "v_d": [0.1]}})
    with LocalCluster(n_workers=1, threads_per_worker=1, processes=False,
                      **LOOPBACK_CLUSTER) as cluster, Client(cluster) as client:
        res = sweeps.run_sweep(spec, store=tmp_path / "s", client=client, progress=False)
        assert res.state == "done" and res.n_ok == 2
        assert client.status == "running"
    assert Path(res.cube_path).name == "cube.nc"
    # the same numbers as the service's own cluster computes
    own = sweeps.run_sweep(spec, store=tmp_path / "own", workers=1, progress=False)
    for name in ("v_mean", "status"):
        np.testing.assert_array_equal(sweeps.open_sweep(res.sweep_id, tmp_path / "s")[name],
                                      sweeps.open_sweep(own.sweep_id, tmp_path / "own")[name])


def test_status_of_one_sweep_imports_no_numerics(avg_store):
    """`status SWEEP` reads the cube's attributes with h5py alone (0.4 s, against 1.9 s)."""
    key = sweeps.load_spec(AVERAGED).sweep_id   # the name may be shared by now (see above)
    said, heavy = _status_in_a_child("status", key, "--store", str(avg_store))
    assert "state: done" in said and heavy == "[]"


def test_a_name_given_again_after_editing_a_brought_law_means_its_source_as_it_is(tmp_path):
    """A user edits their law (docs/examples/mylab) and submits the same spec again: a new
    sweep (the id covers the model's source) under the same name. The name was refused as
    naming two current sweeps; it now means the sweep of the source as it is now
    (sweeps.lookup.model_changed), and once that source is gone too it is refused again."""
    import json
    import os
    import shutil

    root = Path(__file__).resolve().parents[2]
    shutil.copytree(root / "docs" / "examples" / "mylab", tmp_path / "mylab",
                    ignore=shutil.ignore_patterns("__pycache__"))
    (tmp_path / "spec.json").write_text(json.dumps({
        "name": "edited-law", "friction": "mylab.laws:MaxwellSlip", "dither": "none",
        "outputs": ["v_mean"], "accuracy": "draft", "time": {"t_end": 2.0, "t_transient": 1.0},
        "params": {"gms": {"k": [100.0], "alpha": [1.0], "C": 20.0}},
        "grid": {"v_ref": [0.1, 0.2]}}))
    env = {**os.environ, "PYTHONPATH": str(tmp_path)}

    def ditherlab(*args):
        return subprocess.run([str(Path(sys.executable).parent / "ditherlab"), *args,
                               "--store", str(tmp_path / "runs")], cwd=tmp_path, env=env,
                              capture_output=True, text=True, timeout=300)

    laws = tmp_path / "mylab" / "laws.py"
    ids = []
    for edit in ("", "\n# the user's edit\n"):
        laws.write_text(laws.read_text() + edit)
        out = ditherlab("submit", "spec.json", "--detach")   # queued: nothing computed
        assert out.returncode == 0, out.stderr
        ids.append(out.stdout.split(":")[0].strip())
    assert len(set(ids)) == 2, ids
    out = ditherlab("status", "edited-law")
    assert out.returncode == 0 and ids[1] in out.stdout and ids[0] not in out.stdout, \
        (out.stdout, out.stderr)
    laws.write_text(laws.read_text() + "\n# edited once more\n")   # neither is current now
    out = ditherlab("status", "edited-law")
    assert out.returncode == 2 and "names 2 sweeps" in out.stderr, out.stderr
