"""A running sweep as other processes see it: its ETA and progress line (``status``), and
:func:`attach`, which waits while another live process runs the sweep, printing its
progress (a second submitter of a running sweep; sweeps.service)."""
from __future__ import annotations

import sys
import time

from store.catalogue import Catalogue

ATTACH_POLL_S = 0.5        # an attached submitter reads the catalogue this often


def eta_s(row: dict, now: float | None = None) -> float | None:
    """Seconds left for a running sweep, from its block rate since its run began."""
    started, first = float(row.get("run_started") or 0.0), int(row.get("run_start_blocks") or 0)
    done, total = int(row["done_blocks"]), int(row["n_blocks"])
    if not started or done <= first or total <= 0:
        return None
    rate = (done - first) / max((now or time.time()) - started, 1e-9)
    return max(total - done, 0) / rate


def clock_text(s: float | None) -> str:
    """A duration as a clock reads it (``25 s``, ``3 min 05 s``, ``1 h 02 min``): ETAs and
    run times; estimates of cost are :func:`sweeps.estimates.time_estimate.format_seconds`."""
    if s is None:
        return "?"
    s = round(s)
    if s < 60:
        return f"{s} s"
    if s < 3600:
        return f"{s // 60} min {s % 60:02d} s"
    return f"{s // 3600} h {s % 3600 // 60:02d} min"


def progress_text(row: dict) -> str:
    """``12/32 blocks (37 %), ETA 25 s`` for a running row."""
    total = int(row["n_blocks"]) or 1
    done = int(row["done_blocks"])
    text = f"{done}/{row['n_blocks']} blocks ({100 * done / total:.0f} %)"
    eta = eta_s(row)
    return text + (f", ETA {clock_text(eta)}" if eta is not None else "")


def attach(catalogue: Catalogue, sweep_id: str, *, progress: bool = True,
           poll_s: float = ATTACH_POLL_S, out=None) -> dict:
    """Wait while another live process runs the sweep, printing its progress; returns the
    row once nobody holds the lease (final, queued or stalled), with ``attached_to``: the
    owner it waited for."""
    out = out or sys.stderr
    row = catalogue.get(sweep_id)
    holder = row["owner"]
    if progress:
        print(f"sweep {sweep_id} is running in {row['owner']}: attaching (this process "
              "computes nothing; Ctrl-C detaches and leaves it running)", file=out, flush=True)
    last = ""
    while row["state"] == "running" and Catalogue.alive(row):
        if progress:
            text = progress_text(row)
            if text != last:
                print(f"  {sweep_id}: {text}", file=out, flush=True)
                last = text
        time.sleep(poll_s)
        row = catalogue.get(sweep_id)
    return {**row, "attached_to": holder}
