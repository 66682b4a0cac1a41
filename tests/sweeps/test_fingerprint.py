"""Results tied to the engine that made them (issue 9, "no stale result served as current").

The sweep id hashes the engine fingerprint (engine.provenance: sha256 over engine/**/*.py),
so after any engine edit a resubmitted spec computes a fresh sweep instead of returning
the old cube as "already complete"; the old cube stays readable and is marked stale.
Engine edits are simulated on a copy of the engine tree or by monkeypatching
``engine.provenance.fingerprint`` -- the real sources are never touched.
"""
import shutil
import sqlite3

import pytest
import xarray as xr

from engine import jit, provenance
from store.catalogue import Catalogue
from store.catalogue_db import SCHEMA
from sweeps import cli, lookup, version
from sweeps.spec import parse_spec
from ..helpers import SIMULATE_OUTPUTS

FP_A, FP_B = "aaaaaaaaaaaa", "bbbbbbbbbbbb"

TINY_AVERAGED = """
name = "fp-avg"
friction = "lugre"
dither = "square-velocity"
method = "averaged"
[grid]
W = [0.0, 0.5, 1.0]
v_ref = [0.1, 0.5]
v_d = [0.1]
"""


pytestmark = pytest.mark.subprocess   # what it starts (tests/conftest.py)

def engine_copy(tmp_path):
    return shutil.copytree(provenance.ENGINE_ROOT, tmp_path / "engine",
                           ignore=shutil.ignore_patterns("__pycache__", "*.pyc"))


def test_any_engine_source_edit_changes_the_fingerprint(tmp_path):
    copy = engine_copy(tmp_path)
    before = provenance.source_hash(copy)
    assert before == provenance.source_hash(provenance.ENGINE_ROOT) == provenance.fingerprint()
    assert len(before) == 12 and int(before, 16) >= 0

    with open(copy / "status.py", "a") as f:          # a comment is an edit too
        f.write("# a comment\n")
    after_comment = provenance.source_hash(copy)
    assert after_comment != before
    (copy / "friction" / "extra.py").write_text("X = 1\n")   # a new file, in a subpackage
    after_new = provenance.source_hash(copy)
    assert after_new not in (before, after_comment)
    (copy / "friction" / "extra.py").rename(copy / "friction" / "other.py")   # a rename
    assert provenance.source_hash(copy) not in (before, after_comment, after_new)
    (copy / "notes.txt").write_text("not a source")   # non-Python files do not count
    (copy / "friction" / "other.py").unlink()
    (copy / "status.py").write_bytes((provenance.ENGINE_ROOT / "status.py").read_bytes())
    assert provenance.source_hash(copy) == before


def test_fingerprint_is_cached_and_names_the_numba_cache():
    assert provenance.fingerprint() is provenance.fingerprint()
    assert provenance.fingerprint.cache_info().hits >= 1
    assert jit.cache_dir().name == f"numba-{provenance.fingerprint()}"


def test_sweep_id_depends_on_the_engine_fingerprint(monkeypatch):
    spec = parse_spec({"name": "x", "method": "averaged",
                       "grid": {"W": [0.0, 1.0], "v_ref": [0.1], "v_d": [0.1]}})
    renamed = spec.model_copy(update={"name": "y"})
    monkeypatch.setattr(provenance, "fingerprint", lambda: FP_A)
    id_a = spec.sweep_id
    assert renamed.sweep_id == id_a                   # cosmetic fields still do not count
    monkeypatch.setattr(provenance, "fingerprint", lambda: FP_B)
    assert spec.sweep_id != id_a


def run(capsys, *args) -> tuple[int, str, str]:
    code = cli.main(list(args))
    out, err = capsys.readouterr()
    return code, out, err


def source_copy(tmp_path):
    """A copy of the three packages, for edits the real tree never sees."""
    skip = shutil.ignore_patterns("__pycache__", "*.pyc")
    for package in version.PACKAGES:
        shutil.copytree(version.ROOT / package, tmp_path / package, ignore=skip)
    return tmp_path


def fingerprint_of_copy(root):
    return version.fingerprint_of(root, provenance.source_hash(root / "engine"))


def test_every_module_on_the_computing_path_is_in_the_results_fingerprint(tmp_path):
    """The path is found, not listed (sweeps.version): an edit of any module it holds --
    here a comment appended, the smallest edit -- changes the fingerprint. The module that
    escaped the hand-kept list before (the refinement's lattices, moved out of refine.py
    without being added) is on it."""
    root = source_copy(tmp_path)
    before = fingerprint_of_copy(root)
    assert before == version.results_fingerprint()
    path = version.computing_path(root)
    import sweeps.planning.lattice as lattice
    assert lattice.__name__ in path and set(version.ENTRY_MODULES) <= set(path)
    for name, file in sorted(path.items()):
        original = file.read_bytes()
        file.write_bytes(original + b"\n# an edit\n")
        assert fingerprint_of_copy(root) != before, f"{name} is not in the fingerprint"
        file.write_bytes(original)
    assert fingerprint_of_copy(root) == before


def test_a_module_off_the_computing_path_leaves_the_fingerprint(tmp_path):
    """The command line's help text and the read side's maps make no number of a cube: an
    edit there keeps every sweep current."""
    root = source_copy(tmp_path)
    before = fingerprint_of_copy(root)
    for rel in ("sweeps/cli/main.py", "store/maps.py"):
        assert not any(p == root / rel for p in version.computing_path(root).values())
        file = root / rel
        text = file.read_text()
        assert "help=" in text or rel != "sweeps/cli/main.py"
        file.write_text(text.replace('help="', 'help="(edited) ', 1) + "# an edit\n")
        assert fingerprint_of_copy(root) == before, rel


# The computing path, reviewed (issue 38): every module of store/ and sweeps/ whose source is
# in the results fingerprint (engine/ is, all of it, by its own hash). A module joining or
# leaving the path shows here, in the diff that makes it join or leave.
COMPUTING_PATH = """
store store.atomic store.attrs store.catalogue store.catalogue_db store.cube store.cube_io
store.cubedata store.errors store.flags store.journal store.journal_groups store.layout
store.lease store.netcdf_write store.points store.record
sweeps sweeps.errors sweeps.version
sweeps.spec sweeps.spec.accuracy sweeps.spec.fixed_step sweeps.spec.grid sweeps.spec.messages
sweeps.spec.methods sweeps.spec.model_params sweeps.spec.models
sweeps.planning sweeps.planning.blocks sweeps.planning.lattice sweeps.planning.plan
sweeps.planning.refine
sweeps.workers sweeps.workers.cluster sweeps.workers.compute sweeps.workers.deaths
sweeps.workers.matching sweeps.workers.local_start sweeps.workers.task sweeps.workers.threads
sweeps.estimates sweeps.estimates.error_estimate sweeps.estimates.error_reruns
sweeps.run sweeps.run.dispatch sweeps.run.head_start sweeps.run.interrupt sweeps.run.lease_holder
sweeps.run.local
sweeps.run.new_cube sweeps.run.order sweeps.run.outcome sweeps.run.preparation sweeps.run.quiet
sweeps.run.refined sweeps.run.sink sweeps.run.submit
""".split()

# Off the path, each for its reason, though a run may load them: they make no number. The
# display and the time history are called by the runner's callers (the display handed in:
# sweeps.run.quiet), the batch jobs are built by the command line (Compute is handed a
# BatchWorkers); nothing they return is computed with.
OFF_THE_PATH = {
    "sweeps.run.phases": "the progress bars, handed to the runner (sweeps.run.quiet)",
    "sweeps.run.progress": "another run's progress, shown while attached",
    "sweeps.estimates.time_history": "estimated against measured wall time, for `plan`",
    "sweeps.workers.batch": "the batch system's job options and scaling (Compute(batch=))",
}


def test_the_computing_path_is_the_reviewed_list():
    """The path's modules are those of COMPUTING_PATH: none joined or left it unreviewed;
    the display, the time history, the batch options and the tests' gates are not on it
    (2026-11-27: 53 modules of store/ and sweeps/, 54 before issue 38; +1: sweeps.workers.local_start, split from sweeps.workers.cluster; 2026-11-28 +1: sweeps.workers.deaths, which decides
    that a block that kept killing its workers is journaled FAILED; 2026-11-30 +1:
    sweeps.run.order, split from sweeps.run.dispatch: which blocks a task computes)."""
    path = {name for name in version.computing_path() if name.split(".")[0] != "engine"}
    joined, left = sorted(path - set(COMPUTING_PATH)), sorted(set(COMPUTING_PATH) - path)
    assert not joined and not left, \
        f"the computing path changed: joined {joined}, left {left}; review, then update COMPUTING_PATH"
    assert not path & set(OFF_THE_PATH)
    assert len(COMPUTING_PATH) == len(set(COMPUTING_PATH))


# Run in a fresh interpreter: the front (API, spec loading) is imported first; every module
# of ours that planning, a worker's block, refinement, journaling and publishing then load
# must be on the computing path, or be one of OFF_THE_PATH.
LOADED_BY_A_RUN = """
import json, sys, warnings
import sweeps.api, sweeps.lookup, sweeps.spec.load
from sweeps.spec import parse_spec

chart = parse_spec({{"name": "c", "friction": "lugre", "method": "averaged", "refine": True,
                    "grid": {{"W": {{"start": 0.0, "stop": 1.0, "num": 9}},
                             "v_ref": {{"start": 0.05, "stop": 1.0, "num": 9}}}}}})
sim = parse_spec({{"name": "s", "friction": "lugre", "accuracy": "draft",
                  "outputs": {outputs!r},   # (the e2e SIMULATE_SPEC's scene: one compile)
                  "time": {{"t_end": 2.0, "t_transient": 1.0}},
                  "grid": {{"W": [0.0, 0.5], "omega": [100.0], "v_ref": [0.1]}}}})
before = set(sys.modules)
with warnings.catch_warnings():
    warnings.simplefilter("ignore")
    sweeps.api.run_sweep(chart, store={store!r}, progress=False)
    from sweeps.planning.plan import make_plan
    from sweeps.workers import task
    plan = make_plan(sim)
    out = task.compute_block(plan.scene, plan.block_points(0), plan.params,
                             plan.numerics.settings)
    assert (out.status == 0).all(), out
print(json.dumps(sorted(set(sys.modules) - before)))
"""


@pytest.mark.long
def test_the_computing_path_holds_every_module_a_run_loads(tmp_path):
    import json
    import subprocess
    import sys

    code = LOADED_BY_A_RUN.format(store=str(tmp_path / "store"), outputs=list(SIMULATE_OUTPUTS))
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr[-3000:]
    ours = {m for m in json.loads(proc.stdout.splitlines()[-1])
            if m.split(".")[0] in version.PACKAGES}
    assert {"sweeps.run.submit", "sweeps.workers.task", "engine.blocks", "store.journal"} <= ours, ours
    missing = sorted(ours - set(version.computing_path()) - set(OFF_THE_PATH))
    assert not missing, f"loaded by a run but not in the results fingerprint: {missing}"


def test_resubmission_after_an_engine_change_recomputes_and_the_old_cube_is_stale(
        tmp_path, monkeypatch, capsys):
    store_dir = str(tmp_path / "store")
    spec = tmp_path / "spec.toml"
    spec.write_text(TINY_AVERAGED)
    st = ("--store", store_dir)

    monkeypatch.setattr(provenance, "fingerprint", lambda: FP_A)
    RA = version.results_fingerprint()      # the engine's and the planning modules' hash
    code, out, _ = run(capsys, "submit", str(spec), "--quiet", *st)
    assert code == 0 and "ran " in out
    old_id = out.split(":")[0]
    code, out, _ = run(capsys, "submit", str(spec), "--quiet", *st)
    assert code == 0 and "already complete" in out and out.startswith(old_id)
    with xr.open_dataset(tmp_path / "store" / old_id / "cube.nc", engine="h5netcdf") as ds:
        assert ds.attrs["engine_fingerprint"] == RA
    code, out, err = run(capsys, "status", *st)
    assert "stale" not in out

    # the engine changes: the old cube is stale, but still readable
    monkeypatch.setattr(provenance, "fingerprint", lambda: FP_B)
    RB = version.results_fingerprint()
    assert RA != RB
    code, out, _ = run(capsys, "status", *st)
    assert code == 0 and f"done ({lookup.STALE})" in out
    code, out, err = run(capsys, "query", "fp-avg", "--var", "F_eff", "--format", "csv", *st)
    assert code == 0 and out.startswith("W,")                # still answers ...
    warnings = [line for line in err.splitlines() if "warning" in line]
    assert len(warnings) == 1 and RA in warnings[0] and RB in warnings[0]  # ... one line
    code, out, _ = run(capsys, "status", old_id, *st)
    assert f"state: done ({lookup.STALE})" in out
    assert f"made by engine {RA}, the installed engine is {RB}" in out
    assert "ditherlab submit SPEC" in out

    # resubmitting computes a fresh sweep rather than serving the old cube
    code, out, _ = run(capsys, "submit", str(spec), "--quiet", *st)
    assert code == 0 and "already complete" not in out and "ran " in out
    new_id = out.split(":")[0]
    assert new_id != old_id
    with xr.open_dataset(tmp_path / "store" / new_id / "cube.nc", engine="h5netcdf") as ds:
        assert ds.attrs["engine_fingerprint"] == RB
    code, out, _ = run(capsys, "status", *st)
    lines = {line.split()[0]: line for line in out.splitlines()[1:]}
    assert lookup.STALE in lines[old_id] and lookup.STALE not in lines[new_id]

    # the name now resolves to the current-engine sweep, without a warning
    assert lookup.resolve_sweep(tmp_path / "store", "fp-avg")[0] == new_id
    code, out, err = run(capsys, "query", "fp-avg", "--var", "F_eff", *st)
    assert code == 0 and "warning" not in err
    code, out, err = run(capsys, "map", old_id, "--kind", "friction", "-o",
                         str(tmp_path / "old.png"), *st)
    assert code == 0 and err.count("warning") == 1 and old_id in err

    # rows recorded no fingerprint before this change (legacy catalogues): judged by
    # whether their spec still hashes to their id
    con = sqlite3.connect(tmp_path / "store" / "catalogue.sqlite")
    con.execute("UPDATE sweeps SET engine_fingerprint = ''")
    con.commit()
    con.close()
    rows = {r["sweep_id"]: r for r in Catalogue(tmp_path / "store").list()}
    assert lookup.is_stale(rows[old_id]) and not lookup.is_stale(rows[new_id])


def test_old_catalogues_gain_the_fingerprint_column(tmp_path):
    con = sqlite3.connect(tmp_path / "catalogue.sqlite")
    con.execute(SCHEMA)             # the first schema, without engine_fingerprint
    con.close()
    cat = Catalogue(tmp_path)
    row = cat.register("abc", "n", "{}", 1, 1, tmp_path / "abc", engine_fingerprint=FP_A)
    assert row["engine_fingerprint"] == FP_A
    assert cat.register("def", "n", "{}", 1, 1, tmp_path / "def")["engine_fingerprint"] == ""
