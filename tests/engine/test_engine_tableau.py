"""Tableau invariants: every registered explicit method satisfies its order conditions
(Hairer-Norsett-Wanner I, Sec. II.2, rooted trees up to order 5), and a wrong tableau is
refused when built."""
import numpy as np
import pytest

from engine.integrators import METHODS, dopri5, rk4
from engine.integrators.tableau import ButcherTableau, order_of


@pytest.mark.parametrize("mod", [rk4, dopri5], ids=lambda m: m.NAME)
def test_registered_and_sum_rules(mod):
    tab = mod.TABLEAU
    assert METHODS[mod.NAME] is mod
    assert np.allclose(tab.a.sum(axis=1), tab.c, atol=1e-15)
    assert abs(tab.b.sum() - 1.0) < 1e-15
    assert order_of(tab.a, tab.b, tab.c) == mod.ORDER


def test_dopri5_embedded_pair_and_dense_output():
    tab = dopri5.TABLEAU
    assert order_of(tab.a, tab.b_hat, tab.c) == 4          # the error estimator's order
    assert abs(tab.b_err.sum()) < 1e-15                      # consistent estimate
    assert np.allclose(tab.a[6], tab.b)                      # FSAL: last stage = solution
    assert np.allclose(tab.dense.sum(axis=1), tab.b)         # dense(theta = 1) = b


def test_rk4_continuous_extension_is_third_order():
    tab = rk4.TABLEAU
    th = 0.37
    w = tab.dense @ th ** np.arange(1, 4)
    # quadrature conditions of the extension: sum w = th, w.c = th^2/2, w.c^2 = th^3/3
    assert abs(w.sum() - th) < 1e-15
    assert abs(w @ tab.c - th**2 / 2) < 1e-15
    assert abs(w @ tab.c**2 - th**3 / 3) < 1e-15


def test_wrong_tableau_is_refused_with_the_failing_rule():
    a = [[0, 0], [0.5, 0]]
    with pytest.raises(ValueError, match="row sums of a must equal c"):
        ButcherTableau("bad-c", c=[0, 0.4], a=a, b=[0, 1], order=2)
    with pytest.raises(ValueError, match="b is of order 1, claimed 2"):
        ButcherTableau("bad-b", c=[0, 0.5], a=a, b=[0.5, 0.5], order=2)
    with pytest.raises(ValueError, match="strictly lower triangular"):
        ButcherTableau("implicit", c=[0.5, 0.5], a=[[0.5, 0], [0.5, 0]], b=[0, 1], order=1)
