"""Observables reduced while integrating (engine/observables.py definitions).

- Phase times and sticking runs: elasto-plastic contact (Sec. 3) at constant u > 0 from
  z = 0 sticks (alpha = 0, Eq. 2.7: |z| <= z_ba) exactly while z = u t <= z_ba, i.e. for
  t_ba = lam g(u) / (sigma0 u), then pre-slides; the window [t_transient, t_end] clips runs.
- Window means and the dither-period average: v_mean, F_mean and v_slow_p2p against the
  scipy DOP853 reference carrying the quadratures X = int v and Q = int F
  (tests/engine/reference.py), with t_transient > 0.
"""
import numpy as np
import pytest

from engine import params as P
from engine import status as S
from engine.api import simulate
from engine.settings import Settings
from tests.engine import reference as R
from tests.engine.common import scene

U = 1e-3


def _t_ba():
    c = P.CONTACT_DEFAULTS
    return c["lam"] * R.g(U, c) / (c["sigma0"] * U)


@pytest.mark.long
@pytest.mark.parametrize("t_tr,long_stick", [(0.0, 5e-3), (5e-3, 1e-3), (0.0, 0.012)])
def test_elastoplastic_stick_run_is_exact(t_tr, long_stick):
    t_end, t_ba = 0.02, _t_ba()
    p = P.pack(P.CONTACT_DEFAULTS, v_ref=U, W=0.0, omega=1.0, t_end=t_end, t_transient=t_tr,
               long_stick=long_stick)
    r = simulate(scene("elastoplastic", "none", system="contact"), p,
                 Settings(rtol=1e-9, atol=1e-16))
    assert r.status == S.OK
    o, span, run = r.outputs, t_end - t_tr, t_ba - t_tr
    assert o["stick_fraction"] == pytest.approx(run / span, rel=1e-9)
    assert o["max_stick"] == pytest.approx(run, rel=1e-9)
    assert o["long_stick_fraction"] == pytest.approx(run / span if run > long_stick else 0.0,
                                                     rel=1e-9)
    assert o["stick_fraction"] + o["presliding_fraction"] + o["slip_fraction"] == \
        pytest.approx(1.0, abs=1e-12)
    assert o["v_mean"] == pytest.approx(U, rel=1e-12)      # prescribed u
    assert o["v_slow_p2p"] == pytest.approx(0.0, abs=1e-15)


@pytest.mark.parametrize("dither,kw", [
    ("square-velocity", {"W": 0.3, "omega": 100.0}),
    ("sine-force", {"W": 0.3, "omega": 100.0}),
    ("none", {}),
])
@pytest.mark.long
def test_window_means_and_period_average_match_reference(dither, kw):
    t_tr, t_end = 0.5, 2.0
    p = P.pack(v_ref=0.4, t_end=t_end, t_transient=t_tr, **kw)
    d = P.unpack(p)
    omega = kw.get("omega")
    stops = [t_tr] + ([] if omega is None else
                      list(np.arange(1, int(t_end * omega / (2 * np.pi)) + 1)
                           * (2 * np.pi / omega)))
    y_end, at = R.slider(d, "lugre", dither, (0, 0, 0), t_end, stops=stops)
    r = simulate(scene("lugre", dither), p, Settings(rtol=1e-10, atol=1e-12))
    assert r.status == S.OK
    o, span = r.outputs, t_end - t_tr
    assert o["v_mean"] == pytest.approx((y_end[4] - at[0, 4]) / span, abs=1e-9)
    assert o["F_mean"] == pytest.approx((y_end[3] - at[0, 3]) / span, abs=1e-9)
    if omega is not None:
        tb, xb = np.array(stops[1:]), at[1:, 4]
        keep = tb >= t_tr
        vbar = np.diff(xb[keep]) / np.diff(tb[keep])
        assert o["v_slow_p2p"] == pytest.approx(np.ptp(vbar), abs=1e-9)
