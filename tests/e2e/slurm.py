"""A single-node Slurm in a temporary folder, for tests (../shared/recipes/batch-system.md).

No file under /etc: ``SLURM_CONF`` names a ``slurm.conf`` in the folder, with state,
spool, pid and log files beside it; no munge (``auth/none``); free ports picked at start,
so another Slurm on the machine does not clash. Needs root and the Debian packages
``slurmctld slurmd slurm-client`` (``.ci/run`` installs them). :func:`stop` ends both
daemons by their pid files, also when the test failed.
"""
from __future__ import annotations

import os
import shutil
import signal
import socket
import subprocess
import time
from pathlib import Path

DAEMONS = ("slurmctld", "slurmd")


def missing() -> str | None:
    """Why a Slurm cannot be started here, or None."""
    absent = [c for c in (*DAEMONS, "sbatch", "sinfo", "scancel") if not shutil.which(c)]
    if absent:
        return (f"{', '.join(absent)} not found: apt-get install --no-install-recommends "
                "slurmctld slurmd slurm-client munge")
    if os.geteuid() != 0:
        return "a test Slurm runs its daemons as root"
    return None


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def write_conf(folder: Path) -> Path:
    host = socket.gethostname().split(".")[0]
    for sub in ("state", "spool", "log"):
        (folder / sub).mkdir(parents=True, exist_ok=True)
    conf = folder / "slurm.conf"
    conf.write_text(f"""ClusterName=ditherlab-test
SlurmctldHost={host}(127.0.0.1)
SlurmctldPort={_free_port()}
SlurmdPort={_free_port()}
SlurmUser=root
SlurmdUser=root
AuthType=auth/none
CredType=cred/none
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
SwitchType=switch/none
MpiDefault=none
SelectType=select/cons_tres
SelectTypeParameters=CR_CPU
AccountingStorageType=accounting_storage/none
JobAcctGatherType=jobacct_gather/none
ReturnToService=2
StateSaveLocation={folder / 'state'}
SlurmdSpoolDir={folder / 'spool'}
SlurmctldPidFile={folder / 'slurmctld.pid'}
SlurmdPidFile={folder / 'slurmd.pid'}
SlurmctldLogFile={folder / 'log' / 'slurmctld.log'}
SlurmdLogFile={folder / 'log' / 'slurmd.log'}
NodeName={host} NodeAddr=127.0.0.1 CPUs=2 RealMemory=2000 State=UNKNOWN
PartitionName=debug Nodes={host} Default=YES MaxTime=INFINITE State=UP
""")
    return conf


def start(folder: Path, seconds: float = 60.0) -> dict:
    """Start slurmctld (fresh state) and slurmd; return the environment that reaches
    them (``SLURM_CONF``) once the node is idle. Raises RuntimeError with the logs'
    tails otherwise (the caller still calls :func:`stop`)."""
    env = {**os.environ, "SLURM_CONF": str(write_conf(folder))}
    subprocess.run(["slurmctld", "-c"], env=env, check=True, timeout=60)
    subprocess.run(["slurmd"], env=env, check=True, timeout=60)
    t0 = time.monotonic()
    while time.monotonic() - t0 < seconds:
        out = subprocess.run(["sinfo", "-h", "-o", "%t"], env=env, capture_output=True,
                             text=True, timeout=30)
        if out.stdout.strip() == "idle":
            return env
        time.sleep(0.5)
    tails = "; ".join(f"{p.name}: {p.read_text()[-500:]}" for p in (folder / "log").glob("*"))
    raise RuntimeError(f"the test Slurm's node is not idle after {seconds} s: {tails}")


def stop(folder: Path, seconds: float = 30.0) -> None:
    """Cancel this Slurm's jobs, then end both daemons by their pid files and wait until
    they are gone."""
    env = {**os.environ, "SLURM_CONF": str(folder / "slurm.conf")}
    subprocess.run(["scancel", "--full", "--user", "root"], env=env, capture_output=True,
                   timeout=60)
    t0 = time.monotonic()   # the jobs end through slurmd: stopped first, their steps outlive it
    while time.monotonic() - t0 < seconds:
        out = subprocess.run(["squeue", "-h"], env=env, capture_output=True, text=True,
                             timeout=30)
        if out.returncode != 0 or not out.stdout.strip():
            break
        time.sleep(0.2)
    for name in DAEMONS:
        pidfile = folder / f"{name}.pid"
        try:
            pid = int(pidfile.read_text().split()[0])
            os.kill(pid, signal.SIGTERM)
        except (OSError, ValueError, IndexError):
            continue
        t0 = time.monotonic()
        while time.monotonic() - t0 < seconds:
            try:
                os.kill(pid, 0)
            except OSError:
                break
            time.sleep(0.1)
        else:
            os.kill(pid, signal.SIGKILL)


def jobs(env: dict) -> list[str]:
    """Ids of the jobs in the queue (pending or running)."""
    out = subprocess.run(["squeue", "-h", "-o", "%i"], env=env, capture_output=True, text=True,
                         timeout=30, check=True)
    return out.stdout.split()
