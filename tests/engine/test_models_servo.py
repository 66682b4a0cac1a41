"""The servo system (issue 35): a PID position loop with GMS friction hunts, and dither
quenches it. Its outputs are checked against the same quantities computed with numpy from
the recorded trajectory (dense output every 0.01), an independent reading of their
definitions (engine.systems.servo)."""
from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import trapezoid

from engine import Scene, Settings, registry, simulate

# long: trajectories at tight tolerances (minutes on 2 cores); CI runs them (.ci/run)
pytestmark = pytest.mark.long

OWN = {"k": [40.0, 100.0, 250.0], "alpha": [0.2, 0.3, 0.5], "C": 20.0}
OUTS = ("hunt_amplitude", "hunt_period", "steady_error", "stick_fraction")


def _servo(W, omega, record_dt=None):
    dither = "sine-velocity" if W else "none"
    p = registry.pack("gms", "servo", OWN, W=W, omega=omega, t_end=300.0, t_transient=100.0)
    scene = Scene.from_params(p, system="servo", friction="gms", dither=dither, outputs=OUTS,
                              sizes=registry.sizes_of("gms", "servo", OWN))
    r = simulate(scene, p, Settings(rtol=1e-8, atol=1e-11), record_dt=record_dt,
                 record_from=100.0)
    assert r.status == 0
    return r


@pytest.fixture(scope="module")
def hunting():
    """The undithered servo, its trajectory recorded every 0.01 (both tests: one kernel,
    one run). Sampling at instants takes no steps of its own (its steps, evaluations and
    end state are the plain run's, tests/engine/test_engine_sampling.py), and the second
    test compares outputs by factors of 1e3."""
    return _servo(0.0, 0.0, record_dt=0.01)


def test_without_dither_the_servo_hunts_and_its_outputs_read_the_trajectory(hunting):
    r = hunting
    e = 1.0 - r.y[:, 0]                     # x_ref = 1, v_ref = 0
    t = r.t
    amp = 0.5 * (e.max() - e.min())
    assert amp > 0.1                        # a limit cycle, not a settled error
    assert r.outputs["hunt_amplitude"] == pytest.approx(amp, rel=1e-3)
    band = 1e-3                             # Servo.params["hunt_band"]
    ups, armed = [], e[0] < -band
    for i in range(1, len(e)):
        if e[i] < -band:
            armed = True
        elif armed and e[i] > band:
            ups.append(t[i - 1] + (band - e[i - 1]) / (e[i] - e[i - 1]) * (t[i] - t[i - 1]))
            armed = False
    assert len(ups) >= 3
    assert r.outputs["hunt_period"] == pytest.approx((ups[-1] - ups[0]) / (len(ups) - 1),
                                                     rel=1e-3)
    rms = np.sqrt(trapezoid(e * e, t) / (t[-1] - t[0]))
    assert r.outputs["steady_error"] == pytest.approx(rms, rel=1e-3)


def test_dither_quenches_the_hunting(hunting):
    hunting = hunting.outputs
    quenched = _servo(0.8, 30.0).outputs
    assert quenched["hunt_amplitude"] < 1e-3 * hunting["hunt_amplitude"]
    assert quenched["steady_error"] < 1e-3 * hunting["steady_error"]
    assert quenched["hunt_period"] == 0.0   # no crossing of the band: no hunting
