"""``ditherlab submit``, ``serve``, ``cancel`` and ``plan``: the commands that run or
queue work (and ``plan``, which only estimates it and writes nothing unless ``--record``)."""
from __future__ import annotations

import sys
from pathlib import Path

from ..errors import EXIT_FAILED, Interrupted, UserError
from ..lookup import catalogue, resolve_sweep, store_root


def _load(args):
    """The spec of a ``submit``/``plan`` command (pydantic is imported here, not at start);
    ``--device`` overrides the spec's ``device``."""
    from ..spec.load import load_spec

    spec = load_spec(args.spec, max_points=args.max_points)
    if getattr(args, "device", None) and args.device != spec.device:
        spec = spec.model_copy(update={"device": args.device})
    return spec


def cmd_submit(args) -> int:
    from ..workers.local_start import PRESTART_MIN_WORKERS, prestart

    if args.workers >= PRESTART_MIN_WORKERS and not (args.scheduler or args.cluster or
                                                     args.detach):
        prestart()   # the local workers' fork server imports while this process plans
    import store

    from ..estimates.time_history import record_run
    from ..planning.plan import make_plan
    from ..errors import Terminated
    from ..run.interrupt import remembered, terminated_as_interrupt
    from ..run.phases import shown
    from ..run.submit import submit

    spec = _load(args)
    plan = make_plan(spec)
    root = store_root(args.store)
    if not args.quiet:
        print(f"sweep {plan.sweep_id} '{spec.name}': {plan.n_points} points in "
              f"{len(plan.blocks)} blocks, path={plan.path}"
              + (", on the GPU" if plan.numerics.settings.device == "cuda" else ""),
              file=sys.stderr)
    if plan.device_note:
        print(f"ditherlab: {plan.device_note}", file=sys.stderr)
    if args.detach:
        return _submit_detached(plan, root)
    try:
        with remembered(), terminated_as_interrupt():   # (never swallowed by dask)
            res = submit(plan, root, _compute(args), progress=shown(not args.quiet))
    except KeyboardInterrupt as exc:
        how = "terminated (SIGTERM)" if isinstance(exc, Terminated) else "interrupted"
        stop = Interrupted(f"{how}; {_kept(plan, root)}; submit the spec again to resume")
        stop.exit_status = getattr(exc, "exit_status", stop.exit_status)
        raise stop from None
    except store.layout.NoSpaceError as exc:
        raise UserError(f"{exc}; {_kept(plan, root)}") from None
    record_run(root, plan, res)
    if res.attached_to:
        verb = f"attached to the run in {res.attached_to}"
    else:
        verb = "already complete" if res.blocks_run == 0 else f"ran {res.blocks_run} blocks"
    print(f"{res.sweep_id}: {res.state}, {verb}; {res.n_ok}/{res.n_points} ok, "
          f"{res.n_failed} failed; {res.wall_s:.1f} s\ncube: {res.cube_path}")
    if res.message:
        print(f"{res.sweep_id}: {res.message}", file=sys.stderr)
    from ..overview import cube_warnings   # (as status, query and map say them)

    for warning in cube_warnings(res.cube_path):
        print(f"ditherlab: warning: {warning}", file=sys.stderr)
    return 0 if res.state == "done" else EXIT_FAILED


def _kept(plan, root: Path) -> str:
    """What a stopped submit kept: ``the journal keeps the N finished blocks (of M)``."""
    import store

    try:
        n = len(store.Journal(store.SweepDir(root, plan.sweep_id).journal).files())
    except OSError:
        return "the journal keeps its finished blocks"
    return f"the journal keeps the {n} finished blocks (of {len(plan.blocks)})"


def _submit_detached(plan, root: Path) -> int:
    """``submit --detach``: queue the sweep for ``ditherlab serve`` and return at once."""
    import store

    from ..service import enqueue, unserved

    row = enqueue(plan, root)
    cat = store.Catalogue(root)
    state = cat.live_state(row)
    if state == "queued":
        print(f"{row['sweep_id']}: queued" + (f" ({row['message']})" if row["message"] else ""))
        if unserved(cat.servers(), [row]):
            wanted = "`ditherlab serve --device cuda`" if plan.spec.device == "cuda" \
                else "`ditherlab serve`"
            print(f"ditherlab: no {wanted} is running on store {root}; start one to "
                  "run the queue", file=sys.stderr)
    elif state == "running":
        print(f"{row['sweep_id']}: running in {row['owner']} (`ditherlab status "
              f"{row['sweep_id']}` shows its progress)")
    else:
        print(f"{row['sweep_id']}: {state}, already complete")
    return 0


def cmd_serve(args) -> int:
    from ..service import serve

    return serve(store_root(args.store), _compute(args), device=args.device, progress=False)


def _plan_workers(args, plan) -> tuple[int, tuple[float, str]]:
    """The workers a plan's estimate counts, and the start-up it adds: a batch run's jobs
    (no more than blocks) start in JOB_START_S on an idle queue (sweeps.workers.batch)."""
    if not args.cluster or plan.path != "simulate":
        return args.workers, (0.0, "; cluster start comes on top")
    from ..workers.batch import JOB_START_S

    jobs = max(1, min(args.jobs, len(plan.blocks)))
    return jobs, (JOB_START_S, f" on {jobs} {args.cluster} jobs, plus {JOB_START_S:.0f} s of "
                               "job start-up (an idle queue; a busy one adds its wait)")


def _estimated_device(spec, plan):
    """``(spec, GPU name)`` for a plan run on the GPU; without a GPU the plan says so in one
    line and estimates the CPU instead (``(spec on the cpu, "")``): a GPU's calibration is
    measured on one, never made up from launches that could not run."""
    if spec.device != "cuda":
        return spec, ""
    on_cpu = spec.model_copy(update={"device": "cpu"})
    if plan.device_note:   # it runs on the CPU (a level's plan might not: estimated so too)
        return on_cpu, ""
    from engine.gpu import NoGPU, check_device

    try:
        return spec, check_device()
    except NoGPU as exc:
        print(f"           {exc}; the estimates below are for this machine's CPU")
        return on_cpu, ""


def _compute(args):
    """Where the blocks are computed: ``--scheduler ADDRESS``, ``--cluster KIND --jobs N``
    batch jobs, or ``--workers N`` local processes; ``--dashboard``."""
    from ..workers.batch import BatchWorkers
    from ..workers.compute import Compute

    batch = BatchWorkers(args.cluster, args.jobs) if args.cluster else None
    return Compute.chosen(workers=args.workers, batch=batch, scheduler=args.scheduler,
                          dashboard=args.dashboard)


def cmd_cancel(args) -> int:
    import store

    from ..service import cancel

    root = store_root(args.store)
    live = [r for r in catalogue(root).matches(args.sweep) if r["state"] in ("running", "queued")]
    # the one sweep of that key still running or queued (stale or not), else as query finds it
    sweep_id = live[0]["sweep_id"] if len(live) == 1 else \
        resolve_sweep(root, args.sweep, need_cube=False)[0]
    try:
        row = cancel(root, sweep_id, wait=args.wait)
    except LookupError as exc:
        raise UserError(str(exc)) from None
    state, sid = store.Catalogue.live_state(row), row["sweep_id"]
    if state == "cancelled":
        print(f"{sid}: cancelled; {row['message']}")
    elif state == "running" and row["cancel_requested"]:
        print(f"{sid}: cancel requested; {row['owner']} stops after its blocks in flight "
              f"(`ditherlab status {sid}` shows when)")
    else:
        print(f"{sid}: {state}; nothing to cancel")
    return 0


def cmd_plan(args) -> int:
    from ..estimates.time_estimate import estimates, format_seconds
    from ..planning.plan import make_plan

    from ..estimates import time_history as history

    spec = _load(args)
    plan = make_plan(spec)
    if args.record:   # a store path that cannot be one is refused before the calibration
        import store

        store.layout.check_store(store_root(args.store), write=False)
    shape = " x ".join(f"{a}={len(v)}" for a, v in plan.coords.items())
    print(f"sweep      {plan.sweep_id}  '{spec.name}'")
    print(f"points     {plan.n_points}  ({shape})  in {len(plan.blocks)} interleaved blocks")
    print(f"path       {plan.path}" + ("" if plan.path == "simulate" else
                                       "  (no time integration)"))
    print(f"scene      system={spec.system} friction={spec.friction} dither={plan.scene.dither}")
    if plan.path == "simulate":
        on = [k for k, v in plan.effects().items() if v]
        off = [k for k, v in plan.effects().items() if not v]
        print(f"effects    compiled in: {', '.join(on) or '-'}; left out: {', '.join(off) or '-'}")
        from engine.kernels import step_cap_note
        from engine.systems import describe_states
        print(f"states     {describe_states(plan.scene)}")
        s = plan.numerics.settings
        stops = ("; steps land on every square-wave switch"
                 if plan.scene.dither == "square-velocity" else "") + step_cap_note(plan.scene)
        print(f"numerics   {plan.numerics.integrator} ({plan.numerics.label}): rtol={s.rtol:g} "
              f"atol={s.atol:g}{' (natural units)' if s.atol_units == 'natural' else ''}{stops}")
    if spec.device == "cuda":
        print(f"device     {plan.device_note or 'cuda: one GPU thread a point'}")
    print(f"outputs    {', '.join(plan.outputs)}")
    workers, start = _plan_workers(args, plan)
    spec, on_gpu = _estimated_device(spec, plan)
    if on_gpu:
        print(f"estimates  (calibrated now on this machine's GPU, {on_gpu}: a block is one "
              f"launch of up to {max(len(b) for b in plan.blocks)} points, blocks one after "
              "another; a launch lasts at least its slowest point; first compilation comes "
              "on top)")
    else:
        print(f"estimates  (calibrated now on this machine, {workers} workers, compute "
              f"phase{start[1]}; first compilation comes on top)")
    found = estimates(spec, workers=workers)
    for est in found:
        slowest = f", slowest point {format_seconds(est.slowest_s)}" if on_gpu else ""
        print(f"  {est.level:<10} {est.integrator:<11} {format_seconds(est.per_point_s):>9} "
              f"per point{slowest}  ->  {format_seconds(est.wall_s + start[0])} wall")
    root = store_root(args.store)
    previous = history.last_comparison(root)
    if previous:
        print(previous)
    if args.record:   # plan writes nothing unless asked
        try:
            history.record_estimate(root, plan.sweep_id, {e.level: e.wall_s for e in found})
        except OSError as err:   # a read-only store or a full disk: shown, not remembered
            print(f"ditherlab: warning: estimates not recorded ({err.strerror or err})",
                  file=sys.stderr)
    return 0


