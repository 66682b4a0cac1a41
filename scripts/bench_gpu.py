"""GPU against all CPU cores of the same machine, and against the hand-written GPU kernel.

    python3 scripts/bench_gpu.py                    # on a machine with an NVIDIA GPU
    python3 scripts/bench_gpu.py --points 131072 --cpu-points 2048 --fig14 16384
    NUMBA_ENABLE_CUDASIM=1 python3 scripts/bench_gpu.py --smoke    # anywhere: the script runs

One run prints, with the CPU model, its core count and the GPU's name:

1. the anchors' scene (``../shared/anchors/README.md``: LuGre slider, square-velocity dither
   W in [0, 0.8), omega = 1000, v_ref = 0.4, tau in [0, 100], fixed-step RK4 with 2 steps a
   half-period aligned to the switches) through ``engine.blocks.run_block``: points/s on the
   GPU (``Settings.device = "cuda"``, one thread a point, engine/gpu.py) and on every CPU core (one
   thread per core, each running the CPU block kernel on its share: the kernels release the
   GIL), their ratio, and the hand kernel ``../shared/anchors/anchor_cuda.py`` (constants
   compiled in) at the same point count as the limit;
2. Fig. 14's scene (specs/fig14.toml at its standard level: LuGre, square-velocity dither,
   the spec's integrator and tolerances) on a W x omega grid over the spec's ranges, GPU
   and all CPU cores;
3. agreement: the largest difference GPU vs CPU over the points both computed, per output,
   relative to the output's scale (fixed step: the promise is 1e-9 relative; adaptive:
   the level's);
4. optionally, each scene's GPU rate at other block sizes (``--tpb``) and register caps
   (``--regs``), and ``--probe``: Fig. 14's costliest point on one GPU thread, on a warp of
   copies and in its warp of a sweep, against one CPU core.

GPU times are medians of ``--repeats`` after a warm-up launch on a few points (which
compiles: its time is printed as the first call's). The CPU side runs once, after its own
warm-up (loading or compiling its kernels), on ``--cpu-points`` / ``--fig14-cpu`` points spread
evenly over the GPU's (a core needs ~10 ms a point of the anchors' scene and ~0.2 s of Fig.
14's); its rate is points/s over all cores.
"""
from __future__ import annotations

import argparse
import dataclasses
import json
import subprocess
import sys
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import numpy as np

from machine import cores, cpu_model

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))
ANCHOR_CUDA = ROOT.parent / "shared" / "anchors" / "anchor_cuda.py"

def anchors_case(n: int, t_end: float):
    """``(scene, p, points, settings)`` of the anchors' fig10 scene, W over [0, 0.8)."""
    from engine import Scene, Settings
    from engine import params as P

    p = P.pack(t_end=t_end, t_transient=0.5 * t_end, v_ref=0.4, omega=1000.0)
    scene = Scene.from_params(p, dither="square-velocity", integrator="rk4",
                              outputs=("v_mean", "v_slow_p2p"))
    W = 0.8 * np.arange(n) / n
    points = np.column_stack([W, np.full(n, 1000.0), np.full(n, 0.4), np.full(n, p[P.VD])])
    return scene, p, points, Settings(steps_per_period=2)


def fig14_case(n: int, t_end: float | None):
    """Fig. 14's plan (specs/fig14.toml, its level) on a ``sqrt(n) x sqrt(n)`` W x omega grid."""
    from engine import params as P
    from sweeps.planning.plan import make_plan
    from sweeps.spec.load import load_spec

    plan = make_plan(load_spec(ROOT / "specs" / "fig14.toml"))
    side = max(1, int(round(n ** 0.5)))
    coords = plan.grid.coords
    W = np.linspace(coords["W"].min(), coords["W"].max(), side)
    omega = np.geomspace(coords["omega"].min(), coords["omega"].max(), side)   # (log, as the spec)
    WW, OO = np.meshgrid(W, omega, indexing="ij")
    p = plan.params.copy()
    if t_end is not None:
        p[P.T_END], p[P.T_TRANSIENT] = t_end, 0.5 * t_end
    points = np.column_stack([WW.ravel(), OO.ravel(), np.full(WW.size, coords["v_ref"][0]),
                              np.full(WW.size, coords["v_d"][0])])
    return plan.scene, p, points, plan.numerics.settings


def timed(fn, repeats: int, warm=None) -> tuple[float, object, float]:
    """``(median seconds, result, warm-up seconds)``: ``warm`` (default ``fn``) runs first,
    compiling the GPU kernel or loading the CPU kernel cache."""
    t0 = time.perf_counter()
    (warm or fn)()
    warm_s = time.perf_counter() - t0
    times, result = [], None
    for _ in range(repeats):
        t0 = time.perf_counter()
        result = fn()
        times.append(time.perf_counter() - t0)
    return float(np.median(times)), result, warm_s


def on_cpu(scene, p, points, settings, threads: int):
    """All cores: the points in ``threads`` interleaved shares, one thread each."""
    from engine.blocks import run_block

    shares = [np.arange(k, len(points), threads) for k in range(threads)]
    with ThreadPoolExecutor(threads) as pool:
        parts = list(pool.map(lambda ix: run_block(scene, points[ix], p, settings), shares))
    outputs = {}
    for name in parts[0].outputs:
        col = np.empty((len(points), *parts[0].outputs[name].shape[1:]))
        for ix, part in zip(shares, parts):
            col[ix] = part.outputs[name]
        outputs[name] = col
    return outputs


def on_gpu(scene, p, points, settings):
    from engine.blocks import run_block

    return run_block(scene, points, p, dataclasses.replace(settings, device="cuda")).outputs


def agreement(cpu: dict, gpu: dict, k: int) -> dict:
    """Per output, the largest ``|gpu - cpu|`` over the points both computed, relative to
    the output's scale (its largest ``|cpu|`` there): a pointwise relative difference is
    meaningless where a value is rounding noise (the anchors' v_slow_p2p is ~1e-12 where
    the slider slides smoothly, and there differed by 0.6 of itself on an H200)."""
    out = {}
    for name, c in cpu.items():
        g = gpu[name][:k]
        both = np.isfinite(c) & np.isfinite(g)
        scale = np.abs(c[both]).max() if both.any() else 0.0
        diff = np.abs(g[both] - c[both]).max() if both.any() else float("nan")
        out[name] = float(diff / scale) if scale > 0 else float(diff)
        odd = int((np.isfinite(c) != np.isfinite(g)).reshape(len(c), -1).any(axis=1).sum())
        if odd:   # a point computed on one side only (a failed or non-finite point)
            out[name] = float("inf")
            print(f"{name}: {odd} points finite on one side only", flush=True)
    return out


def hand_kernel(n: int, t_end: float) -> dict | None:
    if not ANCHOR_CUDA.is_file():
        return None
    proc = subprocess.run([sys.executable, str(ANCHOR_CUDA), str(n), "--tend", str(t_end)],
                          capture_output=True, text=True, timeout=600)
    if proc.returncode != 0:
        return {"error": proc.stderr.strip().splitlines()[-1:]}
    return json.loads(proc.stdout.strip().splitlines()[-1])


def row(label: str, n: int, seconds: float) -> str:
    return f"| {label} | {n:,} | {seconds:.3f} s | {n / seconds:,.0f} |"


def launch_variants(label: str, case, args) -> dict:
    """The scene on the GPU at each ``--tpb`` block size and ``--regs`` register cap (one
    launch each, after one that compiles): ``{"tpb=64": points/s, ...}``."""
    from engine import gpu

    scene, p, points, settings = case
    few = points[:64]
    rates, defaults = {}, (gpu.THREADS_PER_BLOCK, gpu.MAX_REGISTERS)
    tried = [("tpb", int(t)) for t in args.tpb.split(",") if t] + \
            [("regs", int(r)) for r in args.regs.split(",") if r]
    compiled_cap = defaults[1]   # the cap the cached kernel was compiled with
    try:
        for what, value in tried:
            gpu.THREADS_PER_BLOCK, gpu.MAX_REGISTERS = defaults
            setattr(gpu, "THREADS_PER_BLOCK" if what == "tpb" else "MAX_REGISTERS", value)
            if gpu.MAX_REGISTERS != compiled_cap:   # a register cap is a compile option
                gpu.block_kernel.cache_clear()
                compiled_cap = gpu.MAX_REGISTERS
            seconds, _, warm = timed(lambda: on_gpu(scene, p, points, settings), 1,
                                     warm=lambda: on_gpu(scene, p, few, settings))
            rates[f"{what}={value}"] = len(points) / seconds
            print(row(f"{label}, engine on the GPU, {what} = {value}", len(points), seconds)
                  + f" {warm:.1f} s |", flush=True)
    finally:
        gpu.THREADS_PER_BLOCK, gpu.MAX_REGISTERS = defaults
        if compiled_cap != defaults[1]:   # the kernel of the default cap again
            gpu.block_kernel.cache_clear()
    return rates


def probe(t_end: float | None, repeats: int) -> dict:
    """Fig. 14's costliest point on one GPU thread, on 32 (one warp, no divergence), the 32
    points of specs/fig14.toml's first warp in the GPU's order (omega = 1000, W from 3 down
    to 0, and one point of the next omega: divergence), and on one CPU core: seconds and
    seconds per step. (On 2026-11-28 "its warp" was W = 3.0 down to 2.0 in steps of 3/95.)"""
    from engine import params as P
    from engine.blocks import run_block

    from engine.gpu import cost_order
    from sweeps.planning.plan import make_plan
    from sweeps.spec.load import load_spec

    scene, p, _, settings = fig14_case(4, t_end)
    grid = make_plan(load_spec(ROOT / "specs" / "fig14.toml")).points   # the spec's points
    warp = grid[cost_order(grid)[:32]]   # its first warp: omega = 1000, W from 3 down to 0
    top = warp[:1]                       # (and one point of the next omega)
    cases = {"one point": top, "32 copies": np.repeat(top, 32, axis=0), "its warp": warp}
    gpu_settings = dataclasses.replace(settings, device="cuda")
    out = {}
    cpu_s, cpu_res, _ = timed(lambda: run_block(scene, top, p, settings), 1)
    steps = int(cpu_res.steps[0] + cpu_res.rejected[0])
    out["cpu core"] = {"seconds": cpu_s, "steps": steps}
    print(f"\nprobe: Fig. 14's costliest point {top[0, :2].tolist()}, tau 0..{p[P.T_END]:g}: one "
          f"CPU core {cpu_s:.3f} s, {steps} steps ({1e6 * cpu_s / steps:.2f} us a step)",
          flush=True)
    for label, pts in cases.items():
        seconds, res, _ = timed(lambda: run_block(scene, pts, p, gpu_settings), repeats)
        most = int((res.steps + res.rejected).max())
        out[label] = {"seconds": seconds, "most_steps": most}
        print(f"probe: GPU, {label:9s}: {seconds:.3f} s, most steps {most} "
              f"({1e6 * seconds / most:.2f} us a step, {seconds / cpu_s:.1f}x the core)",
              flush=True)
    return out


def spread(n: int, k: int) -> np.ndarray:
    """``k`` indices spread evenly over ``range(n)`` (the CPU's share keeps the cost mix)."""
    return np.unique(np.linspace(0, n - 1, min(k, n)).round().astype(int))


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--points", type=int, default=1048576, help="GPU points, anchors' scene")
    ap.add_argument("--cpu-points", type=int, default=4096, help="CPU points, anchors' scene")
    ap.add_argument("--fig14", type=int, default=65536, help="GPU points, Fig. 14's scene")
    ap.add_argument("--fig14-cpu", type=int, default=256,
                    help="CPU points, Fig. 14's scene (spread over the GPU's)")
    ap.add_argument("--tend", type=float, default=100.0, help="tau span of the anchors' scene")
    ap.add_argument("--fig14-tend", type=float, default=None,
                    help="tau span of Fig. 14's scene (default the spec's 100; the transient "
                         "is half of it): both sides' cost is linear in it, so a shorter "
                         "span measures the same ratio in less time")
    ap.add_argument("--tpb", default="",
                    help="also time both scenes on the GPU at these threads per CUDA block "
                         "(comma-separated; engine.gpu.THREADS_PER_BLOCK)")
    ap.add_argument("--regs", default="",
                    help="also time both scenes on the GPU with these caps on a thread's "
                         "registers (comma-separated; engine.gpu.MAX_REGISTERS; each "
                         "compiles the kernel again)")
    ap.add_argument("--probe", action="store_true",
                    help="Fig. 14's costliest point (W = 3, omega = 1000) alone, 32 copies of "
                         "it, and the 32 points of its warp, on the GPU; alone on a CPU core: "
                         "a GPU thread's speed against a core's, and what divergence costs")
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--only", choices=("anchors", "fig14"), default=None,
                    help="one of the two scenes")
    ap.add_argument("--smoke", action="store_true",
                    help="a few points on a short span (the CUDA simulator)")
    args = ap.parse_args()
    fig14_tend = args.fig14_tend
    if args.smoke:
        args.points, args.cpu_points, args.fig14, args.fig14_cpu = 64, 16, 9, 4
        args.tend, args.repeats, fig14_tend = 0.5, 1, 0.5

    from engine import gpu

    device = gpu.check_device()
    threads = cores()
    print(f"CPU: {cpu_model()}, {threads} cores; GPU: {device}; numba "
          f"{__import__('numba').__version__}", flush=True)
    print("\n| run | points | time | points/s | first call (compile) |\n"
          "| --- | --- | --- | --- | --- |", flush=True)
    report = {"cpu": cpu_model(), "cores": threads, "gpu": device}

    def measure(label, name, scene, p, points, settings, n_cpu):
        few = points[:min(len(points), 2 * threads)]
        t_gpu, g_out, w_gpu = timed(lambda: on_gpu(scene, p, points, settings), args.repeats,
                                    warm=lambda: on_gpu(scene, p, few, settings))
        print(row(f"{label}, engine on the GPU", len(points), t_gpu) + f" {w_gpu:.1f} s |",
              flush=True)
        share = spread(len(points), n_cpu)
        cpu_pts = points[share]
        t_cpu, c_out, w_cpu = timed(lambda: on_cpu(scene, p, cpu_pts, settings, threads), 1,
                                    warm=lambda: on_cpu(scene, p, few, settings, threads))
        print(row(f"{label}, engine on {threads} CPU cores", len(cpu_pts), t_cpu)
              + f" {w_cpu:.1f} s |", flush=True)
        gpu_pps, cpu_pps = len(points) / t_gpu, len(cpu_pts) / t_cpu
        report[name] = {"gpu_points": len(points), "gpu_s": t_gpu, "gpu_pps": gpu_pps,
                        "gpu_first_s": w_gpu, "cpu_points": len(cpu_pts), "cpu_s": t_cpu,
                        "cpu_pps": cpu_pps, "ratio": gpu_pps / cpu_pps,
                        "agreement": agreement(c_out, {k: v[share] for k, v in g_out.items()},
                                               len(cpu_pts))}

    hand = None
    if args.only in (None, "anchors"):
        measure("anchors scene", "anchors", *anchors_case(args.points, args.tend),
                args.cpu_points)
        hand = hand_kernel(args.points, args.tend)
        report["anchors"]["hand"] = hand
        if hand and "points_per_s" in hand:
            print(row("anchors scene, hand kernel (anchor_cuda.py)", args.points,
                      hand["seconds"]) + " - |", flush=True)
        report["anchors"]["variants"] = launch_variants(
            "anchors scene", anchors_case(args.points, args.tend), args)
    if args.only in (None, "fig14"):
        scene, p, points, settings = fig14_case(args.fig14, fig14_tend)
        measure(f"Fig. 14 scene ({scene.integrator})", "fig14", scene, p, points, settings,
                args.fig14_cpu)
        report["fig14"]["variants"] = launch_variants(
            "Fig. 14 scene", (scene, p, points, settings), args)
    if args.probe:   # (after the Fig. 14 rows: their first call is the compilation)
        report["probe"] = probe(fig14_tend, args.repeats)

    shown = [k for k in ("anchors", "fig14") if k in report]
    print(f"\nGPU / {threads} CPU cores: "
          + ", ".join(f"{k} {report[k]['ratio']:.3g}x" for k in shown), flush=True)
    if hand and "points_per_s" in hand:
        print(f"engine / hand kernel on the GPU: "
              f"{report['anchors']['gpu_pps'] / hand['points_per_s']:.2f}", flush=True)
    for name in shown:
        worst = max(report[name]["agreement"].values())
        print(f"{name}: largest difference GPU vs CPU, relative to the output's scale, "
              f"{worst:.1e} "
              f"({report[name]['agreement']})", flush=True)
    print(json.dumps(report), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
