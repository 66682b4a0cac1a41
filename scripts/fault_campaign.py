#!/usr/bin/env python3
"""Fault campaign (issue 10): kill -9 the submitter -- and ``ditherlab serve``, and single dask
workers -- at random instants and at instants chosen by journal count, resume, and check that
nothing was lost.

Each trial uses a fresh store:

1. start ``ditherlab submit SPEC`` (or ``submit --detach`` + ``ditherlab serve``) in its own
   process group, and kill the whole group (the process and its dask workers) with SIGKILL
   after a random delay, once the journal holds k blocks, or once it holds every block
   (``after-last``: the window before the final publish, where the error estimate and the
   cluster shutdown run);
2. meanwhile a reader thread opens the published cube again and again: every read at every
   observed instant must succeed;
3. resume (``submit`` again, or ``submit --detach`` + a new ``serve`` until the sweep is done)
   and count the blocks the resume computed -- from ``$DITHERLAB_BLOCK_LOG`` (every
   ``compute_block`` call appends its key) when this ditherlab has it, else from the
   submit's "ran N blocks": it must equal the blocks missing from the journal;
4. the final cube must equal a clean run's in every variable but the wall-clock ``cost_s``.

A worker trial kills one dask worker of a running submitter: the submitter must finish by
itself (exit 0; the ``at`` column adds the blocks computed twice) with an identical cube.

Prints a table of trials and the counts; exit status 0 when every trial survived and every
final cube is identical. Standard library and the project only.

    .venv/bin/python scripts/fault_campaign.py       # 20 submit, 6 serve, 4 worker kills
    .venv/bin/python scripts/fault_campaign.py --trials 4 --serve-trials 0 --worker-trials 1
"""
from __future__ import annotations

import argparse
import json
import os
import random
import shutil
import signal
import subprocess
import sys
import tempfile
import threading
import time
from dataclasses import asdict, dataclass, field
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

import store  # noqa: E402
from sweeps.workers import task as sweeps_task  # noqa: E402
from sweeps.planning.plan import make_plan  # noqa: E402
from sweeps.spec import load_spec  # noqa: E402

BIN = Path(sys.executable).parent / "ditherlab"
BLOCK_LOG_ENV = getattr(sweeps_task, "BLOCK_LOG_ENV", None)

# 16 one-point blocks of ~0.5 s each: a whole run takes ~25 s here, so kills land in every
# phase (cluster start, warm-up, blocks, error estimate, final publish)
SPEC = """
name = "fault-campaign"
friction = "lugre"
dither = "square-velocity"
method = "simulate"
outputs = ["v_mean", "v_slow_p2p", "F_mean", "stick_fraction", "max_stick"]
accuracy = "standard"
block_size = 1
[time]
t_end = 150.0
t_transient = 4.0
[grid]
W = [0.0, 0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7]
omega = [300.0, 1000.0]
v_ref = [0.4]
v_d = [0.1]
"""


@dataclass
class Trial:
    n: int
    target: str                 # "submit" or "serve"
    mode: str                   # "random", "journal" or "after-last"
    at: str                     # "3.2 s" or "k=5"
    killed: bool = False        # False: the run finished before the kill instant
    journaled: int = 0          # blocks in the journal after the kill
    cube_behind: bool = False   # the published cube lacked journaled blocks (the window)
    reads: int = 0              # reads of the published cube while it ran and after
    bad_reads: int = 0
    resumed: int = -1           # blocks the resume computed
    expected: int = -1          # blocks missing from the journal
    identical: bool = False     # final cube == clean cube but cost_s
    seconds: float = 0.0
    kill_s: float = 0.0         # seconds from start to the kill (or to the end)
    notes: list = field(default_factory=list)

    @property
    def survived(self) -> bool:
        return self.bad_reads == 0 and self.resumed == self.expected and not self.notes


class Reader(threading.Thread):
    """Opens the published cube again and again; counts reads and failures."""

    def __init__(self, cube: Path):
        super().__init__(daemon=True)
        self.cube, self.reads, self.bad, self.errors = cube, 0, 0, []
        self.halt = threading.Event()

    def run(self) -> None:
        while not self.halt.is_set():
            self.read_once()
            self.halt.wait(0.01)

    def read_once(self) -> None:
        if not self.cube.exists():
            return
        try:
            ds = store.open_cube(self.cube)
            ds["status"].values.sum()
            self.reads += 1
        except FileNotFoundError:
            pass
        except Exception as err:  # noqa: BLE001 -- any failure to read is what we count
            self.bad += 1
            self.errors.append(f"{type(err).__name__}: {err}"[:200])

    def stop(self) -> None:
        self.halt.set()
        self.join()
        self.read_once()   # and once after the kill


def _journal_count(journal: Path) -> int:
    return len(list(journal.glob("block-*.npz"))) if journal.is_dir() else 0


def _start(args: list[str], env: dict, log: Path) -> subprocess.Popen:
    with open(log, "ab") as out:
        return subprocess.Popen([str(BIN), *args], stdout=out, stderr=subprocess.STDOUT,
                                env=env, start_new_session=True)


def _kill_when(proc: subprocess.Popen, journal: Path, mode: str, param: float,
               timeout: float = 600) -> tuple[bool, float]:
    """SIGKILL ``proc``'s process group at the chosen instant (``param`` seconds, or
    blocks in the journal); ``(False, s)`` if it ended first, after ``s`` seconds."""
    t0 = time.monotonic()
    while proc.poll() is None and time.monotonic() - t0 < timeout:
        if (mode == "random" and time.monotonic() - t0 >= param) or \
                (mode != "random" and _journal_count(journal) >= param):
            break
        time.sleep(0.005)
    elapsed = time.monotonic() - t0
    if proc.poll() is not None:
        return False, elapsed
    os.killpg(proc.pid, signal.SIGKILL)
    proc.wait()
    return True, elapsed


def _workers_of(pid: int) -> list[int]:
    """The dask worker processes a submitter spawned (children running ``spawn_main``)."""
    found = []
    for proc in Path("/proc").iterdir():
        if not proc.name.isdigit():
            continue
        try:
            ppid = int((proc / "stat").read_text().rpartition(")")[2].split()[1])
            cmdline = (proc / "cmdline").read_bytes()
        except (OSError, IndexError, ValueError):
            continue
        if ppid == pid and b"spawn_main" in cmdline:
            found.append(int(proc.name))
    return found


def _kill_a_worker(proc: subprocess.Popen, journal: Path, k: int, rng: random.Random,
                   timeout: float = 600) -> bool:
    """SIGKILL one dask worker of ``proc`` once the journal holds ``k`` blocks."""
    t0 = time.monotonic()
    while proc.poll() is None and time.monotonic() - t0 < timeout:
        workers = _workers_of(proc.pid)
        if workers and _journal_count(journal) >= k:
            os.kill(rng.choice(workers), signal.SIGKILL)
            return True
        time.sleep(0.005)
    return False


def _cube_ok_blocks(cube: Path, plan) -> int:
    try:
        status = store.open_cube(cube)["status"].values.reshape(-1)
    except (FileNotFoundError, ValueError):
        return 0
    return sum(bool((status[idx] == 0).all()) for idx in plan.blocks)


def _blocks_logged(log: Path, keys: set[str]) -> int:
    if not log.exists():
        return 0
    return sum(1 for line in log.read_text().splitlines() if line.split()[-1] in keys)


def _results(cube: Path):
    ds = store.open_cube(cube)
    return ds.drop_vars("cost_s").drop_attrs()


def _identical(a: Path, b: Path) -> bool:
    x, y = _results(a), _results(b)
    return x.identical(y)


def _serve_until_done(root: Path, sweep_id: str, env: dict, log: Path,
                      timeout: float = 900) -> None:
    proc = _start(["serve", "--store", str(root)], env, log)
    catalogue = store.Catalogue(root)
    t0 = time.monotonic()
    try:
        while time.monotonic() - t0 < timeout:
            state = catalogue.get(sweep_id)["state"]
            if state in ("done", "partial", "failed", "cancelled") or proc.poll() is not None:
                break
            time.sleep(0.2)
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGTERM)
            try:
                proc.wait(timeout=120)
            except subprocess.TimeoutExpired:
                os.killpg(proc.pid, signal.SIGKILL)
                proc.wait()


def run_trial(n: int, target: str, mode: str, param: float, spec_path: Path, plan,
              keys: set[str], clean_cube: Path, work: Path) -> Trial:
    at = f"{param:.1f} s" if mode == "random" else f"k={int(param)}"
    trial = Trial(n, target, mode, at)
    t0 = time.monotonic()
    root = work / f"trial-{n:02d}"
    sweep = store.SweepDir(root, plan.sweep_id)
    env = {**os.environ, "MPLBACKEND": "Agg"}
    log = work / f"trial-{n:02d}.log"
    reader = Reader(sweep.cube)
    reader.start()
    if target == "worker":   # a worker dies; the submitter must finish by itself
        return _worker_trial(trial, param, spec_path, plan, keys, clean_cube, root, env, log,
                             reader, t0)
    if target == "submit":
        proc = _start(["submit", str(spec_path), "--quiet", "--store", str(root)], env, log)
    else:
        subprocess.run([str(BIN), "submit", str(spec_path), "--detach", "--store", str(root)],
                       env=env, capture_output=True, check=True)
        proc = _start(["serve", "--store", str(root)], env, log)
    trial.killed, trial.kill_s = _kill_when(proc, sweep.journal, mode, param)
    reader.stop()
    readers = [reader]
    trial.journaled = _journal_count(sweep.journal)
    trial.cube_behind = _cube_ok_blocks(sweep.cube, plan) < trial.journaled
    trial.expected = len(plan.blocks) - trial.journaled

    reader = Reader(sweep.cube)   # a reader during the resume too
    reader.start()
    blocks_log = work / f"trial-{n:02d}.blocks"
    env_resume = {**env, BLOCK_LOG_ENV: str(blocks_log)} if BLOCK_LOG_ENV else env
    if target == "submit":
        done = subprocess.run([str(BIN), "submit", str(spec_path), "--quiet", "--store",
                               str(root)], env=env_resume, capture_output=True, text=True)
        if done.returncode != 0:
            trial.notes.append(f"resume exit {done.returncode}: {done.stderr.strip()[-200:]}")
        ran = (0 if "already complete" in done.stdout else
               int(done.stdout.split("ran ")[1].split(" blocks")[0])
               if "ran " in done.stdout else -1)
    else:
        subprocess.run([str(BIN), "submit", str(spec_path), "--detach", "--store", str(root)],
                       env=env, capture_output=True, check=True)
        _serve_until_done(root, plan.sweep_id, env_resume, log)
        ran = -1
    reader.stop()
    readers.append(reader)
    trial.resumed = _blocks_logged(blocks_log, keys) if BLOCK_LOG_ENV else ran
    if target == "submit" and BLOCK_LOG_ENV and ran != trial.resumed:
        trial.notes.append(f"submit said it ran {ran}, the block log has {trial.resumed}")
    trial.reads = sum(r.reads for r in readers)
    trial.bad_reads = sum(r.bad for r in readers)
    errors = [e for r in readers for e in r.errors]
    if errors:
        trial.notes.append(errors[0])
    try:
        trial.identical = _identical(sweep.cube, clean_cube)
    except (FileNotFoundError, ValueError) as err:
        trial.notes.append(f"final cube: {err}"[:200])
    if not trial.identical:
        trial.notes.append("final cube differs from the clean run")
    trial.seconds = time.monotonic() - t0
    return trial


def _worker_trial(trial: Trial, k: float, spec_path: Path, plan, keys: set[str],
                  clean_cube: Path, root: Path, env: dict, log: Path, reader: Reader,
                  t0: float) -> Trial:
    blocks_log = log.with_suffix(".blocks")
    env = {**env, BLOCK_LOG_ENV: str(blocks_log)} if BLOCK_LOG_ENV else env
    proc = _start(["submit", str(spec_path), "--quiet", "--store", str(root)], env, log)
    sweep = store.SweepDir(root, plan.sweep_id)
    trial.killed = _kill_a_worker(proc, sweep.journal, int(k), random.Random(trial.n))
    code = proc.wait(timeout=900)
    reader.stop()
    trial.reads, trial.bad_reads = reader.reads, reader.bad
    trial.notes += reader.errors[:1]
    if code != 0:
        trial.notes.append(f"the submitter exited {code} after its worker was killed")
    trial.journaled = _journal_count(sweep.journal)
    trial.expected = trial.resumed = 0   # nothing to resume: the run completes by itself
    if BLOCK_LOG_ENV:   # blocks computed twice: those in flight on the killed worker
        trial.at += f" +{_blocks_logged(blocks_log, keys) - len(plan.blocks)}"
    trial.identical = code == 0 and _identical(sweep.cube, clean_cube)
    if code == 0 and not trial.identical:
        trial.notes.append("final cube differs from the clean run")
    trial.seconds = time.monotonic() - t0
    return trial


def schedule(n_submit: int, n_serve: int, n_worker: int, n_blocks: int,
             rng: random.Random) -> list[tuple[str, str, float]]:
    """Kill instants of the submitter and serve: a third after the last block, a third at a
    random journal count, a third at a random time (a fraction of a whole run's duration,
    which ``campaign`` measures as it goes); of a worker: at a random journal count."""
    plan = []
    for target, count in (("submit", n_submit), ("serve", n_serve)):
        for i in range(count):
            kind = ("after-last", "journal", "random")[i % 3]
            param = {"after-last": n_blocks,
                     "journal": rng.randint(1, n_blocks - 1),
                     "random": rng.uniform(0.05, 0.95)}[kind]
            plan.append((target, kind, param))
    plan += [("worker", "journal", rng.randint(1, n_blocks // 2)) for _ in range(n_worker)]
    return plan


def campaign(spec_text: str, work: Path, n_submit: int, n_serve: int, seed: int = 0,
             say=print, n_worker: int = 0) -> list[Trial]:
    """Run the clean reference and the trials; returns the trials."""
    work.mkdir(parents=True, exist_ok=True)
    spec_path = work / "spec.toml"
    spec_path.write_text(spec_text)
    plan = make_plan(load_spec(spec_path))
    keys = {sweeps_task.block_key(plan.scene, plan.block_points(b), plan.numerics.settings)
            for b in range(len(plan.blocks))} if BLOCK_LOG_ENV else set()
    t0 = time.monotonic()
    clean = work / "clean"
    subprocess.run([str(BIN), "submit", str(spec_path), "--quiet", "--store", str(clean)],
                   check=True, capture_output=True)
    clean_s = time.monotonic() - t0
    say(f"clean run: {len(plan.blocks)} blocks in {clean_s:.1f} s; block counts from "
        f"{'$' + BLOCK_LOG_ENV if BLOCK_LOG_ENV else 'the submit output'}")
    say(HEADER)
    rng = random.Random(seed)
    run_s = [clean_s]   # how long a whole run takes (clean run, then each after-last kill)
    trials = []
    for n, (target, mode, param) in enumerate(
            schedule(n_submit, n_serve, n_worker, len(plan.blocks), rng)):
        if mode == "random":   # the machine's load changes: the fastest of the latest runs
            param *= min(run_s[-3:])
        trial = run_trial(n, target, mode, param, spec_path, plan, keys,
                          store.SweepDir(clean, plan.sweep_id).cube, work)
        if mode == "after-last" and trial.killed:
            run_s.append(trial.kill_s)
        say(row(trial))
        trials.append(trial)
    return trials


HEADER = (f"{'#':>3} {'target':<7}{'kill':<11}{'at':>8}{'killed':>7}{'journal':>8}"
          f"{'behind':>7}{'reads':>7}{'bad':>5}{'resumed':>8}{'missing':>8}{'same':>6}"
          f"{'s':>6}  notes")


def row(t: Trial) -> str:
    return (f"{t.n:>3} {t.target:<7}{t.mode:<11}{t.at:>8}{'yes' if t.killed else 'no':>7}"
            f"{t.journaled:>8}{'yes' if t.cube_behind else '':>7}{t.reads:>7}{t.bad_reads:>5}"
            f"{t.resumed:>8}{t.expected:>8}{'yes' if t.identical else 'NO':>6}"
            f"{t.seconds:>6.0f}  {'; '.join(t.notes)}")


def summary(trials: list[Trial]) -> str:
    killed = sum(t.killed for t in trials)
    behind = sum(t.cube_behind for t in trials)
    kinds = ", ".join(f"{k} {sum(t.target == k for t in trials)}"
                      for k in ("submit", "serve", "worker"))
    return (f"trials {len(trials)} ({kinds}); killed mid-run {killed}; killed "
            f"with the cube behind the journal {behind}; survived "
            f"{sum(t.survived for t in trials)}; identical {sum(t.identical for t in trials)}; "
            f"cube reads {sum(t.reads for t in trials)}, failed "
            f"{sum(t.bad_reads for t in trials)}")


def has_serve() -> bool:
    proc = subprocess.run([str(BIN), "serve", "--help"], capture_output=True)
    return proc.returncode == 0


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--trials", type=int, default=20, help="kills of `ditherlab submit`")
    ap.add_argument("--serve-trials", type=int, default=6, help="kills of `ditherlab serve`")
    ap.add_argument("--worker-trials", type=int, default=4,
                    help="kills of one dask worker of a running submitter")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--work", type=Path, help="folder for the stores (default: a temporary "
                    "one, removed afterwards)")
    ap.add_argument("--json", type=Path, help="also write the trials to this JSON file")
    args = ap.parse_args(argv)
    n_serve = args.serve_trials
    if n_serve and not has_serve():
        print("this ditherlab has no `serve` command: serve trials skipped", flush=True)
        n_serve = 0
    work = args.work or Path(tempfile.mkdtemp(prefix="ditherlab-faults-"))
    try:
        trials = campaign(SPEC, work, args.trials, n_serve, args.seed,
                          say=lambda text: print(text, flush=True), n_worker=args.worker_trials)
    finally:
        if args.work is None:
            shutil.rmtree(work, ignore_errors=True)
    print(summary(trials))
    if args.json:
        args.json.write_text(json.dumps([{**asdict(t), "survived": t.survived}
                                         for t in trials], indent=1))
    return 0 if all(t.survived and t.identical for t in trials) else 1


if __name__ == "__main__":
    sys.exit(main())
