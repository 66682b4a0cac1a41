"""Engine benchmark: speed of the numba engine as ratios to compiled C and to scipy.

Run: ``.venv/bin/python scripts/bench_engine.py [--quick] [--no-scipy] [--scipy-cap S]``

The machine is shared and noisy, so absolute times are only printed for context;
what counts is the ratio to the C reference ``/work/shared/anchors/anchor.c``
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
import pathlib
import re
import subprocess
import sys
import time

import numpy as np

ROOT = pathlib.Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

ANCHOR_DIR = pathlib.Path("/work/shared/anchors")
BUILD = ROOT / "scripts" / "_build"

# anchors/README.md: paper parameters of both scenes
SIGMA0, FC, V_REF, OMEGA, T_END, T_WIN = 100.0, 1.0, 0.4, 1000.0, 100.0, 50.0
SCENES = {"fig10": 0.4, "nodither": 0.0}          # scene -> W
ACCURACIES = (1e-4, 1e-7)
C_METHOD = {"rk4": 0, "dp5": 1, "rhs": 2, "dp5dense": 3}


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
        if not lib.exists() or lib.stat().st_mtime < src.stat().st_mtime:
            cmd = ["gcc", "-O3", "-march=native", "-DANCHOR_LIB", "-shared", "-fPIC",
                   "-o", str(lib), str(src), "-lm"]
            subprocess.run(cmd, check=True)
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


# --------------------------------------------------------------------------- timing
def paired_medians(fns, repeats: int) -> list[float]:
    """Median wall time of each callable, the calls interleaved round-robin."""
    times = [[] for _ in fns]
    for _ in range(repeats):
        for i, fn in enumerate(fns):
            t0 = time.perf_counter()
            fn()
            times[i].append(time.perf_counter() - t0)
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
