"""The engine's hard cases: parameters, method, tolerance, step budget, and how they are run.

Every case is a variation of the Fig. 10 anchor scene (paper Sec. 5.1 parameters, LuGre
slider, v_ref = 0.4, square-velocity dither W = 0.4 at omega = 1000, tau in [0, t_end],
from rest; ../shared/anchors/README.md) with one parameter pushed to an extreme.
Parameters and the independent references (scipy Radau / DOP853 restarted at every
switching instant) come from ``references.json``, written by ``scripts/reference_engine.py``
(which states method, tolerances and the reference's own error ``self_error``).

Quantities of interest (anchors/README.md): ``q = [z(t_end), e(t_end), v(t_end), mean v,
p2p v]`` over the switching instants ``k pi / omega`` in ``[t_end / 2, t_end]``, taken from
the recorded steps (the driver stops exactly on every switch). Cases too long to record
(``record=False``) use the engine's own observables instead, ``q = [z, e, v at t_end,
v_mean, v_slow_p2p]`` over ``[0, t_end]`` (and are compared with their refined run only);
error units
``|q - q_ref| / [fc / sigma0, fc, v_ref, v_ref, |p2p_ref|]``, maximum over the five.

Tolerances: ``rtol`` and ``atol = 1e-2 rtol`` in natural units
(``Settings(atol_units="natural")``: per component ``e ~ fc``, ``v ~ max(v_ref, W)``,
``z ~ fc / sigma0``), so that ``z`` at sigma0 = 1e6 and ``v`` at v_ref = 1e-6 are
controlled relatively (test_atol_units.py shows what one absolute ``atol`` costs there).
The *refined run* takes ``rtol / REFINE``.
"""
from __future__ import annotations

import json
import pathlib
from dataclasses import dataclass, field

import numpy as np

from engine import params as P
from engine.api import simulate
from engine.scene import Scene
from engine.settings import Settings
from tests.engine import common
from tests.engine.common import ALL

HERE = pathlib.Path(__file__).parent
REFS = json.loads((HERE / "references.json").read_text())
FIG10 = REFS["fig10"]["params"]
REFINE = 100.0
OUTPUTS = ("v_mean", "v_slow_p2p", "F_mean")   # what the cases compare
MAX_RECORDS = 2_000_000   # rows of (t, e, v, z, Q): 80 MB


@dataclass(frozen=True)
class Case:
    """One hard case.

    ``budget`` bounds accepted + rejected steps (``Settings.max_steps``): about twice what
    the run took when the case was set up, so that a regression that multiplies the work
    fails the test (as status FAILED). ``tol`` bounds the disagreement with the refined
    run and, where ``references.json`` holds the case, with the scipy reference (error units).
    """

    name: str
    method: str
    rtol: float
    budget: int
    tol: float
    overrides: dict = field(default_factory=dict)   # cases without a scipy reference
    record: bool = True                             # False: q from the observables

    @property
    def params(self) -> dict:
        if self.name in REFS:
            return dict(REFS[self.name]["params"])
        return {**FIG10, **self.overrides}

    @property
    def reference(self) -> dict | None:
        return REFS.get(self.name) if self.record else None


@dataclass
class Run:
    status: int
    q: np.ndarray
    steps: int
    rejected: int
    evals: int
    z_max: float
    outputs: dict
    seconds: float = 0.0


def settings_for(rtol: float, max_steps: int, atol_units: str = "natural") -> Settings:
    """The cases' tolerances (module docstring)."""
    return Settings(rtol=rtol, atol=1e-2 * rtol, atol_units=atol_units,
                    max_steps=int(max_steps))


def error_units(q, q_ref, c) -> float:
    """max_i |q_i - q_ref_i| / scale_i (module docstring)."""
    scale = np.array([c["fc"] / c["sigma0"], c["fc"], c["v_ref"], c["v_ref"], abs(q_ref[4])])
    return float(np.max(np.abs(np.asarray(q) - np.asarray(q_ref)) / scale))


def scene_of(method: str) -> Scene:
    """The cases' Scene: the Fig. 10 slider (LuGre, square-velocity dither). DP5's keeps
    every output: it is the engine tests' scene (tests.engine.common.scene), one kernel
    for both. Under a square dither the observables add no stop, so the cases' steps and
    OUTPUTS are those of a scene with OUTPUTS alone. The Rosenbrock scene, which no engine
    test compiles, keeps OUTPUTS."""
    return common.scene(integrator=method, outputs=ALL if method == "dopri5" else OUTPUTS)


def run(c: dict, method: str, rtol: float, max_steps: int, record: bool = True,
        atol_units: str = "natural") -> Run:
    """One trajectory of the case parameters ``c``; q from the recorded switching instants."""
    import time

    scene = scene_of(method)
    settings = settings_for(rtol, max_steps, atol_units)
    t0 = time.perf_counter()
    sim = simulate(scene, P.pack(**c), settings, record=record,
                   max_records=min(int(max_steps) + 1, MAX_RECORDS) if record else 0)
    secs = time.perf_counter() - t0
    q = np.full(5, np.nan)
    z_max = np.nan
    e, vv, z = sim.y_end[:3]
    if sim.status == 0 and not record:
        q = np.array([z, e, vv, sim.outputs["v_mean"], sim.outputs["v_slow_p2p"]])
        z_max = abs(z)
    if sim.status == 0 and record and not sim.truncated and len(sim.t):
        hp = np.pi / c["omega"]
        k = np.round(sim.t / hp)
        at = (sim.t == k * hp) & (sim.t >= 0.5 * c["t_end"])   # exact: the driver's k * hp
        v = sim.y[at, 1]
        if v.size:
            q = np.array([z, e, vv, v.mean(), v.max() - v.min()])
        z_max = float(np.max(np.abs(sim.y[:, 2])))
    return Run(sim.status, q, sim.steps, sim.rejected, sim.evals, z_max, sim.outputs, secs)
