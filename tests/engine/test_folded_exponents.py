"""Stribeck exponents folded into the kernels (Scene.delta / delta_d, Eqs. 2.4-2.5).

The folded kernel compiles only the branch of ``stribeck.decay`` that ``p`` would take at run
time: the same expression, so RK4 (strict IEEE) gives the run-time kernel's numbers bit for
bit. DP5 compiles its stage sums with contraction (FMA, engine.integrators.dopri5); the
smaller folded right-hand side is inlined into them differently, which moves last bits
(measured with scripts/bit_identical.py --quick on specs/fig14.toml thinned to 10x10:
at most 6.5e-8 in F_mean, 3.5e-7 in alpha_hist). A parameter
vector that contradicts a folded exponent is refused, never integrated with the wrong law.
"""
import numpy as np
import pytest

from engine import params as P
from engine.api import simulate
from engine.blocks import run_block
from engine.scene import Scene
from engine.settings import Settings
from tests.engine.common import ALL

OUT = ("v_mean", "F_mean", "stick_fraction")   # compared; the scenes compile every output


@pytest.mark.parametrize("system, friction, dither, p", [
    ("slider", "lugre", "square-velocity",                                   # delta = 2
     P.pack(v_ref=0.4, W=0.4, omega=300.0, t_end=2.0, t_transient=0.5)),
    ("contact", "elastoplastic", "sine-velocity",                            # delta = 1
     P.pack(P.CONTACT_DEFAULTS, W=2e-3, omega=2e3, t_end=0.02, t_transient=0.005)),
])
@pytest.mark.long
@pytest.mark.parametrize("integrator", ["rk4", "dopri5"])
def test_folded_kernel_matches_the_run_time_one(system, friction, dither, p, integrator):
    # every output (tests/engine/common.py): the run-time LuGre kernels are those the
    # DOP853 comparison and the batch tests compile
    folded = Scene.from_params(p, system=system, friction=friction, dither=dither,
                               outputs=ALL, integrator=integrator)
    assert (folded.delta, folded.delta_d) == (p[P.DELTA], p[P.DELTA_D])
    generic = folded.with_(delta=None, delta_d=None)
    settings = Settings(rtol=1e-8, steps_per_period=16)
    a = simulate(folded, p, settings, record=True)
    b = simulate(generic, p, settings, record=True)
    assert a.status == b.status == 0 and a.steps > 10
    if integrator == "rk4":
        np.testing.assert_array_equal(a.y, b.y)
        np.testing.assert_array_equal([a.outputs[k] for k in OUT], [b.outputs[k] for k in OUT])
    else:   # last bits only (module docstring)
        np.testing.assert_allclose([a.outputs[k] for k in OUT], [b.outputs[k] for k in OUT],
                                   rtol=1e-9, atol=1e-12)


def test_an_exponent_other_than_1_or_2_stays_a_run_time_value():
    p = P.pack(delta=1.5)
    scene = Scene.from_params(p)
    assert scene.delta is None and scene.delta_d == 2.0
    with pytest.raises(ValueError, match="delta must be one of"):
        Scene(delta=1.5)


def test_contradicting_parameters_are_refused():
    scene = Scene.from_params(P.pack(), outputs=OUT)       # delta = 2 folded in
    p = P.pack(delta=1.0, t_end=0.1)
    with pytest.raises(ValueError, match=r"compiled for delta = 2\.0"):
        simulate(scene, p)
    with pytest.raises(ValueError, match=r"compiled for delta = 2\.0"):
        run_block(scene, np.array([[0.4, 300.0, 0.4, 0.1]]), p)
    # the analysis paths read the exponents from p: nothing is folded there
    assert Scene.from_params(P.pack(), path="averaged").delta is None
