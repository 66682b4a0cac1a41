"""A running sweep as other processes see it: its ETA and progress line (``status``), and
what a second submitter of a running sweep shows while it waits (:func:`attached_lines`;
the wait is sweeps.run.lease_holder.wait_while_held). Display only: off the computing
path (sweeps.run.quiet)."""
from __future__ import annotations

import sys
import time

from .lease_holder import ATTACH_POLL_S  # noqa: F401 -- serve's poll (sweeps.service)


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


def attached_lines(sweep_id: str, out=None):
    """``show(row)`` for a submitter waiting while another live process runs the sweep
    (sweeps.run.lease_holder.wait_while_held): a first line saying so, then the running
    row's progress each time it changes."""
    last = [None]

    def show(row: dict) -> None:
        stream = out or sys.stderr
        if last[0] is None:
            print(f"sweep {sweep_id} is running in {row['owner']}: attaching (this process "
                  "computes nothing; Ctrl-C detaches and leaves it running)",
                  file=stream, flush=True)
        text = progress_text(row)
        if text != last[0]:
            print(f"  {sweep_id}: {text}", file=stream, flush=True)
            last[0] = text

    return show
