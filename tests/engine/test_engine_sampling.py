"""Sampling at requested instants from the dense output, without stopping there
(``Problem.sampling``; ``engine.api.simulate(record_dt=...)``).

Checked against the independent scipy DOP853 reference (rtol 1e-12, restarted at every
switch and kink, tests/engine/reference.py) *stopped* at the same instants, for each
method; and sampling must leave the trajectory itself untouched (same steps, same end
state, bit for bit), since its whole point is not to shorten steps.
"""
import numpy as np
import pytest

from engine import params as P
from engine.api import simulate
from engine.settings import Settings
from tests.engine import reference as R
from tests.engine.common import scene

T_END, DT, T_FROM = 3.0, 0.1, 0.5
# method -> settings, max error of the sampled states (z in units of fc / sigma0). dopri5
# and rodas4 carry a 4th-order continuous extension, rk4 a 3rd-order one; rk4's fixed steps
# do not locate the |u| = 0 kinks the sine dither puts in every period, which costs it
# accuracy (measured 2.0e-5 at h = 8e-4), hence its wider bound.
METHODS = {
    "dopri5": (Settings(rtol=1e-10, atol=1e-12), 1e-7),
    "rodas4": (Settings(rtol=1e-10, atol=1e-12), 1e-6),
    "rk4": (Settings(h=1e-3, steps_per_period=256), 1e-4),   # sine: h = 2 pi / (30 * 256)
}
# the output of test_engine_vs_scipy's undithered LuGre scene: the plain DP5 kernel below is
# its kernel (one compilation in a CI run for both; the sampled kernels are this module's)
OUTS = ("F_mean",)
CASES = [  # dither, parameters: stick-slip without dither (|u| = 0 kinks), and a sine
    ("none", {"v_ref": 0.4}),
    ("sine-velocity", {"v_ref": 0.4, "W": 0.3, "omega": 30.0}),
]


@pytest.mark.long
@pytest.mark.parametrize("method", sorted(METHODS))
@pytest.mark.parametrize("dither,kw", CASES, ids=[c[0] for c in CASES])
def test_samples_match_reference_at_instants(method, dither, kw):
    settings, tol = METHODS[method]
    p = P.pack(t_end=T_END, **kw)
    sc = scene("lugre", dither, integrator=method, outputs=OUTS)
    r = simulate(sc, p, settings, record_dt=DT, record_from=T_FROM)
    assert r.status == 0
    k = np.arange(np.ceil(T_FROM / DT), np.floor(T_END / DT) + 1)
    np.testing.assert_array_equal(r.t, k * DT)          # the instants, computed from k
    _, ref = R.slider(P.unpack(p), "lugre", dither, (0.0, 0.0, 0.0), T_END, stops=r.t)
    err = np.abs(r.y[:, :3] - ref[:, :3]) * [1.0, 1.0, p[P.SIGMA0]]
    assert err.max() < tol, (method, dither, err.max())


@pytest.mark.long
@pytest.mark.parametrize("method", sorted(METHODS))
def test_sampling_does_not_touch_the_trajectory(method):
    settings, _ = METHODS[method]
    p = P.pack(t_end=T_END, v_ref=0.4)
    sc = scene("lugre", "none", integrator=method, outputs=OUTS)
    plain = simulate(sc, p, settings)
    sampled = simulate(sc, p, settings, record_dt=0.0123)
    assert (sampled.steps, sampled.rejected, sampled.evals) == \
        (plain.steps, plain.rejected, plain.evals)
    np.testing.assert_array_equal(sampled.y_end, plain.y_end)
    assert sampled.t[0] == 0.0 and len(sampled.t) == int(T_END // 0.0123) + 1


def test_record_dt_must_be_positive():
    with pytest.raises(ValueError, match="record_dt must be > 0"):
        simulate(scene("lugre", "none", outputs=OUTS), P.pack(t_end=1.0), record_dt=0.0)


def test_instant_at_t_end_is_kept_despite_rounding_and_bad_dt_samples_nothing():
    """3 * 0.1 = 0.30000000000000004 > t_end = 0.3: the instant still falls on the last step
    end. A non-positive spacing in cfg (only reachable below the API) samples nothing and
    must not hang."""
    from engine.integrators.problem import CTR_NREC, CTR_SIZE
    from engine.kernels import make_config, point_kernel

    sc = scene("lugre", "none", outputs=OUTS)
    r = simulate(sc, P.pack(t_end=0.3, v_ref=0.4), record_dt=0.1)
    assert len(r.t) == 4 and r.t[-1] == 3 * 0.1
    np.testing.assert_array_equal(r.y[-1], r.y_end)
    pk = point_kernel(sc, sampled_record=True)
    for dt in (0.0, -0.1):
        ctr, rec = np.zeros(CTR_SIZE, np.int64), np.empty((10, pk.n + 1))
        status = pk.run_point(P.pack(t_end=0.3, v_ref=0.4), make_config(Settings(), 1, dt),
                              pk.alloc(), np.empty(pk.n), np.empty(pk.obs_size),
                              np.empty(len(pk.names)), ctr, rec)
        assert status == 0 and ctr[CTR_NREC] == 0
