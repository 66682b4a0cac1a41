"""ditherlab as a batch service (DESIGN.md §5-6): a queue, ``serve``, ``cancel``, and one
writer per sweep.

The catalogue (store.catalogue) is the only shared state. Every state change is one SQLite
transaction; a process computes a sweep's blocks only while it holds the sweep's *lease*
(the row's ``owner`` and ``heartbeat``):

- ``submit --detach`` registers the sweep and queues it (:func:`enqueue`); nothing else runs,
  and dask is not imported.
- ``serve`` (:func:`serve`) claims the oldest queued sweep (``Catalogue.claim_next``: queued ->
  running under its ``host:pid``), runs it on one dask cluster it keeps for its lifetime, and
  takes the next. SIGTERM or SIGINT: the running sweep finishes its in-flight blocks (the
  journal keeps them), goes back to ``queued`` with a message, and serve exits 0. A second
  signal stops at once (the journal still keeps every finished block).
- A foreground ``submit`` takes the lease (``Catalogue.acquire``). If a live process holds it,
  the submitter *attaches* (:func:`sweeps.run.lease_holder.wait_while_held`): it computes nothing,
  prints the progress the holder writes to the catalogue, and returns the final result.
  If the holder dies (its pid is gone on this host, or its heartbeat is older than
  ``STALE_S``), the attached submitter takes the lease over and computes the blocks still
  missing from the journal.
- ``ditherlab cancel`` (:func:`cancel`): a queued sweep is cancelled at once; a running one is
  flagged, and its runner, which asks the catalogue between blocks
  (:meth:`sweeps.run.lease_holder.Lease.stop_reason`), stops after its in-flight blocks.

While it holds a lease a runner beats every ``HEARTBEAT_S`` seconds from a thread
(:class:`sweeps.run.lease_holder.Lease`); a beat that finds the lease taken over stops the
runner too, so a block is never computed by two processes that both believe they own the
sweep.
"""
from __future__ import annotations

import json
import logging
import signal
import sys
import threading
import time

import store
from store.catalogue import Catalogue
from store.lease import HEARTBEAT_S, owner_tag, queued_device

from .run.progress import ATTACH_POLL_S, clock_text, progress_text
from .version import results_fingerprint

log = logging.getLogger("ditherlab")

SERVE_POLL_S = 1.0         # an idle serve looks for queued sweeps this often
# the spec devices whose queued sweeps a serve runs, by the serve's own --device
SERVED = {"cpu": ("cpu",), "cuda": ("cpu", "cuda")}


# --- submit --detach -------------------------------------------------------------------

def enqueue(plan, store_root) -> dict:
    """Record ``plan`` as a queued sweep (spec saved in its folder); returns the row. The
    row names the engine of its id (readers judge it by that, not by loading the spec: a
    brought model was probed in a child on every `status` and web refresh). A sweep that is
    done or running (live) is left as it is: the row says so; a done one whose cube is
    unusable (sweeps.run.outcome.unusable) is queued again."""
    store.layout.check_store(store_root, write=True)   # read-only, a file: one line, now
    sweep, catalogue = store.SweepDir(store_root, plan.sweep_id), Catalogue(store_root)
    sweep.root.mkdir(parents=True, exist_ok=True)
    spec_json = plan.spec.to_json()
    sweep.write_spec(spec_json)
    catalogue.register(plan.sweep_id, plan.spec.name, spec_json, plan.n_points,
                       len(plan.blocks), sweep.root, results_fingerprint())
    row = catalogue.enqueue(plan.sweep_id)
    from .run.outcome import unusable   # (here: `status` imports this module, no numerics)
    if row["state"] == "done" and (why := unusable(plan, sweep)):   # rebuild it
        catalogue.finish(plan.sweep_id, "cancelled", message=f"{why}; re-queued")
        row = {**catalogue.enqueue(plan.sweep_id), "message": f"{why}; re-queued"}
    return row


# --- cancel ----------------------------------------------------------------------------

def cancel(store_root, key: str, *, wait: bool = False, timeout_s: float | None = None,
           poll_s: float = ATTACH_POLL_S) -> dict:
    """Cancel a sweep (id, id prefix or name); returns its row after the request (after it
    stopped, with ``wait``). ``LookupError`` if there is no such sweep."""
    store.layout.check_store(store_root, write=True)
    catalogue = Catalogue(store_root)
    found = catalogue.find(key)
    if found is None:
        raise LookupError(f"no sweep {key!r} in store {store_root} (see `ditherlab status`)")
    row = catalogue.request_cancel(found["sweep_id"])
    t0 = time.monotonic()
    while wait and row["state"] == "running" and Catalogue.alive(row):
        if timeout_s is not None and time.monotonic() - t0 > timeout_s:
            break
        time.sleep(poll_s)
        row = catalogue.get(row["sweep_id"])
    return row


# --- serve -----------------------------------------------------------------------------

class _Signals:
    """SIGTERM/SIGINT: the first sets ``stop`` (finish in-flight blocks, re-queue, exit 0);
    a second raises KeyboardInterrupt (stop now; the journal keeps finished blocks)."""

    def __init__(self, stop: threading.Event, say):
        self.stop, self.say, self.previous = stop, say, {}

    def __enter__(self):
        for sig in (signal.SIGTERM, signal.SIGINT):
            self.previous[sig] = signal.signal(sig, self._handle)
        return self

    def _handle(self, signum, frame):
        if self.stop.is_set():
            raise KeyboardInterrupt
        self.stop.set()
        self.say(f"serve: {signal.Signals(signum).name}: stopping; a running sweep finishes "
                 "its blocks in flight and goes back to the queue (signal again to stop at once)")

    def __exit__(self, *exc):
        for sig, handler in self.previous.items():
            signal.signal(sig, handler)
        return False


def serve(store_root, compute=None, *, device: str = "cpu", poll_s: float = SERVE_POLL_S,
          idle_exit_s: float | None = None, progress: bool = False, say=None) -> int:
    """Run queued sweeps of the store, oldest first, one at a time, on ``compute`` (a
    :class:`sweeps.workers.compute.Compute`, default a local cluster of 2 workers, started
    for the first simulated sweep and kept between sweeps) until SIGTERM/SIGINT (or, with
    ``idle_exit_s``, until the queue has been empty that long). Returns 0.

    ``device``: ``cpu`` leaves the sweeps queued for the GPU (spec ``device = "cuda"``) to a
    serve with one; ``cuda`` runs them too, on this machine's GPU or the scheduler's GPU
    workers, and is refused at once (a RefusedError) where there is no GPU to run them."""
    from .workers.compute import Compute

    compute = compute or Compute()
    if device == "cuda":
        compute.check_gpu()   # no GPU here, or batch jobs: one line before anything starts
    server = _Server(store_root, compute, device, progress,
                     say or (lambda text: print(text, file=sys.stderr, flush=True)))
    server.start()
    try:
        with _Signals(server.stop, server.say):
            idle_since = time.monotonic()
            while not server.stop.is_set():
                if server.next():
                    idle_since = time.monotonic()
                elif idle_exit_s is not None and time.monotonic() - idle_since > idle_exit_s:
                    break
                else:
                    server.stop.wait(poll_s)
    finally:
        server.shut_down()
    server.say(f"serve {server.me}: stopped")
    return 0


class _Server:
    """serve's steps: :meth:`start` (heartbeat, banner), :meth:`next` (claim the oldest
    queued sweep, :meth:`plan_of` it, :meth:`run` it on the kept compute), :meth:`shut_down`
    (the claimed sweep back to the queue, the cluster closed)."""

    def __init__(self, store_root, compute, device: str, progress: bool, say):
        self.root = store.layout.check_store(store_root, write=True)
        self.catalogue, self.me = Catalogue(self.root), owner_tag()
        self.compute, self.progress, self.say = compute, progress, say
        self.device, self.devices = device, SERVED[device]
        self.stop, self.beating = threading.Event(), threading.Event()
        self.current = ""   # the sweep claimed, until its run ends

    def start(self) -> None:
        """serve's own heartbeat, on a thread (also while a sweep runs), and its banner."""
        self.beat()
        threading.Thread(target=self._beat_loop, daemon=True, name="ditherlab-serve-beat").start()
        gpu = {"cuda": "; also the sweeps queued for the GPU",
               "cpu": "; the sweeps queued for the GPU are left to `serve --device cuda`"}
        self.say(f"serve {self.me}: store {self.root}, {self.compute.where}{gpu[self.device]}; "
                 "waiting for queued sweeps (SIGTERM or Ctrl-C stops)")

    def beat(self) -> None:
        self.catalogue.server_beat(self.me, sweep_id=self.current, cluster=self.compute.where,
                                   device=self.device)

    def _beat_loop(self) -> None:
        while not self.beating.wait(HEARTBEAT_S):
            try:
                self.beat()
            except Exception as err:  # noqa: BLE001 -- a busy catalogue: next beat
                log.warning("serve heartbeat failed: %s", err)

    def next(self) -> bool:
        """Claim and run the oldest queued sweep; False when none is queued."""
        row = self.catalogue.claim_next(self.me, devices=self.devices)
        if row is None:
            return False
        self.current = row["sweep_id"]
        self.beat()
        plan = self.plan_of(row)
        if plan is not None:
            self.run(plan)
        self.current = ""
        self.beat()
        return True

    def plan_of(self, row: dict):
        """The plan of a claimed row; None (the row settled) when its spec is refused now,
        or when the installed engine gives it another id (re-queued under that id)."""
        from .planning.plan import make_plan
        from .spec.load import SpecError, load_spec

        sweep_id = row["sweep_id"]
        try:
            plan = make_plan(load_spec(json.loads(row["spec_json"]),
                                       max_points=max(row["n_points"], 1)))
        except (SpecError, ValueError) as err:
            self.catalogue.finish(sweep_id, "failed", owner=self.me,
                                  message=f"cannot run the queued spec: {err}")
            self.say(f"serve: {sweep_id} failed: {err}")
            return None
        if plan.sweep_id != sweep_id:
            # the engine (or ditherlab) changed since it was queued: its results belong
            # under the id the installed engine gives the spec
            enqueue(plan, self.root)
            self.catalogue.finish(sweep_id, "cancelled", owner=self.me, message=(
                f"the engine changed after it was queued; re-queued as {plan.sweep_id}"))
            self.say(f"serve: {sweep_id}: the engine changed since it was queued; "
                     f"re-queued as {plan.sweep_id}")
            return None
        return plan

    def run(self, plan) -> None:
        """Run ``plan`` on the compute, opened for the first simulated sweep and kept (a
        failed run closes it: the cluster may be the culprit); batch jobs end after it."""
        from .estimates.time_history import record_run
        from .run.phases import shown
        from .run.submit import submit

        sweep_id = plan.sweep_id
        self.say(f"serve: running {sweep_id} '{plan.spec.name}': {plan.n_points} points in "
                 f"{len(plan.blocks)} blocks")
        try:
            if plan.path == "simulate":
                self.compute.open()
            res = submit(plan, self.root, self.compute, progress=shown(self.progress),
                         owner=self.me, stop=self.stop)
        except Exception as err:  # noqa: BLE001 -- recorded as failed; serve goes on
            text = f"{type(err).__name__}: {err}".splitlines()[0][:500]
            self.say(f"serve: {sweep_id} failed: {text}")
            # raised before the run took its lease (store checks): still ours
            self.catalogue.finish(sweep_id, "failed", owner=self.me,
                                  message=f"the run could not start: {text}")
            self.compute.close()   # a fresh cluster for the next sweep
        else:
            record_run(self.root, plan, res)
            self.say(f"serve: {sweep_id}: {res.state}, ran {res.blocks_run} blocks; "
                     f"{res.n_ok}/{res.n_points} ok, {res.n_failed} failed; "
                     f"{res.wall_s:.1f} s" + (f" ({res.message})" if res.message else ""))
        finally:   # batch jobs end between sweeps: no allocation held while waiting
            self.compute.release()

    def shut_down(self) -> None:
        self.beating.set()
        if self.current:   # interrupted between claim and run: back to the queue
            self.catalogue.requeue(self.current, self.me, "re-queued: serve was interrupted")
        self.compute.close()
        self.catalogue.server_gone(self.me)


def queue_hint(catalogue: Catalogue, rows: list[dict]) -> str | None:
    """A line for ``status``: who serves this store, and the queued sweeps no serve
    running on it will take (:func:`unserved`)."""
    servers, parts = catalogue.servers(), []
    if servers:
        parts.append("serve: " + "; ".join(
            f"{s['owner']} ({'running ' + s['sweep_id'] if s['sweep_id'] else 'idle'}, "
            f"{s['cluster']}{', and the GPU sweeps' if s.get('device') == 'cuda' else ''})"
            for s in servers))
    waiting = unserved(servers, [r for r in rows if r["state"] == "queued"])
    return "; ".join(parts + ([waiting] if waiting else [])) or None


def unserved(servers: list[dict], queued: list[dict]) -> str | None:
    """What the ``queued`` rows wait for that none of the live ``servers`` gives: any
    serve at all, or one started with ``--device cuda`` for the sweeps queued for the GPU."""
    devices = {d for s in servers for d in SERVED.get(s.get("device") or "cpu", ("cpu",))}
    asks = [queued_device(r["spec_json"]) for r in queued]
    if not servers and asks:
        return (f"{len(asks)} queued sweep(s) wait for `ditherlab serve` (no serve process is "
                "running on this store)" + ("; those queued for the GPU for `ditherlab serve "
                                            "--device cuda`" if "cuda" in asks else ""))
    gpu = sum(1 for a in asks if a not in devices)
    if gpu:
        return (f"{gpu} sweep(s) queued for the GPU wait for `ditherlab serve --device cuda` "
                "(no serve on this store runs the GPU's sweeps)")
    return None


# clock_text, progress_text: re-exported for sweeps.cli (status)
__all__ = ["cancel", "clock_text", "enqueue", "progress_text", "queue_hint", "serve",
           "unserved"]
