"""Effective friction <F>(v), Sec. 5: the paper's closed forms, its low-velocity slopes
(Eqs. 5.13, 5.21), and the secondary negative slope of Fig. 5(a)/(b)."""
import numpy as np
import pytest

from engine import params as P
from engine.analysis.effective import (
    effective_friction,
    negative_slope_zones,
    sine_force_simplified,
)
from engine.analysis.integrands import dsigma1

PAPER = P.pack()                       # Sec. 5.1 set, vd = 0.1
FC, FS, VS, S1, S2 = 1.0, 1.5, 0.1, 10.0, 0.004


def _g(u):
    return FC + (FS - FC) * np.exp(-(u / VS) ** 2)


def _s1(u, vd):
    return S1 * np.exp(-(u / vd) ** 2)


def _fd_slope(f, v, h=1e-6):
    return (f(v + h) - f(v - h)) / (2 * h)


def test_square_lugre_is_eq_5_9_with_slow_manifold_5_10():
    """Eqs. 5.9-5.10 typed out from the paper (numpy, with sigma1(v - W) in the second
    term) against the engine's phase-average path."""
    v, W, vd = np.linspace(-1.5, 1.5, 301), 0.5, 0.1
    up, um = v + W, v - W
    Y = 2 * v / (np.abs(up) / _g(up) + np.abs(um) / _g(um))
    F = (Y + S2 * v + 0.5 * (_s1(up, vd) * up + _s1(um, vd) * um)
         - 0.5 * Y * (_s1(up, vd) * np.abs(up) / _g(up) + _s1(um, vd) * np.abs(um) / _g(um)))
    assert np.allclose(effective_friction(v, W, PAPER, vd=vd), F, rtol=1e-13, atol=1e-14)


def test_static_model_is_eq_5_14():
    v, W = np.linspace(-1.5, 1.5, 301), 0.5
    F = 0.5 * (_g(v + W) * np.sign(v + W) + _g(v - W) * np.sign(v - W)) + S2 * v
    assert np.allclose(effective_friction(v, W, PAPER, model="static"), F, rtol=1e-13, atol=1e-14)


def test_without_dither_lugre_is_the_steady_state_curve():
    """Fig. 5(d): W = 0 gives the LuGre steady state g(v) sgn(v) + sigma2 v (Eq. 2.2)."""
    v = np.linspace(0.01, 1.0, 100)
    assert np.allclose(effective_friction(v, 0.0, PAPER), _g(v) + S2 * v, rtol=1e-13)


@pytest.mark.parametrize("W", [0.2, 0.5, 1.0])
def test_eq_5_12_exact_slope_and_the_eq_5_13_approximation(W):
    """Eq. 5.12's slope at v = 0 is exactly g(W)/W + sigma2 (Y ~ 2v / (2W/g(W)));
    Eq. 5.13 prints (fc + W sigma2)/W, short by (fs - fc) exp(-(W/vs)^2) / W."""
    slope = _fd_slope(lambda v: effective_friction(v, W, PAPER, model="no-damping"), 0.0)
    exact = _g(W) / W + S2
    assert slope == pytest.approx(exact, rel=1e-8)
    eq_5_13 = (FC + W * S2) / W
    assert exact - eq_5_13 == pytest.approx((FS - FC) * np.exp(-(W / VS) ** 2) / W, rel=1e-9)


@pytest.mark.parametrize("W", [0.5, 0.75])
def test_eq_5_21_low_velocity_slope_of_sine_force_dither(W):
    """Eq. 5.21: d<F>/dv at v = 0 is pi fc / (2 a Omega) + sigma2, exactly, both for the
    closed form Eq. 5.20 and for the quadrature path with the same simplified law."""
    simple = P.pack(fs=FC, sigma1=0.0)
    expected = np.pi * FC / (2 * W) + S2
    assert _fd_slope(lambda v: sine_force_simplified(v, W, FC, S2), 0.0) == pytest.approx(expected, rel=1e-8)
    _F, dF = effective_friction(0.0, W, simple, dither="sine-force", slope=True)
    assert dF == pytest.approx(expected, rel=1e-12)


def test_eq_5_20_closed_form_equals_the_quadrature_and_is_continuous():
    """Eq. 5.20 corrected (1/pi in 5.19a, fc sgn(v) outside) equals the sine-rule average
    of the simplified law everywhere; with the printed fs it would jump by fs - fc."""
    W, simple = 0.5, P.pack(fs=FC, sigma1=0.0)
    v = np.linspace(-1.5, 1.5, 601)
    closed = sine_force_simplified(v, W, FC, S2)
    assert np.allclose(closed, effective_friction(v, W, simple, dither="sine-force"),
                       rtol=1e-12, atol=1e-13)
    eps = 1e-9
    jump = sine_force_simplified(W + eps, W, FC, S2) - sine_force_simplified(W - eps, W, FC, S2)
    assert abs(jump) < 1e-3


@pytest.mark.parametrize("vd", [0.1, 0.01])
def test_lugre_square_low_velocity_slope(vd):
    """Slope of Eq. 5.9 at v = 0 (Y(0) = 0, Y'(0) = g(W)/W):
    g(W)/W (1 - C) + B' + sigma2 = g(W)/W + sigma1'(W) W + sigma2."""
    W = 0.5
    _F, dF = effective_friction(0.0, W, P.pack(vd=vd), slope=True)
    expected = _g(W) / W + dsigma1(W, P.pack(vd=vd), 1.0) * W + S2
    assert dF == pytest.approx(expected, rel=1e-12)
    assert _fd_slope(lambda v: effective_friction(v, W, P.pack(vd=vd)), 0.0) == pytest.approx(expected, rel=1e-7)


@pytest.mark.parametrize("dither", ["square-velocity", "sine-velocity"])
def test_analytic_slope_equals_finite_differences(dither):
    v = np.array([-0.9, -0.3, 0.05, 0.2, 0.38, 0.45, 0.7, 1.2])   # away from |v| = W
    W, p = 0.5, P.pack(vd=0.1)
    _F, dF = effective_friction(v, W, p, dither=dither, slope=True)
    fd = _fd_slope(lambda x: effective_friction(x, W, p, dither=dither), v)
    assert np.allclose(dF, fd, rtol=1e-6, atol=1e-6)


def _zones(vd, W=0.5):
    v = np.linspace(0.0, 1.5, 150001)                # step 1e-5
    _F, dF = effective_friction(v, W, P.pack(vd=vd), slope=True)
    return negative_slope_zones(v, dF)


def test_fig5a_secondary_negative_slope_below_W():
    """Fig. 5(a), vd = 0.1, W = 0.5: besides the primary (Stribeck) zone above W, a
    secondary zone of negative slope lies below W."""
    zones = _zones(0.1)
    below = [z for z in zones if z[1] < 0.5]
    above = [z for z in zones if z[0] > 0.5]
    assert len(below) == 1 and len(above) == 1
    assert below[0][1] - below[0][0] > 0.05                # a broad zone, ~0.33..0.41
    assert above[0][0] - 0.5 < 0.1 and above[0][1] - above[0][0] > 0.1


def test_fig5b_secondary_zone_shrinks_to_a_sliver_for_small_vd():
    """Fig. 5(b), vd = 0.01: what remains below W is a sliver of width ~vd next to W
    (the sigma1(v - W) bump), >5x narrower than for vd = 0.1; another sliver of the
    same origin sits just above W, before the primary zone."""
    wide = next(z for z in _zones(0.1) if z[1] < 0.5)
    zones = _zones(0.01)
    below = [z for z in zones if z[1] < 0.5]
    assert len(below) == 1
    lo, hi = below[0]
    assert 0.5 - 3 * 0.01 < lo < hi < 0.5
    assert hi - lo < (wide[1] - wide[0]) / 5


def test_static_model_slope_is_sigma2_at_low_velocity():
    """Fig. 5(c): the static-model curve has slope sigma2 for |v| << W (W >> vs)
    and lies below the LuGre curve (the static model underestimates <F>)."""
    v, W = np.linspace(0.0, 0.05, 11), 0.5
    Fs, dFs = effective_friction(v, W, PAPER, model="static", slope=True)
    # the rest is the Stribeck tail g'(W - v) ~ 2 (W - v)/vs^2 (fs - fc) e^{-20} < 2e-7
    assert np.allclose(dFs, S2, rtol=0, atol=2e-7)
    assert np.all(Fs[1:] < effective_friction(v[1:], W, PAPER))


def test_undefined_at_rest_without_dither_and_bad_names():
    assert np.isnan(effective_friction(0.0, 0.0, PAPER))
    with pytest.raises(ValueError, match="model must be one of"):
        effective_friction(0.1, 0.5, PAPER, model="coulomb")
    with pytest.raises(ValueError, match="dither must be one of"):
        effective_friction(0.1, 0.5, PAPER, dither="triangle")
