"""Engine benchmark: speed of the numba engine as ratios to compiled C and to scipy.

Run: ``.venv/bin/python scripts/bench_engine.py [--repeats N] [--no-scipy] [--no-effects] [--no-stiff]``

The machine is shared and noisy, so absolute times (thread CPU time, median of repeats) are
only printed for context; what counts is the ratio to the C reference ``../shared/anchors/anchor.c``
(see its README) compiled here at run time (``gcc -O3 -march=native``, into the
gitignored ``scripts/_build/``) and timed in the same process through ctypes,
interleaved with the engine runs (paired A/B timing, median of repeats).

Scenes (anchors/README.md): ``fig10`` (LuGre slider, paper parameters, v_ref = 0.4,
square-velocity dither W = 0.4, omega = 1000, tau in [0, 100], from rest) and
``nodither`` (the same with W = 0). Quantities of interest
``q = [z(100), e(100), v(100), mean v, p2p v]``, the mean and peak-to-peak taken over
the switching instants ``k pi / omega`` in [50, 100]; error
``max_i |q_i - q_ref_i| / scale_i`` with ``scale = [fc/sigma0, fc, v_ref, v_ref, |p2p_ref|]``;
``q_ref`` is read from the README's table (RK4, 2048 steps per half-period, checked
against adaptive DP5 at rtol 1e-14).

Tables printed:

1. per scene, accuracy (1e-4, 1e-7) and method: the cheapest setting reaching the
   accuracy, its error, median time, steps, RHS evaluations, ns per evaluation, and
   the ratio to C (same algorithm, its own cheapest setting, same run);
2. the ratio to scipy ``solve_ivp`` (DOP853 at rtol 1e-10 and RK45, run once with a
   time cap; a capped run gives a lower bound ``>=``);
3. "only the effects a scene calls for": cost per trajectory with each effect or
   observable switched on against the plain scene (kernel specialisation flags).
"""
from __future__ import annotations

import argparse
import ctypes
import math
import os
import pathlib
import subprocess
import sys
import time

import numpy as np

ROOT = pathlib.Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

ANCHOR_DIR = ROOT.parent / "shared" / "anchors"   # beside the checkout, never copied in
BUILD = ROOT / "scripts" / "_build"

# anchors/README.md: paper parameters of both scenes
SIGMA0, FC, V_REF, OMEGA, T_END, T_WIN = 100.0, 1.0, 0.4, 1000.0, 100.0, 50.0
SCENES = {"fig10": 0.4, "nodither": 0.0}          # scene -> W
ACCURACIES = (1e-4, 1e-7)
C_METHOD = {"rk4": 0, "dp5": 1, "rhs": 2, "dp5dense": 3}
C_FLAGS = ("-O3", "-march=native")   # gcc's default -ffp-contract=fast: FMA where it pays


# --------------------------------------------------------------------------- reference
def read_references(readme: pathlib.Path = ANCHOR_DIR / "README.md") -> dict[str, np.ndarray]:
    """q_ref per scene, parsed from the converged-reference table of anchors/README.md."""
    refs = {}
    for line in readme.read_text().splitlines():
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        if len(cells) == 6 and cells[0] in SCENES:
            refs[cells[0]] = np.array([float(c) for c in cells[1:]])
    missing = set(SCENES) - set(refs)
    if missing:
        raise RuntimeError(f"{readme}: no reference row for {sorted(missing)}")
    return refs


def qoi_error(q, q_ref) -> float:
    """anchors/README.md error: max_i |q_i - q_ref_i| / scale_i."""
    scale = np.array([FC / SIGMA0, FC, V_REF, V_REF, abs(q_ref[4])])
    return float(np.max(np.abs(np.asarray(q) - q_ref) / scale))


# --------------------------------------------------------------------------- C anchor
class Anchor:
    """anchor.c compiled at run time; ``run`` calls ``anchor_run`` through ctypes."""

    def __init__(self):
        BUILD.mkdir(parents=True, exist_ok=True)
        src = ANCHOR_DIR / "anchor.c"
        lib = BUILD / "libanchor.so"
        self.cmd = ["gcc", *C_FLAGS, "-DANCHOR_LIB", "-shared", "-fPIC",
                    "-o", str(lib), str(src), "-lm"]
        if not lib.exists() or lib.stat().st_mtime < src.stat().st_mtime:
            subprocess.run(self.cmd, check=True)
        self.lib = ctypes.CDLL(str(lib))
        self.lib.anchor_run.argtypes = [ctypes.c_int, ctypes.c_double, ctypes.c_double,
                                        ctypes.c_double, ctypes.c_double,
                                        ctypes.POINTER(ctypes.c_double)]
        self.lib.anchor_run.restype = None
        self.out = np.zeros(8)
        self._ptr = self.out.ctypes.data_as(ctypes.POINTER(ctypes.c_double))

    def run(self, method: str, W: float, arg: float):
        """One C trajectory: (q, steps, evals, rejected)."""
        self.lib.anchor_run(C_METHOD[method], W, V_REF, OMEGA, float(arg), self._ptr)
        o = self.out
        return o[:5].copy(), int(o[5]), int(o[6]), int(o[7])


def print_machine(anchor: Anchor) -> None:
    """The CPU and both compilers with their flags: ratios differ between CPUs."""
    import llvmlite.binding as llvm
    import numba
    model = next((line.split(":", 1)[1].strip() for line in
                  pathlib.Path("/proc/cpuinfo").read_text().splitlines()
                  if line.startswith("model name")), "unknown CPU")
    gcc = subprocess.run(["gcc", "--version"], capture_output=True, text=True).stdout
    print(f"CPU: {model} ({len(os.sched_getaffinity(0))} cores usable)")
    print(f"C: {gcc.splitlines()[0]}; flags {' '.join(C_FLAGS)} (anchor.c, as the README's)")
    print(f"numba {numba.__version__} (LLVM {'.'.join(map(str, llvm.llvm_version_info))}), "
          f"target {llvm.get_host_cpu_name()}; njit(error_model='numpy'); DP5 stage sums "
          "with fastmath={'contract'} (FMA), everything else strict IEEE")


# --------------------------------------------------------------------------- timing
def paired_medians(fns, repeats: int) -> list[float]:
    """Median CPU time of the calling thread for each callable, the calls interleaved
    round-robin (numba and the ctypes call into C both run in this thread; thread CPU time
    is what the shared, oversubscribed machine distorts least)."""
    times = [[] for _ in fns]
    for _ in range(repeats):
        for i, fn in enumerate(fns):
            t0 = time.thread_time()
            fn()
            times[i].append(time.thread_time() - t0)
    return [float(np.median(t)) for t in times]


def cheapest(run, settings, q_ref, accuracy):
    """First setting (ordered cheap -> expensive) whose error <= accuracy.

    ``run(setting) -> (q, steps, evals, rejected)``; returns (setting, result, error)
    or None when no setting reaches the accuracy.
    """
    for s in settings:
        res = run(s)
        err = qoi_error(res[0], q_ref)
        if err <= accuracy:
            return s, res, err
    return None


# --------------------------------------------------------------------------- engine
def engine_params(W: float):
    """Parameter vector of an anchor scene (paper set, from rest, no transient window)."""
    from engine import params as P
    return P.pack(v_ref=V_REF, W=W, omega=OMEGA, t_end=T_END, t_transient=0.0)


def _qoi_accumulate(t, v, obs):
    """Add the sample v(t) to the anchor's mean / extremes when t is in the window."""
    if t >= T_WIN:
        obs[0] += v
        obs[1] += 1.0
        obs[2] = min(obs[2], v)
        obs[3] = max(obs[3], v)


def qoi_observer(sampled: bool):
    """An engine Observer for the anchor's QoI ``q = [z, e, v, mean v, p2p v]`` (the mean
    and peak-to-peak over the switching instants ``k pi / omega`` in [T_WIN, T_END]; the
    engine's own observables average over time, not over instants).

    ``sampled=False``: v is taken at the driver's stops (the scene stops at every switch).
    ``sampled=True``: the stop hook does nothing; ``sample`` (returned too) is the
    integrator's dense-output sampling hook, called at the instants without stopping.
    """
    from numba import njit

    from engine.observables import Observer
    from engine.systems.slider import E, V, Z
    accumulate = njit(_qoi_accumulate)

    @njit
    def init(obs):
        obs[0], obs[1], obs[2], obs[3] = 0.0, 0.0, np.inf, -np.inf

    @njit
    def start(t, y, p, sq, obs):
        pass

    @njit
    def observe(t0, y0, t1, y1, ymid, p, sq, obs):
        pass

    @njit
    def stop(t, y, p, is_period, obs):
        if not sampled:
            accumulate(t, y[V], obs)

    @njit
    def sample(t, y, p, sq, obs, ctr, rec):
        accumulate(t, y[V], obs)

    @njit
    def finish(t, y, p, obs, out):
        out[0], out[1], out[2] = y[Z], y[E], y[V]
        out[3] = obs[0] / obs[1]
        out[4] = obs[3] - obs[2]

    names = ("z", "e", "v", "v_mean_switch", "v_p2p_switch")
    return Observer(4, names, False, False, False, init, start, observe, stop, finish), sample


class EngineQoI:
    """One compiled engine trajectory per method with the QoI observer above, built from the
    engine's own pieces (systems, integrator METHODS, shared driver).

    ``dense=False``: the square-wave scene (W = 0 for "nodither"), stopping at every switch
    as the anchor's rk4/dp5 do. ``dense=True`` (adaptive methods, "nodither" only): the
    scene without dither -- no stops at all -- and v sampled at the switching instants
    from the dense output (``Problem.sampling``), as the anchor's dp5dense does.
    """

    def __init__(self, method: str, dense: bool = False, kinks: bool = True):
        from numba import njit

        from engine import params as P
        from engine import status as S
        from engine.integrators import METHODS
        from engine.integrators.driver import make_solve
        from engine.integrators.problem import CTR_SIZE, Problem
        from engine.scene import Scene
        from engine.systems import make_system

        # as a sweep builds it: effects and exponents folded from the parameters
        scene = Scene.from_params(engine_params(0.4), integrator=method,
                                  dither="none" if dense else "square-velocity")
        system = make_system(scene)
        obs, sample = qoi_observer(sampled=dense)
        problem = Problem(n=system.n, n_err=system.n_err, rhs=system.rhs,
                          n_events=system.n_events if kinks else 0, events=system.events,
                          observe=obs.observe, record=False, needs_mid=False,
                          sampling=dense, sample=sample)
        stepper = METHODS[method].make_stepper(problem)
        solve = make_solve(stepper, obs, scene.dither)
        init, obs_init, finish, n = system.init, obs.init, obs.finish, system.n
        i_end = P.T_END

        @njit
        def run(p, cfg, work, y, o, out, ctr, rec):
            init(p, y)
            obs_init(o)
            ctr[:] = 0
            st = solve(work, y, p, cfg[0], o, ctr, rec)
            finish(p[i_end], y, p, o, out)
            return st

        self.method, self.dense, self.run_jit, self.ok = method, dense, run, S.OK
        self.label = method + (" dense" if dense else "") + ("" if kinks else " nokink")
        self.work = stepper.alloc()
        self.y, self.o, self.out = np.empty(n), np.empty(4), np.empty(5)
        self.ctr = np.zeros(CTR_SIZE, np.int64)
        self.rec = np.empty((0, n + 1))
        self.adaptive = METHODS[method].ADAPTIVE

    def cfg(self, setting):
        from engine.kernels import make_config
        from engine.settings import Settings
        if self.adaptive:
            cfg = make_config(Settings(rtol=setting, atol=1e-2 * setting))
        else:
            cfg = make_config(Settings(steps_per_period=int(setting)))
        if self.dense:
            cfg["sample_dt"], cfg["sample_t0"] = math.pi / OMEGA, T_WIN
        return cfg

    def runner(self, W, setting):
        """Zero-argument callable running one trajectory (for the timing loop)."""
        p, cfg = engine_params(W), self.cfg(setting)
        args = (p, cfg, self.work, self.y, self.o, self.out, self.ctr, self.rec)
        return lambda: self.run_jit(*args)

    def run(self, W, setting):
        """(q, steps, evals, rejected) of one trajectory; q is NaN when the status is not OK."""
        st = self.runner(W, setting)()
        q = self.out.copy() if st == self.ok else np.full(5, np.nan)
        return q, int(self.ctr[0]), int(self.ctr[2]), int(self.ctr[1])


# --------------------------------------------------------------------------- table 1
RK4_N = (1, 2, 3, 4, 6, 8, 12, 16, 24, 32, 48, 64, 96, 128)
RTOLS = tuple(10.0 ** (-k / 2) for k in range(6, 27))          # 1e-3 ... 1e-13
C_OF = {"rk4": "rk4", "dopri5": "dp5", "dopri5 dense": "dp5dense"}   # same algorithm in C
DENSE_SCENES = ("nodither",)        # scenes where the engine also runs without stops
C_ONLY = ("dp5dense",)                                           # C's no-stop variant


def settings_for(method: str):
    return RK4_N if method in ("rk4",) else RTOLS


def fmt_setting(method: str, s) -> str:
    return f"N={int(s)}" if method == "rk4" else f"rtol={s:.0e}"


def c_cheapest(anchor: Anchor, W: float, q_ref, acc: float) -> dict:
    """C method -> (setting, result, error) of its cheapest setting reaching ``acc``."""
    out = {}
    for cm in ("rk4", "dp5") + C_ONLY:
        hit = cheapest(lambda s, cm=cm: anchor.run(cm, W, s), RK4_N if cm == "rk4" else RTOLS,
                       q_ref, acc)
        if hit is not None:
            out[cm] = hit
    return out


def speed_row(scene, acc, m, hit, t, ratio=None, ratio_same=None, vs_best=None,
              c_evals=None):
    _, steps, evals, _ = hit[1]
    kind = "rk4" if "rk4" in m.split() else "adaptive"   # "rk4", "rk4 nokink", "C rk4"
    return {"scene": scene, "acc": acc, "method": m, "setting": fmt_setting(kind, hit[0]),
            "error": hit[2], "t": t, "steps": steps, "evals": evals, "ns": 1e9 * t / evals,
            "ratio": ratio, "ratio_same": ratio_same, "vs_best": vs_best,
            "per_eval": ratio * c_evals / evals if ratio and c_evals else None}


def table_speed(anchor: Anchor, methods, refs, repeats: int, nokink: bool = False):
    """Table 1: cheapest setting per (scene, accuracy, method), timed paired with C.

    ``ratio`` = engine / C of the same algorithm, each at its own cheapest setting;
    ``ratio_same`` = engine / C at the engine's setting (same steps: implementation cost).
    ``nokink`` adds each method without kink landing (``nokink``: no event functions,
    like the C anchor, which lands on the square wave's switches only): the engine's
    driver against C doing the same work.
    """
    engines = [EngineQoI(m) for m in methods]
    engines += [EngineQoI(e.method, dense=True) for e in engines if e.adaptive]
    engines += [EngineQoI(m, kinks=False) for m in methods] if nokink else []
    for eng in engines:                                # compile outside the timings
        eng.run(0.4, settings_for(eng.method)[0])
    rows = []
    for scene, W in SCENES.items():
        for acc in ACCURACIES:
            c_hits = c_cheapest(anchor, W, refs[scene], acc)
            c_fns = {cm: (lambda cm=cm, s=h[0], W=W: anchor.run(cm, W, s))
                     for cm, h in c_hits.items()}
            for eng in engines:
                if eng.dense and scene not in DENSE_SCENES:
                    continue
                m = eng.label
                hit = cheapest(lambda s, eng=eng, W=W: eng.run(W, s), settings_for(eng.method),
                               refs[scene], acc)
                if hit is None:
                    rows.append({"scene": scene, "acc": acc, "method": m,
                                 "setting": "not reached"})
                    continue
                fns = [eng.runner(W, hit[0])] + list(c_fns.values())
                same = C_OF.get(m.removesuffix(" nokink"))
                if same:
                    fns.append(lambda s=hit[0], cm=same, W=W: anchor.run(cm, W, s))
                times = paired_medians(fns, repeats)
                t_c = dict(zip(c_fns, times[1:1 + len(c_fns)]))
                rows.append(speed_row(
                    scene, acc, m, hit, times[0],
                    ratio=times[0] / t_c[same] if same in t_c else None,
                    ratio_same=times[0] / times[-1] if same else None,
                    vs_best=times[0] / min(t_c.values()) if t_c else None,
                    c_evals=c_hits[same][1][2] if same in c_hits else None))
            for cm, hit in c_hits.items():
                rows.append(speed_row(scene, acc, "C " + cm, hit,
                                      paired_medians([c_fns[cm]], repeats)[0]))
    return rows


def print_speed(rows):
    print("\nTable 1 -- engine vs the C anchor, same process (error: anchors/README.md; "
          "time: median of paired repeats)")
    print("  ratio C = engine / C same algorithm, each at its cheapest setting; per eval = the "
          "same per right-hand-side evaluation (ns/eval over C's ns/eval; kink landings add "
          "evaluations C does not make); same-N = at the engine's setting (same steps); "
          "vs best = engine / cheapest C of any algorithm")
    hdr = (f"{'scene':9s} {'acc':>6s} {'method':14s} {'setting':11s} {'error':>9s} "
           f"{'time ms':>9s} {'steps':>9s} {'evals':>10s} {'ns/eval':>8s} {'ratio C':>8s} "
           f"{'per eval':>8s} {'same-N':>7s} {'vs best':>8s}")
    print(hdr)
    print("-" * len(hdr))
    x = lambda v: f"{v:.2f}x" if v else "-"
    for r in rows:
        if "error" not in r:
            print(f"{r['scene']:9s} {r['acc']:6.0e} {r['method']:14s} {r['setting']}")
            continue
        print(f"{r['scene']:9s} {r['acc']:6.0e} {r['method']:14s} {r['setting']:11s} "
              f"{r['error']:9.2e} {1e3 * r['t']:9.3f} {r['steps']:9d} {r['evals']:10d} "
              f"{r['ns']:8.1f} {x(r['ratio']):>8s} {x(r['per_eval']):>8s} "
              f"{x(r['ratio_same']):>7s} "
              f"{x(r['vs_best']):>8s}")


# --------------------------------------------------------------------------- table 2
class TimeCap(Exception):
    pass


def scipy_fig10(method: str, rtol: float, cap_s: float):
    """solve_ivp on fig10 the way a scipy user would: sign(sin) inside the RHS, no restarts,
    v sampled by dense output (t_eval) at the switching instants in [T_WIN, T_END].
    Returns (q or None, seconds, capped)."""
    from scipy.integrate import solve_ivp
    sig0, sig1, sig2, vs, vd, fc, fs, W = SIGMA0, 10.0, 0.004, 0.1, 0.1, FC, 1.5, 0.4
    deadline = time.perf_counter() + cap_s

    def rhs(t, y):
        if time.perf_counter() > deadline:
            raise TimeCap
        z, e, v = y
        u = v + (W if math.sin(OMEGA * t) >= 0.0 else -W)
        g = fc + (fs - fc) * math.exp(-(u / vs) ** 2)
        dz = u - sig0 * abs(u) * z / g
        F = sig0 * z + sig1 * math.exp(-(u / vd) ** 2) * dz + sig2 * u
        return [dz, V_REF - v, e - F]

    hp = math.pi / OMEGA
    k = np.arange(math.ceil(T_WIN / hp), math.floor(T_END / hp) + 1)
    t_eval = np.append(k * hp, T_END)
    t0 = time.thread_time()
    try:
        sol = solve_ivp(rhs, (0.0, T_END), [0.0, 0.0, 0.0], method=method, rtol=rtol,
                        atol=1e-2 * rtol, t_eval=t_eval)
    except TimeCap:
        return None, time.thread_time() - t0, True
    v = sol.y[2, :-1]
    q = np.array([sol.y[0, -1], sol.y[1, -1], sol.y[2, -1], v.mean(), v.max() - v.min()])
    return q, time.thread_time() - t0, False


def table_scipy(engine_t: float, engine_label: str, q_ref, cap_s: float):
    """Table 2: scipy solve_ivp on fig10 against the engine's cheapest 1e-4 trajectory."""
    print(f"\nTable 2 -- scipy solve_ivp on fig10 (run once, time cap {cap_s:.0f} s) vs the engine "
          f"({engine_label}, {1e3 * engine_t:.2f} ms)")
    print(f"{'method':8s} {'rtol':>7s} {'error':>10s} {'time s':>8s} {'engine speed-up':>16s}")
    for method, rtol in (("DOP853", 1e-10), ("RK45", 1e-10)):
        q, secs, capped = scipy_fig10(method, rtol, cap_s)
        err = "capped" if capped else f"{qoi_error(q, q_ref):.2e}"
        ge = ">=" if capped else ""
        print(f"{method:8s} {rtol:7.0e} {err:>10s} {ge + f'{secs:.1f}':>8s} "
              f"{ge + f'{secs / engine_t:,.0f}x':>16s}", flush=True)


# --------------------------------------------------------------------------- table 3
EFFECTS = (  # label, parameter overrides that remove the effect, scene changes when removed
    ("Stribeck (fs = fc)", {"fs": 1.0}, {}),
    ("bristle damping (sigma1 = 0)", {"sigma1": 0.0}, {}),
    ("viscous (sigma2 = 0)", {"sigma2": 0.0}, {}),
    ("slow force (A_s = 0)", {"slow_a": 0.0}, {}),
    ("dither (W = 0)", {"W": 0.0}, {"dither": "none"}),
)


def table_effects(repeats: int, n_steps: int = 4):
    """Table 3: cost per trajectory with and without each effect (engine.api.simulate, rk4
    with ``n_steps`` per half-period, so every row takes the same steps)."""
    from engine import params as P
    from engine.api import simulate
    from engine.outputs import SIMULATE
    from engine.scene import Scene
    from engine.settings import Settings

    st = Settings(steps_per_period=n_steps, h=(math.pi / OMEGA) / n_steps)
    full_p = P.pack(v_ref=V_REF, W=0.4, omega=OMEGA, t_end=T_END, slow_a=1.7, slow_omega=0.3)
    full = Scene.from_params(full_p, integrator="rk4")
    run = lambda sc, p: (lambda: simulate(sc, p, st))
    print(f"\nTable 3 -- only the effects a scene calls for (fig10 + slow force 1.7 sin(0.3 tau), "
          f"rk4 N={n_steps}, {T_END:.0f} tau; ms per trajectory, median of {repeats})")
    print(f"{'effect':32s} {'with':>8s} {'zero, compiled in':>18s} {'specialised':>12s} "
          f"{'saved':>7s}")
    for label, off, change in EFFECTS:
        p_off = full_p.copy()
        for k, v in off.items():
            p_off[P.INDEX[k]] = v
        lean = Scene.from_params(p_off, integrator="rk4", dither=change.get("dither", full.dither))
        fns = [run(full, full_p), run(full, p_off), run(lean, p_off)]
        for fn in fns:
            fn()
        t = paired_medians(fns, repeats)
        print(f"{label:32s} {1e3 * t[0]:8.2f} {1e3 * t[1]:18.2f} {1e3 * t[2]:12.2f} "
              f"{100 * (1 - t[2] / t[1]):6.0f}%", flush=True)
    rows = [("elasto-plastic phases vs LuGre", full.with_(friction="elastoplastic"), full)]
    rows += [(f"observable {o}", full.with_(outputs=(o,)), full) for o in SIMULATE]
    for label, with_, without in rows:
        fns = [run(with_, full_p), run(without, full_p)]
        for fn in fns:
            fn()
        t = paired_medians(fns, repeats)
        print(f"{label:32s} {1e3 * t[0]:8.2f} {'':>18s} {1e3 * t[1]:12.2f} "
              f"{100 * (1 - t[1] / t[0]):6.0f}%", flush=True)


# --------------------------------------------------------------------------- table 4
def table_stiff(rtols=(1e-4, 1e-6, 1e-8)):
    """Table 4: stiff contacts (fig10 with sigma0 = 1e4, 1e5, 1e6 over 5 tau) -- RODAS
    against explicit DP5: steps, evaluations, time, error and the bound max|z| sigma0 / fs <= 1.
    Reference: scipy Radau (tests/hard/references.json) where there is one, else RODAS at
    rtol 1e-11 (marked ``rodas4``)."""
    from tests.hard.hardcases import REFS, error_units, run

    print("\nTable 4 -- stiff contacts: fig10 with sigma0 = 1e4 / 1e5 / 1e6, 5 tau; error in "
          "anchor units vs the reference ('Radau': scipy rtol 1e-11 restarted at switches); "
          "time includes recording every step for the QoI")
    hdr = (f"{'sigma0':>7s} {'method':7s} {'rtol':>6s} {'status':>6s} {'steps':>8s} "
           f"{'rejected':>8s} {'evals':>9s} {'time s':>7s} {'error':>9s} {'ref':>6s} "
           f"{'max|z|s0/fs':>11s}")
    print(hdr)
    print("-" * len(hdr))
    base = REFS["sigma0_1e4"]["params"]
    for sigma0 in (1e4, 1e5, 1e6):
        name = f"sigma0_1e{round(math.log10(sigma0))}"
        c = {**base, "sigma0": sigma0}
        if name in REFS:
            q_ref, ref = np.array(REFS[name]["q"]), "Radau"
        else:
            q_ref, ref = run(c, "rodas4", 1e-11, 50_000_000).q, "rodas4"
        for method in ("rodas4", "dopri5"):
            run(c, method, 1e-3, 10)                        # compile outside the timing
            for rtol in rtols:
                r = run(c, method, rtol, 50_000_000)
                err = error_units(r.q, q_ref, c)
                print(f"{sigma0:7.0e} {method:7s} {rtol:6.0e} {r.status:6d} {r.steps:8d} "
                      f"{r.rejected:8d} {r.evals:9d} {r.seconds:7.3f} {err:9.2e} {ref:>6s} "
                      f"{r.z_max * sigma0 / c['fs']:11.6f}", flush=True)


# --------------------------------------------------------------------------- main
def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=7, help="timing repeats (median)")
    ap.add_argument("--methods", default="rk4,dopri5,rodas4", help="engine methods, comma-separated")
    ap.add_argument("--no-scipy", action="store_true", help="skip the scipy comparison")
    ap.add_argument("--scipy-cap", type=float, default=120.0, help="time cap per scipy run (s)")
    ap.add_argument("--no-effects", action="store_true", help="skip the effects table")
    ap.add_argument("--no-stiff", action="store_true", help="skip the stiff-contact table")
    ap.add_argument("--nokink", action="store_true",
                    help="also time each method without kink landing (as the C anchor)")
    args = ap.parse_args(argv)
    anchor = Anchor()
    print_machine(anchor)
    refs = read_references()
    rows = table_speed(anchor, args.methods.split(","), refs, args.repeats, args.nokink)
    print_speed(rows)
    if not args.no_scipy:
        eng = [r for r in rows if r["scene"] == "fig10" and r["acc"] == 1e-4 and "t" in r
               and not r["method"].startswith("C ") and "nokink" not in r["method"]]
        best = min(eng, key=lambda r: r["t"])
        table_scipy(best["t"], f"{best['method']} {best['setting']}", refs["fig10"], args.scipy_cap)
    if not args.no_effects:
        table_effects(args.repeats)
    if not args.no_stiff:
        table_stiff()


if __name__ == "__main__":
    main()
