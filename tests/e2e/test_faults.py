"""Faults a user can meet, through the real command line (issue 10): every one is survived
or ends in one clear line on stderr with the README's exit status, and nothing finished is
lost. The journal is the truth: a cube that disagrees with it is republished from it.

Disk-full and read-only cases mount a tmpfs / a read-only bind mount (root only); they
skip with the reason when this machine does not allow it, and fail instead in CI, which
runs as root (tests/guarantee.py)."""
import os
import shutil
import signal
import subprocess
from pathlib import Path

import numpy as np
import pytest
import xarray as xr

import store
from sweeps.run.new_cube import empty_cube
from sweeps.planning.plan import make_plan
from sweeps.run.submit import submit
from sweeps.spec import load_spec

from ..helpers import AVERAGED_SPEC, BIN, as_a_terminal_job, ditherlab, wait_for

from .test_cluster_and_resume import RESUME_SPEC

pytestmark = pytest.mark.subprocess   # what it starts (tests/conftest.py)

N_BLOCKS_AVG = 8   # AVERAGED_SPEC: 525 points in 8 blocks, computed in-process (no dask)


def _cube(root: Path, spec) -> Path:
    return root / spec.sweep_id / "cube.nc"


def _results(path) -> xr.Dataset:
    """The cube's variables and coordinates but the wall-clock cost."""
    with xr.open_dataset(path, engine="h5netcdf") as ds:
        return ds.drop_vars("cost_s").drop_attrs().load()


def _stderr_lines(proc) -> list[str]:
    return [line for line in proc.stderr.splitlines() if line.strip()]


def _ran(proc) -> int:
    out = proc.stdout
    return 0 if "already complete" in out else int(out.split("ran ")[1].split(" blocks")[0])


@pytest.fixture(scope="module")
def avg(tmp_path_factory):
    """The averaged spec, its parsed form, and a clean store that ran it once (tests copy
    it, never change it)."""
    folder = tmp_path_factory.mktemp("avg")
    path = folder / "spec.toml"
    path.write_text(AVERAGED_SPEC)
    clean = folder / "clean"
    ditherlab("submit", str(path), "--quiet", store=clean, check=True)
    return path, load_spec(path), clean


# --- 1, 2: the cube disagrees with the journal ------------------------------------------

@pytest.mark.long
def test_a_stale_cube_with_a_complete_journal_is_republished(avg, tmp_path):
    """The state a submitter killed after its last journal write and before its final
    publish leaves (measured: 'done, already complete; 256/256 ok' over 152 points of
    status 1): the next submit republishes the cube from the journal."""
    path, spec, clean = avg
    root = tmp_path / "killed"
    shutil.copytree(clean, root)
    sweep = store.SweepDir(root, spec.sweep_id)
    journal = store.Journal(sweep.journal)
    plan = make_plan(spec)
    store.publish(empty_cube(plan), sweep.cube)   # the last cube published: nothing in it
    assert journal.done(plan.blocks) == set(range(N_BLOCKS_AVG))
    proc = ditherlab("submit", str(path), "--quiet", store=root, check=True)
    assert "done, already complete; 525/525 ok" in proc.stdout
    assert "republished it from the journal" in proc.stderr
    xr.testing.assert_identical(_results(sweep.cube), _results(_cube(clean, spec)))
    again = ditherlab("submit", str(path), "--quiet", store=root, check=True)
    assert "republished" not in again.stderr       # now they agree: nothing written


@pytest.mark.long
@pytest.mark.parametrize("damage", ["truncate", "garbage", "delete"])
def test_a_damaged_cube_is_named_by_query_and_repaired_by_submit(avg, tmp_path, damage):
    path, spec, clean = avg
    root = tmp_path / "damaged"
    shutil.copytree(clean, root)
    cube = _cube(root, spec)
    if damage == "truncate":
        cube.write_bytes(cube.read_bytes()[:5000])
    elif damage == "garbage":
        cube.write_bytes(b"\x89HDF\r\n\x1a\n" + os.urandom(4000))
    else:
        cube.unlink()
    proc = ditherlab("query", "e2e-avg", store=root)
    assert proc.returncode == 1 and proc.stdout == ""
    (line,) = _stderr_lines(proc)
    if damage == "delete":
        assert "has no cube yet" in line and "submit it again" in line
    else:
        assert "is unreadable" in line and "submit the spec again (ditherlab submit " in line
        assert "to republish it from the journal" in line
        table = ditherlab("status", store=root, check=True).stdout   # not "1 accuracy warning"
        assert "the cube cannot be read" in table and "accuracy warning" not in table, table
    repaired = ditherlab("submit", str(path), "--quiet", store=root, check=True)
    assert "already complete" in repaired.stdout
    xr.testing.assert_identical(_results(cube), _results(_cube(clean, spec)))
    ditherlab("query", "e2e-avg", "--format", "csv", store=root, check=True)


# --- 3: disk full ----------------------------------------------------------------------

@pytest.mark.long
def test_disk_full_before_anything_is_one_line_not_a_segfault(avg, tmpfs):
    """Measured before: 'RuntimeError: Disable slist on flush dest failure failed ... No
    space left on device', then Segmentation fault (exit 139) on a 200 KB tmpfs."""
    path, spec, clean = avg
    disk = tmpfs("200k")
    proc = ditherlab("submit", str(path), "--quiet", store=disk / "store")
    assert proc.returncode == 1, proc.stderr
    (line,) = _stderr_lines(proc)   # --quiet: the one error line alone
    assert line.startswith(f"ditherlab: no space left on device writing {disk}/store/")
    assert "MB and submit again; the journal keeps the 0 finished blocks (of 8)" in line
    assert "Traceback" not in proc.stderr
    subprocess.run(["mount", "-o", "remount,size=4m", str(disk)], check=True)
    ditherlab("submit", str(path), "--quiet", store=disk / "store", check=True)
    xr.testing.assert_identical(_results(_cube(disk / "store", spec)),
                                _results(_cube(clean, spec)))


@pytest.mark.long
def test_disk_full_keeps_the_previous_cube_and_resumes_when_freed(avg, tmpfs):
    path, spec, clean = avg
    root = tmpfs("2m") / "store"
    first = submit(make_plan(spec), root, progress=False, max_blocks=3)
    assert first.blocks_run == 3
    cube = _cube(root, spec)
    before = cube.read_bytes()
    filler = root.parent / "filler"
    with open(filler, "wb") as f:                 # leave a few pages
        f.write(b"\0" * max(0, store.errors.free_bytes(root) - 48 * 1024))
    proc = ditherlab("submit", str(path), "--quiet", store=root)
    assert proc.returncode == 1
    (line,) = _stderr_lines(proc)
    assert "no space left on device writing" in line
    assert line.endswith("the journal keeps the 3 finished blocks (of 8)")
    assert cube.read_bytes() == before            # the previous cube, untouched
    assert not list(cube.parent.glob(".*.tmp-*"))
    filler.unlink()
    resumed = ditherlab("submit", str(path), "--quiet", store=root, check=True)
    assert _ran(resumed) == N_BLOCKS_AVG - 3
    xr.testing.assert_identical(_results(cube), _results(_cube(clean, spec)))


@pytest.mark.long
def test_disk_filling_up_mid_run_stops_with_one_line_and_resumes(tmp_path, spec_file, tmpfs,
                                                                  env, gate):
    """A 32-block simulated sweep; another process fills the disk after 3 blocks (the
    others held at the gate until the disk is full: certainly mid-run)."""
    path = spec_file(RESUME_SPEC)
    spec = load_spec(path)
    root = tmpfs("3m") / "store"
    proc = subprocess.Popen([str(BIN), "submit", str(path), "--quiet", "--store", str(root)],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env)
    journal = root / spec.sweep_id / "journal"
    gate.let(3)
    wait_for(lambda: len(store.Journal(journal).files()) >= 3 or proc.poll() is not None,
             "three journaled blocks", 300, poll=0.02)
    filler = root.parent / "filler"
    subprocess.run(["dd", "if=/dev/zero", f"of={filler}", "bs=4k"], capture_output=True)
    gate.open()
    out, err = proc.communicate(timeout=300)
    assert proc.returncode == 1, err
    assert "Traceback" not in err
    last = err.strip().splitlines()[-1]
    assert last.startswith("ditherlab: no space left on device writing ") and \
        "the journal keeps the " in last
    kept = len(store.Journal(journal).files())
    store.open_cube(_cube(root, spec))            # readable
    filler.unlink()
    assert kept == 3 and last.endswith("the journal keeps the 3 finished blocks (of 32)"), last
    resumed = ditherlab("submit", str(path), "--quiet", store=root, check=True)
    assert _ran(resumed) == 32 - kept


# --- 4: bad journal blocks -------------------------------------------------------------

def test_bad_journal_blocks_are_set_aside_and_recomputed(avg, tmp_path):
    """Measured before: BadZipFile, or ValueError, on every later submit; wrong numbers
    in a well-formed block read as data."""
    path, spec, clean = avg
    root = tmp_path / "bad"
    shutil.copytree(clean, root)
    journal = store.Journal(root / spec.sweep_id / "journal")

    files = journal.files()   # (a run in this process journals each block in its own file)
    assert len({files[b] for b in (1, 2, 3, 4)}) == 4

    def rewrite(block_id, change):   # as another program would: plain np.savez
        with np.load(files[block_id]) as npz:
            arrays = {k: npz[k] for k in npz.files if k != "_sha256"}
        change(arrays)
        with open(files[block_id], "wb") as f:
            np.savez(f, **arrays)

    data = bytearray(files[1].read_bytes())
    data[len(data) // 3: len(data) // 3 + 64] = b"\xff" * 64
    files[1].write_bytes(bytes(data))                                          # flipped bytes
    rewrite(2, lambda a: a.__setitem__("status", np.full_like(a["status"], 7)))  # bad codes
    rewrite(3, lambda a: a.__setitem__("F_eff", a["F_eff"] * 0 + 1e9))         # wrong numbers
    rewrite(4, lambda a: a.__setitem__("index", a["index"][:5]))               # wrong shape
    proc = ditherlab("submit", str(path), "--quiet", store=root, check=True)
    assert _ran(proc) == 4
    warned = [line for line in _stderr_lines(proc) if "journal: block" in line]
    assert len(warned) == 4 and all(line.startswith("ditherlab: warning: journal: block ")
                                    and "recomputed" in line for line in warned)
    assert len(list((journal.folder / "bad").iterdir())) == 4
    xr.testing.assert_identical(_results(_cube(root, spec)), _results(_cube(clean, spec)))
    assert "journal" not in ditherlab("submit", str(path), "--quiet", store=root).stderr


# --- 5: store paths, read-only stores, a damaged catalogue, Ctrl-C ----------------------

@pytest.mark.long
def test_read_commands_work_on_a_read_only_store_and_submit_says_why_not(avg, tmp_path,
                                                                          read_only):
    """Measured before: sqlite3.OperationalError for status and query on a read-only mount."""
    path, spec, clean = avg
    ro = read_only(clean)
    before = sorted(p.name for p in clean.iterdir())
    listing = ditherlab("status", store=ro, check=True)
    assert spec.sweep_id in listing.stdout and "done" in listing.stdout
    ditherlab("status", "e2e-avg", store=ro, check=True)
    table = ditherlab("query", "e2e-avg", "--var", "F_eff", "--format", "csv", store=ro,
                      check=True)
    assert len(table.stdout.splitlines()) == 1 + 525
    ditherlab("map", "e2e-avg", "--kind", "friction", "--sel", "v_d=0.1", "-o",
              str(tmp_path / "f.png"), store=ro, check=True)
    proc = ditherlab("submit", str(path), "--quiet", store=ro)
    assert proc.returncode == 1
    assert _stderr_lines(proc) == [   # --quiet: the one error line alone
        f"ditherlab: store {ro} is read-only (Read-only file system): cannot write there; "
        "status, query and map still read it"]
    assert sorted(p.name for p in clean.iterdir()) == before


@pytest.mark.parametrize("case", ["a file", "under a file", "name too long"])
def test_an_unusable_store_path_is_one_line_and_exit_2(tmp_path, spec_file, case):
    target = {"a file": tmp_path / "file", "under a file": tmp_path / "file" / "store",
              "name too long": tmp_path / ("x" * 300)}[case]
    (tmp_path / "file").write_text("not a store")
    for args in (("status",), ("query", "x"), ("submit", str(spec_file(AVERAGED_SPEC)),
                                                 "--quiet")):
        proc = ditherlab(*args, store=target)
        assert proc.returncode == 2, (args, proc.stderr)
        lines = [line for line in _stderr_lines(proc) if line.startswith("ditherlab:")]
        assert len(lines) == 1 and "store path" in lines[0] and "Traceback" not in proc.stderr
        assert len(lines[0]) < 300


@pytest.mark.long
def test_a_damaged_catalogue_is_one_line_saying_how_to_rebuild_it(avg, tmp_path):
    path, spec, clean = avg
    root = tmp_path / "damaged"
    shutil.copytree(clean, root)
    catalogue = root / "catalogue.sqlite"
    for extra in root.glob("catalogue.sqlite-*"):
        extra.unlink()
    catalogue.write_bytes(os.urandom(8192))
    for args in (("status",), ("query", "e2e-avg"), ("submit", str(path), "--quiet")):
        proc = ditherlab(*args, store=root)
        assert proc.returncode == 1
        assert _stderr_lines(proc)[-1] == (
            f"ditherlab: the catalogue {catalogue} is damaged (file is not a database); "
            f"move it aside (mv {catalogue} {catalogue}.damaged) and run the command again: "
            "it is rebuilt from the cubes (queued sweeps must be submitted again)")
    catalogue.rename(catalogue.with_name("catalogue.sqlite.damaged"))
    assert spec.sweep_id in ditherlab("status", store=root, check=True).stdout


@pytest.mark.long
@pytest.mark.parametrize("sig, group, status, said", [
    (signal.SIGINT, True, 130, "interrupted"),
    (signal.SIGTERM, False, 143, "terminated (SIGTERM)"),
    (signal.SIGTERM, True, 143, "terminated (SIGTERM)"),
], ids=["ctrl-c", "kill", "scancel"])
def test_ctrl_c_says_what_was_kept_and_resume_computes_the_rest(tmp_path, spec_file, env,
                                                                gate, sig, group, status, said):
    """SIGINT to the whole process group, as a terminal's Ctrl-C: exit 130, one line, no
    tracebacks from the dask workers; the next submit computes only the missing blocks.
    Two blocks are let through the gate and the rest held until the submitter has exited:
    the Ctrl-C certainly comes mid-run, and it does not wait for the blocks still to run.
    SIGTERM to the submitter (``kill``) the same way, exit 143; and to the whole group at
    once (Slurm's ``scancel``: the workers are signalled with the submitter)."""
    path = spec_file(RESUME_SPEC)
    spec = load_spec(path)
    root = tmp_path / "store"
    journal = root / spec.sweep_id / "journal"
    proc = subprocess.Popen([str(BIN), "submit", str(path), "--quiet", "--store", str(root)],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env,
                            start_new_session=True, preexec_fn=as_a_terminal_job)
    gate.let(2)
    wait_for(lambda: len(store.Journal(journal).files()) >= 2 or proc.poll() is not None,
             "two journaled blocks", 300, poll=0.02)
    if group:   # Ctrl-C in a terminal; scancel, which signals every process of the job
        os.killpg(proc.pid, sig)
    else:
        os.kill(proc.pid, sig)
    try:
        out, err = proc.communicate(timeout=300)
    finally:
        gate.open()
    assert proc.returncode == status, err
    assert "Traceback" not in err and "KeyboardInterrupt" not in err, err
    last = err.strip().splitlines()[-1]
    kept = len(store.Journal(journal).files())
    assert last == (f"ditherlab: {said}; the journal keeps the {kept} finished blocks "
                    "(of 32); submit the spec again to resume")
    store.open_cube(root / spec.sweep_id / "cube.nc")
    assert kept == 2
    assert ditherlab("status", spec.sweep_id, store=root).stdout.count("cancelled") >= 1
    resumed = ditherlab("submit", str(path), "--quiet", store=root, check=True)
    assert _ran(resumed) == 32 - kept
