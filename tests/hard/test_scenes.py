"""The stiff method on every scene kind (slow: one compilation per scene and method).

RODAS and DP5 are independent discretisations; at rtol 1e-9 every well-conditioned output
(``v_mean``, ``F_mean``, ``v_slow_p2p``) must agree when both finish, and neither may
return a number with a status other than OK (``FAILED`` is an honest answer). The phase
fractions are left out on purpose, and so is ``v_slow_p2p`` without dither (there it is the
peak-to-peak of ``v`` over the step ends, which depends on where each method puts its steps:
measured 1.3e-5 relative between the two at rtol 1e-9). For LuGre, stick means ``|u| < stick_band`` (a set the
trajectory crosses in an instant), and for the elasto-plastic law ``z`` approaches
``z_ss`` from below with ``alpha -> 1`` at zero slope, so ``alpha == 1`` (slip) is reached
only through rounding or overshoot (measured: DP5 gives slip 0.06 / 0.07 / 0.30 at rtol
1e-6 / 1e-8 / 1e-10 on the slider scene below, RODAS 0.29 / 0.30 / 0.30).
"""
from __future__ import annotations

import itertools

import numpy as np
import pytest

from engine import params as P
from engine import status as S
from engine.api import simulate
from engine.scene import Scene
from engine.settings import Settings

OUTPUTS = ("v_mean", "F_mean", "v_slow_p2p")
SETTINGS = Settings(rtol=1e-9, atol=1e-13, max_steps=2_000_000)
SLIDER = P.pack(v_ref=0.1, W=0.3, omega=50.0, t_end=20.0, slow_a=1.7, slow_omega=0.3,
                t_transient=5.0)
CONTACT = P.pack(P.CONTACT_DEFAULTS, W=1e-3, v_ref=1e-3, omega=10.0, t_end=2.0,
                 t_transient=0.5)


def _cases():
    for system, friction, dither in itertools.product(
            ("slider", "contact"), ("lugre", "elastoplastic", "stribeck"),
            ("none", "square-velocity", "sine-velocity", "sine-force")):
        if system == "contact" and dither == "sine-force":
            continue
        # contact + static law: z is unused and the quadratures of F and u carry the error
        # control (engine.systems.contact.error_size; was 6.5 % off on v_mean before)
        yield pytest.param(system, friction, dither, id=f"{system}-{friction}-{dither}")


@pytest.mark.slow
@pytest.mark.parametrize("system,friction,dither", list(_cases()))
def test_rodas4_agrees_with_dopri5(system, friction, dither):
    p = SLIDER if system == "slider" else CONTACT
    runs = {}
    for method in ("dopri5", "rodas4"):
        scene = Scene.from_params(p, system=system, friction=friction, dither=dither,
                                  integrator=method, outputs=OUTPUTS)
        runs[method] = simulate(scene, p, SETTINGS)
    for r in runs.values():
        assert r.status in (S.OK, S.FAILED), S.MEANINGS[r.status]
        if r.status != S.OK:
            assert all(np.isnan(v) for v in r.outputs.values())
    a, b = runs["dopri5"], runs["rodas4"]
    if a.status == b.status == S.OK:
        for name in OUTPUTS[:2] if dither == "none" else OUTPUTS:
            assert b.outputs[name] == pytest.approx(a.outputs[name], rel=1e-5, abs=1e-9), name
