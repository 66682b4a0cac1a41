"""Convergence of the integrators (STYLE.md "Convergence").

- Order: on a smooth slider problem (LuGre, u > 0 throughout, no kink) the log2-slope of the
  error against the step is within +-0.2 of the method's order (RK4: 4, DP5: 5). Fixed steps
  come from the stop grid: a square "dither" with W = 0 changes nothing in the equations but
  makes the driver stop every pi/omega, and a huge tolerance makes DP5 take one step per stop
  (plus a few shorter ones in the first interval from the starting-step rule).
  Reference: scipy DOP853 at rtol 1e-12 (tests/engine/reference.py).
- Fig. 10 kink: on the anchor scene (v_ref = 0.4, W = 0.4, omega = 1000, tau in [0, 100]),
  the DP5 error in the anchor's quantities of interest falls as rtol falls. Reference
  values: ../shared/anchors/README.md table ("Converged references (RK4 with 2048 steps
  per half-period, checked against an adaptive DP5 at rtol 1e-14)"), same error measure.
"""
import numpy as np
import pytest

from engine import params as P
from engine.api import simulate
from engine.settings import Settings
from tests.engine import reference as R
from tests.engine.common import scene

# smooth, non-stiff variant of the slider: sigma0 = 10, sigma1_hat = 1, sliding at v ~ 1
T_END, V_REF, SIGMA0, SIGMA1, KICK = 10.0, 1.0, 10.0, 1.0, 0.3


def _smooth_problem():
    zss = R.g(V_REF, P.PAPER_DEFAULTS) / SIGMA0   # z_ss = g(v) sgn(v) / sigma0, v > 0
    y0 = (SIGMA0 * zss + 0.004 * V_REF + KICK, V_REF, zss)
    p = P.pack(v_ref=V_REF, W=0.0, omega=1.0, t_end=T_END, sigma0=SIGMA0, sigma1=SIGMA1,
               e0=y0[0], v0=y0[1], z0=y0[2])
    return p, R.slider(P.unpack(p), "lugre", "none", y0, T_END)


@pytest.mark.parametrize("method,order,steps", [("rk4", 4, (50, 100, 200, 400)),
                                                ("dopri5", 5, (50, 100, 200))])
def test_order_of_convergence(method, order, steps):
    p, ref = _smooth_problem()
    errs = []
    for n in steps:
        q = p.copy()
        q[P.OMEGA] = np.pi * n / T_END           # stop every T_END / n
        r = simulate(scene(integrator=method), q, Settings(steps_per_period=1, rtol=1e6, atol=1e6),
                     record=True)
        assert r.status == 0 and r.y[:, 1].min() > 0.1   # no |u| kink on the way
        assert r.steps <= n + 6
        errs.append(np.max(np.abs(r.y_end[:3] - ref[:3]) * [1, 1, SIGMA0]))
    slopes = np.log2(np.array(errs[:-1]) / np.array(errs[1:]))
    assert np.all(np.abs(slopes - order) <= 0.2), (errs, slopes)


FIG10_REF = [0.009999958497670472, 1.001576621121634, 0.39999524679960946,
             0.39994144679398574, 0.0002919114744960316]


def _anchor_error(r, omega=1000.0):
    """anchors/README.md error: q = [z, e, v at 100, mean and p2p of v over the switching
    instants in [50, 100]], scaled by [fc/sigma0, fc, v_ref, v_ref, |p2p_ref|]."""
    hp = np.pi / omega
    ts = np.arange(int(np.ceil(50 / hp)), int(np.floor(100 / hp)) + 1) * hp
    idx = np.searchsorted(r.t, ts)
    assert np.array_equal(r.t[idx], ts)       # every switching instant is a step end
    v = r.y[idx, 1]
    q = np.array([r.y_end[2], r.y_end[0], r.y_end[1], v.mean(), v.max() - v.min()])
    scale = np.array([1 / 100, 1, 0.4, 0.4, abs(FIG10_REF[4])])
    return np.max(np.abs(q - FIG10_REF) / scale)


def test_fig10_error_follows_tolerance():
    """Without kink events DP5 stalls near 8e-5 on this scene for rtol 1e-6 .. 1e-8 (the
    corner of |u| at u = 0 is invisible to its error estimate); with them the error
    keeps falling with rtol."""
    p = P.pack(v_ref=0.4, W=0.4, omega=1000.0, t_end=100.0)
    errs = []
    for rtol in (1e-8, 1e-10, 1e-12):
        r = simulate(scene(), p, Settings(rtol=rtol, atol=1e-2 * rtol), record=True)
        assert r.status == 0
        errs.append(_anchor_error(r))
    assert errs[0] > errs[1] > errs[2], errs
    assert errs[0] < 1e-6 and errs[2] < 1e-9, errs
