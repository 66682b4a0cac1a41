"""Invariants with exact references (STYLE.md "Invariants"; DESIGN.md §1).

- LuGre at constant velocity (contact system, Sec. 3, W = 0): z(t) equals the closed-form
  relaxation :func:`_relax` (the z equation is linear for frozen u), and
  F_mean equals the time average of F = sigma0 z + sigma1(u) dz + sigma2 u along it.
- LuGre keeps |z| <= fs / sigma0 (the invariant set of Eq. 2.3 with alpha = 1) under square
  dither, for the slider and the contact.
- Square-wave switching times k * (pi / omega) appear bitwise in the step sequence
  (DESIGN.md: "an integrator must step exactly onto them, never across them").
"""
import numpy as np
import pytest
from scipy.integrate import quad

from engine import params as P
from engine.api import simulate
from engine.dither import switch_times
from engine.settings import Settings
from tests.engine import reference as R
from tests.engine.common import scene


def _relax(z0, u, t, d):
    """Closed-form z(t) of dz = u - sigma0 |u| z / g(u) at constant u (Eq. 2.3, alpha = 1):
    z_ss + (z0 - z_ss) exp(-k t), z_ss = g(u) sgn(u) / sigma0, k = sigma0 |u| / g(u)."""
    gu = R.g(u, d)
    zss = gu * np.sign(u) / d["sigma0"]
    return zss + (z0 - zss) * np.exp(-d["sigma0"] * abs(u) / gu * t)


@pytest.mark.parametrize("u", [1e-3, -2.5e-3])
def test_contact_lugre_constant_velocity_matches_relaxation(u):
    c = P.CONTACT_DEFAULTS
    t_end = 5e-3
    p = P.pack(P.CONTACT_DEFAULTS, v_ref=u, W=0.0, omega=1.0, t_end=t_end, z0=2e-6)
    # W = 0 in the square-dither scene of the last test (one compilation for both): u = v,
    # and its first switch, at pi / omega = pi, lies beyond t_end
    r = simulate(scene(system="contact", dither="square-velocity", outputs=("F_mean",)), p,
                 Settings(rtol=1e-10, atol=1e-16), record=True)
    assert r.status == 0
    z_exact = np.array([_relax(2e-6, u, t, c) for t in r.t])
    assert np.max(np.abs(r.y[:, 0] - z_exact)) <= 1e-9 * c["fs"] / c["sigma0"]
    s1, gu = R.sigma1(u, c), R.g(u, c)

    def force(t):
        z = _relax(2e-6, u, t, c)
        dz = u - c["sigma0"] * abs(u) * z / gu
        return c["sigma0"] * z + s1 * dz + c["sigma2"] * u
    f_mean = quad(force, 0.0, t_end, epsabs=1e-14, epsrel=1e-12)[0] / t_end
    assert abs(r.outputs["F_mean"] - f_mean) <= 1e-8 * c["fs"]


def test_lugre_bristle_bound_and_exact_switch_times():
    p = P.pack(v_ref=0.4, W=0.4, omega=1000.0, t_end=2.0)
    r = simulate(scene(), p, Settings(rtol=1e-6, atol=1e-8), record=True)
    assert r.status == 0 and not r.truncated
    assert np.all(np.abs(r.y[:, 2]) <= p[P.FS] / p[P.SIGMA0])
    k = np.arange(1, int(2.0 * 1000.0 / np.pi) + 1)
    expected = k * (np.pi / 1000.0)               # computed from k, never accumulated
    assert np.array_equal(np.intersect1d(r.t, expected), expected)
    assert np.array_equal(expected, switch_times(1000.0, 2.0))
    assert r.t[-1] == 2.0


def test_rk4_steps_divide_the_half_period():
    p = P.pack(v_ref=0.4, W=0.4, omega=1000.0, t_end=0.05)
    r = simulate(scene(integrator="rk4"), p, Settings(steps_per_period=4),
                 record=True)
    sw = switch_times(1000.0, 0.05)
    assert np.array_equal(r.t[3::4][:len(sw)], sw)    # every 4th step end is a switch
    assert np.allclose(np.diff(r.t[: 4 * len(sw)]), np.pi / 1000.0 / 4, rtol=1e-9, atol=0)


def test_contact_lugre_bristle_bound_with_square_dither():
    p = P.pack(P.CONTACT_DEFAULTS, v_ref=1e-3, W=2e-3, omega=2 * np.pi * 50, t_end=0.1)
    r = simulate(scene(system="contact", dither="square-velocity", outputs=("F_mean",)), p,
                 Settings(rtol=1e-8, atol=1e-14), record=True)
    assert r.status == 0
    assert np.all(np.abs(r.y[:, 0]) <= P.CONTACT_DEFAULTS["fs"] / P.CONTACT_DEFAULTS["sigma0"])
    assert np.abs(r.y[:, 0]).max() > 0.5 * P.CONTACT_DEFAULTS["fc"] / P.CONTACT_DEFAULTS["sigma0"]
