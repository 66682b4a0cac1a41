"""The scene variants the GPU target must run (issue 36): every built-in law, system, dither
and GPU-capable method at least once, the effect flags off, a vector-parameter law and a
brought model (docs/examples/mylab). Each case is a few points on a short tau, so the CUDA
simulator (tests/engine/test_gpu.py) and the PTX compile check (scripts/gpu_check.py) can
run them all. Compiling a scene's CPU kernels is what a case costs (~15-45 s on 2 cores),
so a case takes another test's scene wherever it can (one compilation in a CI run for both):
the cases with every observable are test_engine_vs_scipy's scenes (tests.engine.common;
:data:`SHARED`), the GMS, Dahl and servo cases test_models_reference's and
test_models_servo's (the Dahl case its undithered ``dahl-a2``, the only case without
dither), the LuGre case without Stribeck effect or bristle damping the LuGre side of its
Dahl identity (the viscous term off: the contact case); the others ask for few outputs.
``scripts/compile_costs.py --scenes`` lists which module compiles which scene.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from engine import Scene, Settings, registry
from engine.outputs import SIMULATE
from tests.engine.common import scene as common_scene

ROOT = Path(__file__).resolve().parents[2]
MYLAB = ROOT / "docs" / "examples" / "mylab"
ALL = tuple(SIMULATE)
FEW = ("v_mean", "F_mean")
GMS = {"k": [40.0, 100.0, 250.0], "alpha": [0.2, 0.3, 0.5], "C": 20.0}
SERVO_OUTS = ("hunt_amplitude", "hunt_period", "steady_error", "stick_fraction")
SLIDER_POINTS = [[0.3, 200.0, 0.4, 0.1], [0.0, 200.0, 0.2, 0.1], [0.5, 300.0, 0.05, 0.01]]
SLOW = {"slow_a": 1.7, "slow_omega": 0.3}   # the Sec. 7 slow force (test_engine_vs_scipy)

# id: (friction, system, dither, integrator, own values, outputs, shared, points, t_end)
CASES = {
    "lugre-square-rk4": ("lugre", "slider", "square-velocity", "rk4", {}, ALL, {},
                         SLIDER_POINTS, 0.5),
    "lugre-square-dopri5": ("lugre", "slider", "square-velocity", "dopri5", {}, ALL, {},
                            SLIDER_POINTS, 0.5),
    "lugre-sine-velocity-dopri5": ("lugre", "slider", "sine-velocity", "dopri5", {}, ALL, {},
                                   SLIDER_POINTS, 0.5),
    "lugre-sine-force-rk4": ("lugre", "slider", "sine-force", "rk4", {}, FEW, {},
                             SLIDER_POINTS, 0.5),
    "lugre-sine-velocity-dopri5-no-effects": ("lugre", "slider", "sine-velocity", "dopri5",
                                              {}, ("v_mean", "F_mean", "v_slow_p2p",
                                                   "stick_fraction"),
                                              {"sigma1": 0.0, "fs": 1.0}, SLIDER_POINTS, 2.0),
    "elastoplastic-square-slow-dopri5": ("elastoplastic", "slider", "square-velocity",
                                         "dopri5", {}, ALL, SLOW, SLIDER_POINTS, 0.5),
    "stribeck-sine-force-dopri5": ("stribeck", "slider", "sine-force", "dopri5", {}, ALL, {},
                                   SLIDER_POINTS, 0.5),
    "coulomb-square-rk4": ("coulomb", "slider", "square-velocity", "rk4", {},
                           ("v_mean", "stick_fraction"), {}, SLIDER_POINTS, 0.5),
    "dahl-none-dopri5": ("dahl", "slider", "none", "dopri5", {"dahl_alpha": 2.0},
                         ("v_mean", "F_mean"), {"sigma1": 0.0}, SLIDER_POINTS, 0.5),
    "gms-sine-velocity-dopri5": ("gms", "slider", "sine-velocity", "dopri5", GMS,
                                 ("v_mean", "F_mean"), {"sigma1": 0.0}, SLIDER_POINTS, 0.5),
    "gms-servo-sine-velocity-dopri5": ("gms", "servo", "sine-velocity", "dopri5", GMS,
                                       SERVO_OUTS, {},
                                       [[0.3, 200.0, 0.4, 0.1], [0.0, 200.0, 0.4, 0.1]], 2.0),
    "lugre-contact-sine-velocity-dopri5": ("lugre", "contact", "sine-velocity", "dopri5", {},
                                           ("v_mean", "F_mean"), {},
                                           [[0.001, 100.0, 0.001, 0.001],
                                            [0.002, 1000.0, 0.001, 0.001]], 0.05),
    "brought-gms-sine-velocity-rk4": (f"{MYLAB / 'laws.py'}:MaxwellSlip", "slider",
                                      "sine-velocity", "rk4", GMS, ("v_mean", "F_mean"),
                                      {"sigma1": 0.0}, SLIDER_POINTS, 0.5),
}


# case -> tests.engine.common.scene's arguments: test_engine_vs_scipy's scenes (runtime
# Stribeck exponents, every observable)
SHARED = {"lugre-square-rk4": {"integrator": "rk4"}, "lugre-square-dopri5": {},
          "lugre-sine-velocity-dopri5": {"dither": "sine-velocity"},
          "elastoplastic-square-slow-dopri5": {"friction": "elastoplastic", "slow": True},
          "stribeck-sine-force-dopri5": {"friction": "stribeck", "dither": "sine-force"}}


def build(case_id: str):
    """``(scene, p, points, settings)`` of one case (standard-level tolerances)."""
    friction, system, dither, integrator, own, outputs, shared, points, t_end = CASES[case_id]
    p = registry.pack(friction, system, own, t_end=t_end, t_transient=0.2 * t_end, **shared)
    if case_id in SHARED:   # the engine tests' scene (its kernels compiled once for both)
        scene = common_scene(**SHARED[case_id])
    else:
        scene = Scene.from_params(p, system=system, friction=friction, dither=dither,
                                  integrator=integrator, outputs=outputs,
                                  sizes=registry.sizes_of(friction, system, own))
    return scene, p, np.array(points, dtype=np.float64), Settings(rtol=1e-6, atol=1e-9)
