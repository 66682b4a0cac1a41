"""The gallery's commands (issue 12), added to the ``ditherlab`` parser by
``sweeps.cli.main.build_parser``:

    ditherlab scenes                                   # the named scenes
    ditherlab submit --scene fig14 [--size small|full] # also plan --scene, map --scene
    ditherlab map SWEEP --kind friction --pick 5       # or --sel W=0.2 --sel W=0.5 ...
    ditherlab gallery [--size small|full] [-o DIR] [--only fig14 ...]

A scene's spec comes from ``specs/`` through :mod:`sweeps.gallery.scenes` (one source).
"""
from __future__ import annotations

import sys
from pathlib import Path

from ..errors import EXIT_FAILED, RefusedError
from ..gallery.scenes import REGISTRY, SIZES, get_scene

SCENE_COMMANDS = {"submit": "spec", "plan": "spec", "map": "sweep"}


def add_commands(sub, common) -> None:
    """Add ``--scene``/``--size`` to submit, plan and map, ``--pick`` to map, and the
    ``scenes`` and ``gallery`` commands."""
    for name, positional in SCENE_COMMANDS.items():
        p = sub.choices[name]
        p.add_argument("--scene", metavar="NAME",
                       help="a named scene instead of a spec file (`ditherlab scenes`)")
        p.add_argument("--size", default=None, choices=SIZES,
                       help="scene size: small (seconds) or full (the paper's figure; default)")
        p.set_defaults(func=_with_scene(p.get_default("func"), positional))
    sub.choices["map"].add_argument(
        "--pick", type=int, metavar="N",
        help="--kind friction: draw N of the cube's W values, evenly spread (first and last "
        "included); or name them with repeated --sel W=VALUE")
    p = sub.add_parser("scenes", parents=[common], help="the paper's figures as named scenes")
    p.set_defaults(func=cmd_scenes)
    p = sub.add_parser("gallery", parents=[common],
                       help="draw every figure of the paper with a page of verdicts")
    p.add_argument("--size", default="small", choices=SIZES)
    p.add_argument("-o", "--output", default="gallery", help="folder (default ./gallery)")
    p.add_argument("--only", action="append", metavar="KEY", help="only these figures "
                   "(fig01 ... fig17, beyond_scaling, beyond_sine); repeat")
    p.add_argument("--workers", type=int, default=2, help="local dask workers for sweeps")
    p.set_defaults(func=cmd_gallery)


def _with_scene(func, positional: str):
    def run(args) -> int:
        given, scene = getattr(args, positional), args.scene
        if given and scene:
            raise RefusedError(f"give a {positional} or --scene {scene}, not both")
        if not given and not scene:
            raise RefusedError(f"missing {positional}: give a {positional} or --scene NAME "
                               "(`ditherlab scenes` lists them)")
        if args.size and not scene:
            raise RefusedError("--size applies to --scene only")
        if scene:
            spec = get_scene(scene).spec(args.size or "full")
            setattr(args, positional, spec if positional == "spec" else _scene_sweep(args, spec))
        if positional == "sweep" and (args.pick is not None or _w_list(args.sel)):
            return _map_picked(args)
        return func(args)
    return run


def _scene_sweep(args, spec: dict) -> str:
    """The id of the scene's sweep for ``map --scene``, computed first when the store does
    not hold it complete (a submit of the scene; a complete one returns at once)."""
    import sys

    from ..api import run_sweep
    from ..gallery.scenes import get_scene

    size = args.size or "full"
    if not args.quiet:   # a full-size map may mean many minutes of compute: say so first
        print(f"scene {args.scene} ({size}, {get_scene(args.scene).n_points(size)} points): "
              f"computing its sweep unless the store holds it"
              + ("; --size small for a quick look" if size == "full" else ""),
              file=sys.stderr, flush=True)
    res = run_sweep(spec, args.store, progress=not args.quiet)
    if res.state != "done":
        raise RefusedError(f"scene {args.scene}: sweep {res.sweep_id} is {res.state}; "
                           f"`ditherlab submit --scene {args.scene}` resumes it")
    return res.sweep_id


def _w_list(items) -> list[str]:
    return [s for s in items or () if s.partition("=")[0].strip() == "W"]


def _map_picked(args) -> int:
    """``map --kind friction`` with a handful of W curves: ``--pick N`` evenly spread, or
    the repeated ``--sel W=...`` (each the nearest grid value)."""
    import store

    from ..exports import draw_map, pick_w
    from .reading import cmd_map, open_for_map, parse_sel, warn_inferred

    if args.kind != "friction" and args.pick is not None:
        raise RefusedError(f"--pick applies to --kind friction only (curves of W), not to "
                           f"--kind {args.kind}")
    if args.kind != "friction":   # --sel W of a stick-slip or stability map: as any --sel
        return cmd_map(args)
    wanted = _w_list(args.sel)
    if args.pick is not None and wanted:
        raise RefusedError("give --pick N or --sel W=VALUE, not both")
    if args.pick is not None and args.pick < 1:
        raise RefusedError(f"--pick: must be >= 1, got {args.pick}")
    ds = open_for_map(args)
    if args.pick is not None:
        keep = pick_w(ds, args.pick)
    else:
        try:   # each the nearest grid value, off the grid refused as by query
            keep = sorted({float(store.select(ds, parse_sel([w]))["W"].values[0])
                           for w in wanted})
        except ValueError as exc:
            raise RefusedError(str(exc)) from None
    rest = [s for s in args.sel or () if s not in wanted]
    draw_map(ds.sel(W=keep), "friction", parse_sel(rest), args.output)
    warn_inferred(ds.sel(W=keep), rest)   # curves are values: inferred ones are said
    print(f"wrote {args.output} (W = {', '.join(f'{w:g}' for w in keep)})")
    return 0


def cmd_scenes(args) -> int:
    from ..gallery.build import RECIPES

    print(f"{'scene':<15}{'small':>8}{'full':>8}  paper")
    for s in REGISTRY.values():
        print(f"{s.name:<15}{s.n_points('small'):>8}{s.n_points('full'):>8}  {s.ref}")
    print("\nrun one: ditherlab submit --scene NAME [--size small|full]\n")
    print(f"{'figure':<15}how it is computed (ditherlab gallery --only FIGURE)")
    for key, recipe in RECIPES.items():
        print(f"{key:<15}{recipe}")
    print("\nall figures: ditherlab gallery [--size small|full] [-o DIR]")
    return 0


def cmd_gallery(args) -> int:
    import time

    from ..gallery.build import FIGURES, build
    from ..gallery.context import Context

    unknown = sorted(set(args.only or ()) - set(FIGURES))
    if unknown:
        raise RefusedError(f"--only: unknown figure {', '.join(unknown)}; known: "
                           f"{', '.join(FIGURES)}")
    out = Path(args.output)
    t0 = time.perf_counter()
    ctx = Context(size=args.size, outdir=out, store=args.store, workers=args.workers,
                  progress=False)
    quiet = args.quiet
    results = build(ctx, only=args.only,
                    log=(lambda *a: None) if quiet else lambda m: print(m, file=sys.stderr))
    print(f"{'figure':<15} verdict")
    for r in results:
        print(f"{r.key:<15} {r.verdict}")
    print(f"wrote {out / 'index.html'} and {out / 'gallery.md'} "
          f"({time.perf_counter() - t0:.0f} s)")
    failed = [r for r in results if r.error]
    for r in failed:
        print(f"ditherlab: {r.key} could not be computed: {r.error}", file=sys.stderr)
    return EXIT_FAILED if failed else 0
