"""Phase average <.> (Eq. 5.3 / 5.17): the square rule is exact with two points, the
split Gauss-Legendre sine rule converges spectrally to an independent adaptive
quadrature (scipy.integrate.quad, epsabs 1e-13, the kink given as a break point)."""
import numpy as np
import pytest
from scipy.integrate import quad

from engine import params as P
from engine.analysis.quadrature import (
    N_AVG,
    SINE,
    SQUARE,
    A,
    B,
    C,
    S,
    gauss_legendre,
    phase_average,
)

PAPER = P.pack()


def _avg(v, W, rule, n=64, vd=0.1, side=1.0):
    x, wx = gauss_legendre(n)
    out = np.empty(N_AVG)
    phase_average(out, v, W, rule, x, wx, P.pack(vd=vd), side)
    return out


def _integrands(u, vd):
    gu = 1.0 + 0.5 * np.exp(-(u / 0.1) ** 2)   # Eqs. 2.4, 2.5 with the Sec. 5.1 set
    s1 = 10.0 * np.exp(-(u / vd) ** 2)
    return np.array([abs(u) / gu, s1 * u, s1 * abs(u) / gu])


@pytest.mark.parametrize("v, W", [(0.3, 0.5), (-0.2, 0.5), (0.7, 0.5), (0.5, 0.5), (0.1, 0.0)])
def test_square_two_point_rule_is_the_exact_phase_average(v, W):
    """A square wave takes two values for half a period each, so the mean over an even
    number of equispaced phases (switches on the grid) is exact: it must equal the
    2-point rule of Eq. 5.6b / 5.9 to rounding."""
    theta = (np.arange(64) + 0.5) * 2 * np.pi / 64
    brute = np.mean([_integrands(v + W * np.sign(np.sin(th)), 0.1) for th in theta], axis=0)
    assert np.allclose(_avg(v, W, SQUARE)[[A, B, C]], brute, rtol=1e-14, atol=1e-15)


@pytest.mark.parametrize("vd", [0.1, 0.01])
@pytest.mark.parametrize("v, W", [(0.2, 0.5), (-0.45, 0.5), (0.8, 1.0), (0.55, 0.5)])
def test_sine_rule_matches_adaptive_quadrature(v, W, vd):
    """<f> = (1/2 pi) int_0^{2 pi} f(v + W sin th) dth by scipy quad with the kink
    u = 0 as a break point, against the split Gauss-Legendre rule with n = 256."""
    brk = [np.arcsin(-v / W), np.pi - np.arcsin(-v / W)] if abs(v) < W else None
    ref = [quad(lambda th, k=k: _integrands(v + W * np.sin(th), vd)[k], -np.pi / 2, 3 * np.pi / 2,
                points=brk, epsabs=1e-13, epsrel=1e-13, limit=200)[0] / (2 * np.pi)
           for k in range(3)]
    assert np.allclose(_avg(v, W, SINE, 256, vd)[[A, B, C]], ref, rtol=1e-10, atol=1e-13)


@pytest.mark.parametrize("W, vd", [(0.5, 0.1), (1.0, 0.1), (0.5, 0.01), (1.0, 0.01)])
def test_sine_rule_converges_spectrally(W, vd):
    """Error against n = 512 falls by orders of magnitude as n doubles (faster than any
    power law: the pieces between kinks are analytic) and is < 1e-12 at n = 128."""
    v = np.linspace(-2 * W, 2 * W, 41)
    ref = np.array([_avg(x, W, SINE, 512, vd) for x in v])
    err = {n: np.abs(np.array([_avg(x, W, SINE, n, vd) for x in v]) - ref).max()
           for n in (16, 32, 64, 128)}
    assert err[16] > err[32] > err[64]
    assert err[64] < 1e-3 * err[16]
    assert err[128] < 1e-12


def test_static_value_takes_the_middle_of_the_jump_at_u_zero():
    """Eq. 5.14's Sgn(0) = 0: at v = W one square-wave point sits on u = 0."""
    W = 0.5
    expected = 0.5 * (1.0 + 0.5 * np.exp(-((2 * W) / 0.1) ** 2))   # g(2W) / 2, Eq. 2.4
    assert _avg(W, W, SQUARE)[S] == pytest.approx(expected, rel=1e-15)


def test_gauss_legendre_refuses_zero_points():
    with pytest.raises(ValueError, match="n_quad must be >= 1, got 0"):
        gauss_legendre(0)
