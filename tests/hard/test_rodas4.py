"""The stiff method itself: RODAS tableau (Hairer & Wanner II, Table IV.7.1 conditions),
L-stability, its linear algebra, finite-difference Jacobian, and measured convergence order.

Independent references: the order conditions and the stability function are textbook
(Hairer & Wanner II, Sec. IV.7); the convergence test integrates a problem with a closed-form
solution.
"""
from __future__ import annotations

import functools
import math

import numpy as np
import pytest
from numba import njit

from engine.integrators import METHODS, rodas4
from engine.integrators.rosenbrock import RosenbrockTableau
from engine.integrators.rosenbrock_ops import invert, make_fd_jacobian, make_time_derivative

TAB = rodas4.TABLEAU
FLOOR_ONE = np.ones(3)   # atol_j = 1 with rtol = 1 (jac increments sqrt(eps) (|y_j| + 1))


def _kwargs(tab):
    return {"name": "x", "gamma": tab.gamma, "a": tab.a, "C": tab.C, "c": tab.c, "d": tab.d,
            "m": tab.m, "m_hat": tab.m_hat, "order": tab.order, "error_order": tab.error_order}


def test_registered_under_its_name_and_the_sweeps_alias():
    assert METHODS["rodas4"] is rodas4
    assert METHODS["rosenbrock"] is rodas4        # sweeps.spec.accuracy.STIFF_METHOD
    assert rodas4.ADAPTIVE and rodas4.ORDER == 4


def test_tableau_meets_order_4_and_embedded_order_3():
    # construction ran the checks; a perturbed coefficient must break them
    m = np.array(TAB.m)
    m[2] += 1e-6
    with pytest.raises(ValueError, match="m is of order 0, claimed 4"):
        RosenbrockTableau(**{**_kwargs(TAB), "m": m})


def test_embedded_weights_are_not_of_order_4():
    # the error estimate m - m_hat must not vanish to order 4 (else it estimates nothing)
    with pytest.raises(ValueError, match="m_hat is of order 3, claimed 4"):
        RosenbrockTableau(**{**_kwargs(TAB), "error_order": 4})


def test_wrong_time_weights_are_refused():
    d = np.array(TAB.d)
    d[1] += 1e-3
    with pytest.raises(ValueError, match="d must be the row sums of Gamma"):
        RosenbrockTableau(**{**_kwargs(TAB), "d": d})


def test_l_stable():
    """|R(z)| <= 1 on the left half-plane (sampled) and R(-inf) = 0 (stiffly accurate)."""
    assert abs(TAB.stability(-1e12)) < 1e-9
    for x in (-1e-3, -0.1, -1.0, -10.0, -1e3):
        for y in (0.0, 0.5, 5.0, 50.0, 5e3):
            assert abs(TAB.stability(complex(x, y))) <= 1.0 + 1e-12
    for y in (0.1, 1.0, 10.0, 100.0):        # A-stable down to the imaginary axis
        assert abs(TAB.stability(complex(0.0, y))) <= 1.0 + 1e-12


def test_stability_function_approximates_exp_to_order_4():
    z = 1e-2
    assert abs(TAB.stability(-z) - math.exp(-z)) < 1e-11   # O(z^5) ~ 1e-10 / 120


def test_invert_with_pivoting():
    rng = np.random.default_rng(0)
    for n in (2, 3, 5):
        M = rng.normal(size=(n, n))
        M[0, 0] = 0.0                       # forces a row swap
        Minv = np.empty((n, n))
        assert invert(M.copy(), Minv)
        np.testing.assert_allclose(M @ Minv, np.eye(n), rtol=0, atol=1e-12)
    assert not invert(np.zeros((3, 3)), np.empty((3, 3)))


@njit
def _stiff_rhs(t, y, p, sq, dy):
    # y0' = -k (y0 - cos t) - sin t  (exact y0 = cos t + c e^{-kt}); y1' = y0 y1 ; y2' = y0
    k = p[0]
    dy[0] = -k * (y[0] - math.cos(t)) - math.sin(t)
    dy[1] = y[0] * y[1]
    dy[2] = y[0]


def test_fd_jacobian_matches_the_analytic_one():
    jac = make_fd_jacobian(3, 2, _stiff_rhs, 0, _no_events)   # third state: quadrature
    y, p = np.array([0.3, 2.0, 5.0]), np.array([1e6])
    f0, J, yt, ft, G = np.empty(3), np.empty((3, 3)), np.empty(3), np.empty(3), np.empty(1)
    _stiff_rhs(0.7, y, p, 1.0, f0)
    jac(0.7, y, f0, p, 1.0, J, yt, ft, FLOOR_ONE, 1.0, G, G)
    exact = np.array([[-1e6, 0, 0], [2.0, 0.3, 0], [1.0, 0, 0]])
    np.testing.assert_allclose(J, exact, rtol=1e-6, atol=1e-6)


def test_time_derivative_matches_the_analytic_one():
    dfdt = _kernels()[3]
    y, p = np.array([0.3, 2.0, 5.0]), np.array([10.0])
    f0, ft, yt, G = np.empty(3), np.empty(3), np.empty(3), np.empty(1)
    # rounding error ~ eps^(2/3) |f| / hh (|f| ~ 5 here): its share of the local error,
    # d_i h^2 df_t ~ h eps^(2/3) |f|, is negligible at any step; a late t rounds t + delta
    for t, hh in ((0.7, 1e-2), (0.7, 1e-7), (1e4, 1e-5)):
        _stiff_rhs(t, y, p, 1.0, f0)
        dfdt(t, y, f0, p, 1.0, hh, ft, yt, G, G)
        tol = 1e-8 + 10 * np.finfo(float).eps ** (2 / 3) * 5 / hh
        assert ft[0] == pytest.approx(-10.0 * math.sin(t) - math.cos(t), abs=tol)
        assert ft[1] == 0.0 and ft[2] == 0.0


@njit
def _no_events(t, y, p, sq, g):
    pass


@functools.cache
def _kernels():
    """RODAS's stage, dense-output and difference kernels on the test problem (compiled once)."""
    return (rodas4._make_attempt(TAB, 3, 3, _stiff_rhs), rodas4._make_dense(TAB, 3),
            make_fd_jacobian(3, 3, _stiff_rhs, 0, _no_events),
            make_time_derivative(3, _stiff_rhs, 0, _no_events))


def _fixed_step_error(n_steps, k=1e4, t_end=2.0):
    """Global error of RODAS with n equal steps on the stiff test problem (exact solution)."""
    attempt, _, jac, dfdt = _kernels()
    p, y, h = np.array([k]), np.array([1.0, 1.0, 0.0]), t_end / n_steps
    U, yt, yn, f0, ft = np.empty((6, 3)), np.empty(3), np.empty(3), np.empty(3), np.empty(3)
    J, Minv, r, G = np.empty((3, 3)), np.empty((3, 3)), np.empty(3), np.empty(1)
    for i in range(n_steps):
        t = i * h
        _stiff_rhs(t, y, p, 1.0, f0)
        jac(t, y, f0, p, 1.0, J, yt, ft, FLOOR_ONE, 1.0, G, G)
        dfdt(t, y, f0, p, 1.0, h, ft, yt, G, G)
        invert(np.eye(3) / (h * TAB.gamma) - J, Minv)
        attempt(t, h, y, f0, ft, True, Minv, p, 1.0, U, yt, r, yn, 1.0, FLOOR_ONE)
        y[:] = yn
    # from y0(0) = 1 = cos 0 the solution stays on cos t exactly (c = 0)
    exact1 = math.exp(math.sin(t_end))
    return max(abs(y[0] - math.cos(t_end)), abs(y[1] - exact1), abs(y[2] - math.sin(t_end)))


def test_convergence_order_4_on_a_nonautonomous_problem():
    """log2-slope of the global error against the step within 0.2 of ORDER = 4 (non-stiff
    regime: k h small), and bounded error with k h up to 1e3 (stiff regime, L-stability)."""
    errs = [_fixed_step_error(n, k=1.0) for n in (20, 40, 80)]
    slopes = np.log2(np.array(errs[:-1]) / np.array(errs[1:]))
    assert np.all(np.abs(slopes - 4) < 0.2), (errs, slopes)
    assert _fixed_step_error(10, k=1e4) < 1e-4


def _dense_mid_error(h, k=1.0):
    """Error of the continuous extension at theta = 1/2 after one step of size h."""
    attempt, (coeffs, dense_eval), jac, dfdt = _kernels()
    p, y = np.array([k]), np.array([1.0, 1.0, 0.0])
    U, yt, yn, f0, ft = np.empty((6, 3)), np.empty(3), np.empty(3), np.empty(3), np.empty(3)
    J, Minv, r, Q, ym = (np.empty((3, 3)), np.empty((3, 3)), np.empty(3), np.empty((3, 3)),
                         np.empty(3))
    G = np.empty(1)
    _stiff_rhs(0.0, y, p, 1.0, f0)
    jac(0.0, y, f0, p, 1.0, J, yt, ft, FLOOR_ONE, 1.0, G, G)
    dfdt(0.0, y, f0, p, 1.0, h, ft, yt, G, G)
    invert(np.eye(3) / (h * TAB.gamma) - J, Minv)
    attempt(0.0, h, y, f0, ft, True, Minv, p, 1.0, U, yt, r, yn, 1.0, FLOOR_ONE)
    coeffs(y, yn, (U,), Q)   # mw: the stages first
    dense_eval(y, h, Q, 0.5, ym)
    t = 0.5 * h
    return max(abs(ym[0] - math.cos(t)), abs(ym[1] - math.exp(math.sin(t))),
               abs(ym[2] - math.sin(t)))


def test_dense_output_is_third_order():
    """Local error of the continuous extension O(h^4) (order 3, rodas.f's dense output)."""
    errs = [_dense_mid_error(h) for h in (0.1, 0.05, 0.025)]
    slopes = np.log2(np.array(errs[:-1]) / np.array(errs[1:]))
    assert np.all(np.abs(slopes - 4) < 0.2), (errs, slopes)
