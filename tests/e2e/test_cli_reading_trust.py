"""The read side never hands back a wrong number silently (a fresh-clone hunt, 2026-11-25):
JSON keeps every digit and says inf, a cube copied from another sweep is refused, a spec
submitted under a second name keeps the first, a W curve off the grid is refused and a
picked refined curve says it holds inferred points, and argparse refusals are one line."""
import json
import shutil

import pytest

import store
from sweeps.lookup import resolve_sweep

from ..helpers import AVERAGED_SPEC, ditherlab

pytestmark = pytest.mark.subprocess   # what it starts (tests/conftest.py)

TINY = AVERAGED_SPEC.replace('name = "e2e-avg"', 'name = "tiny"').replace(
    'W = { start = 0.0, stop = 1.0, num = 21 }', "W = [0.0, 1e-11, 3e-11]").replace(
    'v_ref = { start = 0.02, stop = 1.0, num = 25 }', "v_ref = [0.5]")


@pytest.fixture(scope="module")
def shelf(tmp_path_factory):
    """A store with the tiny spec and the e2e spec, each submitted once."""
    root = tmp_path_factory.mktemp("trust")
    for name, text in (("tiny", TINY), ("avg", AVERAGED_SPEC)):
        (root / f"{name}.toml").write_text(text)
        ditherlab("submit", str(root / f"{name}.toml"), "-q", store=root / "store", check=True)
    return root


@pytest.mark.long
def test_json_keeps_full_precision_and_says_inf(shelf):
    """pandas' to_json rounded W = 1e-11 to 0.0 and wrote omega = inf as null."""
    rows = json.loads(ditherlab("query", "tiny", "--format", "json", store=shelf / "store",
                                check=True).stdout)
    ds = store.open_cube(resolve_sweep(shelf / "store", "tiny")[1])
    assert [r["W"] for r in rows] == ds["W"].values.tolist() == [0.0, 1e-11, 3e-11]
    assert {r["omega"] for r in rows} == {"inf"}
    assert [r["F_eff"] for r in rows] == ds["F_eff"].values.ravel().tolist()   # bit for bit


def _sweep_id(shelf, name) -> str:
    return resolve_sweep(shelf / "store", name)[0]


def test_a_cube_copied_from_another_sweep_is_refused(shelf, tmp_path):
    root = tmp_path / "store"
    shutil.copytree(shelf / "store", root)
    tiny, avg = _sweep_id(shelf, "tiny"), _sweep_id(shelf, "e2e-avg")
    shutil.copy(root / avg / "cube.nc", root / tiny / "cube.nc")
    proc = ditherlab("query", "tiny", store=root)
    assert proc.returncode == 1 and proc.stdout == ""
    assert proc.stderr.strip().splitlines() == [
        f"ditherlab: the cube at {root / tiny / 'cube.nc'} is sweep {avg}'s, not {tiny}'s; "
        f"submit the spec again (ditherlab submit {root / tiny / 'spec.json'} --store {root}) "
        "to republish it from the journal"]
    status = ditherlab("status", "tiny", store=root)   # its row, then the same refusal
    assert status.returncode == 1 and status.stderr == proc.stderr
    ditherlab("submit", str(root / tiny / "spec.json"), "-q", store=root, check=True)
    assert "inf" in ditherlab("query", "tiny", store=root, check=True).stdout


def test_a_sweep_folder_under_another_name_says_how_to_put_it_back(shelf, tmp_path):
    root = tmp_path / "store"
    shutil.copytree(shelf / "store", root)
    tiny = _sweep_id(shelf, "tiny")
    (root / tiny).rename(root / "archive")
    proc = ditherlab("query", "archive", store=root)
    assert proc.returncode == 1
    assert proc.stderr == (f"ditherlab: the folder {root / 'archive'} holds sweep {tiny} under "
                           f"another name; `mv {root / 'archive'} {root / tiny}` puts it back\n")


@pytest.mark.long
def test_the_same_spec_under_a_second_name_keeps_the_first(shelf, tmp_path):
    root = tmp_path / "store"
    shutil.copytree(shelf / "store", root)
    spec = tmp_path / "bob.toml"
    spec.write_text(TINY.replace('name = "tiny"', 'name = "bob"'))
    proc = ditherlab("submit", str(spec), "-q", store=root, check=True)
    sid = _sweep_id(shelf, "tiny")
    assert proc.stderr.strip().splitlines() == [
        f"ditherlab: warning: sweep {sid} is named 'bob' now, 'tiny' before (the same spec "
        "under another name); both names find it"]   # not "republished it from the journal"
    for name in ("tiny", "bob"):
        assert ditherlab("query", name, "--format", "csv", store=root, check=True).stdout == \
            ditherlab("query", sid, "--format", "csv", store=root, check=True).stdout
    shown = ditherlab("status", "tiny", store=root, check=True).stdout
    assert "name: bob" in shown and "also_named: tiny" in shown
    assert f"path: {root / sid}" in shown   # the copied store's folder, not the original's
    # an earlier name does not stand in the way of a sweep that has it now
    (tmp_path / "new.toml").write_text(TINY.replace("v_ref = [0.5]", "v_ref = [0.6]"))
    ditherlab("submit", str(tmp_path / "new.toml"), "-q", store=root, check=True)
    now = ditherlab("query", "tiny", "--format", "csv", store=root, check=True).stdout
    assert ",0.6," in now and ",0.5," not in now
    assert ",0.5," in ditherlab("query", "bob", "--format", "csv", store=root, check=True).stdout


@pytest.mark.long
def test_a_w_curve_off_the_grid_is_refused_and_inferred_picks_warn(tmp_path):
    spec = tmp_path / "ref.toml"
    spec.write_text(AVERAGED_SPEC.replace('name = "e2e-avg"', 'name = "ref"\nrefine = true'))
    root = tmp_path / "store"
    ditherlab("submit", str(spec), "-q", store=root, check=True)
    off = ditherlab("map", "ref", "--kind", "friction", "--sel", "W=99", "-o",
                    str(tmp_path / "f.png"), store=root)
    assert off.returncode == 2 and "sel['W'] = 99 is off the grid" in off.stderr
    ds = store.open_cube(next(root.glob("*/cube.nc")))
    inferred = (ds["provenance"].sel(W=0.5).values == 1).sum()
    assert inferred > 0
    for how in (["--sel", "W=0.5"], ["--pick", "3"]):
        proc = ditherlab("map", "ref", "--kind", "friction", *how, "-o",
                         str(tmp_path / "f.png"), store=root, check=True)
        assert "points are inferred" in proc.stderr, how
    proc = ditherlab("map", "ref", "--kind", "friction", "--sel", "W=0.5", "-o",
                     str(tmp_path / "f.png"), store=root, check=True)
    assert f"{inferred} of {ds.sizes['v_ref']} points are inferred" in proc.stderr


@pytest.mark.parametrize("argv", [("query", "x", "--format", "xml"), ("map", "x", "-o", "x.png"),
                                  ("query",), ("nosuch",)])
def test_argument_refusals_are_one_line(argv, tmp_path):
    proc = ditherlab(*argv, store=tmp_path / "store")
    assert proc.returncode == 2
    assert proc.stderr.count("\n") == 1 and proc.stderr.startswith("ditherlab") and \
        "usage:" not in proc.stderr, proc.stderr


@pytest.mark.long
def test_cancel_finds_a_sweep_as_query_does(shelf, tmp_path):
    """Two current sweeps of one name: query and cancel refuse alike (exit 2, the ids
    listed); cancel of the name once it is unique says the sweep is done."""
    root = tmp_path / "store"
    shutil.copytree(shelf / "store", root)
    other = tmp_path / "dup.toml"
    other.write_text(TINY.replace("v_ref = [0.5]", "v_ref = [0.6]"))
    ditherlab("submit", str(other), "-q", store=root, check=True)
    for argv in (("query", "tiny"), ("cancel", "tiny")):
        proc = ditherlab(*argv, store=root)
        assert proc.returncode == 2, (argv, proc.stderr)
        assert "'tiny' names 2 sweeps" in proc.stderr and "pass the sweep id" in proc.stderr
    proc = ditherlab("cancel", "e2e-avg", store=root, check=True)
    assert proc.stdout.strip() == f"{_sweep_id(shelf, 'e2e-avg')}: done; nothing to cancel"


def test_plan_record_into_a_file_is_refused_like_every_command(tmp_path):
    (tmp_path / "afile").write_text("")
    spec = tmp_path / "tiny.toml"
    spec.write_text(TINY)
    proc = ditherlab("plan", str(spec), "--record", store=tmp_path / "afile")
    assert proc.returncode == 2 and proc.stdout == ""   # was a warning, exit 0
    assert proc.stderr == (f"ditherlab: store path {tmp_path / 'afile'} is not a folder; pass "
                           "--store DIR (or set $DITHERLAB_STORE) naming a folder\n")


@pytest.mark.long
@pytest.mark.parametrize("kind, sel, axis", [("stick-slip", "W=0.5", "W"),
                                             ("stability", "v_ref=0.5", "v_ref"),
                                             ("stability", "W=0.5", "W")])
def test_a_map_refuses_to_fix_its_own_axis_unless_it_has_one_value(shelf, tmp_path, kind, sel,
                                                                   axis):
    proc = ditherlab("map", "e2e-avg", "--kind", kind, "--sel", sel, "-o",
                     str(tmp_path / "m.png"), store=shelf / "store")
    assert proc.returncode == 2 and proc.stderr.startswith(
        f"ditherlab: --sel {axis}: {axis} is an axis of the {kind} map"), proc.stderr
    ditherlab("map", "tiny", "--kind", "stability", "--sel", "v_ref=0.5", "--sel", "v_d=0.1",
              "--sel", "v_d=0.1", "-o", str(tmp_path / "m.png"), store=shelf / "store",
              check=True)   # tiny has one v_ref; a value repeated is not a second value
