"""Averaged velocity-tracking system, Sec. 6 (Eqs. 6.4-6.7) and the Fig. 9 chart."""
import numpy as np
import pytest
from scipy.optimize import brentq

from engine import params as P
from engine.analysis.chart import stability_chart
from engine.analysis.stability import (
    averaged_rhs,
    equilibrium,
    jacobian,
    max_real_eig,
    static_max_real_eig,
)
from store.query import NO_DATA, PU, STABLE, SU, stability_labels

PAPER = P.pack()
CASES = [(0.2, 0.5, 0.1), (0.4, 0.1, 0.01), (0.3, 0.0, 0.1), (0.1, 0.35, 0.01), (0.25, 0.24, 0.01)]


def _fd_jacobian(x0, v_ref, W, vd, dither, mode="central"):
    J = np.empty((3, 3))
    f = lambda x: averaged_rhs(x, v_ref, W, PAPER, dither=dither, vd=vd)
    for k in range(3):
        h = 1e-6 * max(1.0, abs(x0[k]))
        e = np.zeros(3)
        e[k] = h
        if mode == "central":
            J[:, k] = (f(x0 + e) - f(x0 - e)) / (2 * h)
        elif mode == "forward":
            J[:, k] = (f(x0 + e) - f(x0)) / h
        else:
            J[:, k] = (f(x0) - f(x0 - e)) / h
    return J


@pytest.mark.parametrize("dither", ["square-velocity", "sine-velocity"])
@pytest.mark.parametrize("v_ref, W, vd", CASES)
def test_equilibrium_is_a_fixed_point_and_jacobian_matches_finite_differences(v_ref, W, vd, dither):
    """Eq. 6.7 (with the full e0 = <F>(v_ref)) zeroes Eqs. 6.4-6.6; the analytic Jacobian
    equals central differences of the right-hand side (away from the kink |v| = W)."""
    x0 = np.array([float(c) for c in equilibrium(v_ref, W, PAPER, dither=dither, vd=vd)])
    assert np.abs(averaged_rhs(x0, v_ref, W, PAPER, dither=dither, vd=vd)).max() < 1e-14
    J, _F = jacobian(v_ref, W, PAPER, dither=dither, vd=vd)
    assert np.allclose(J, _fd_jacobian(x0, v_ref, W, vd, dither), rtol=1e-7, atol=1e-7)


@pytest.mark.parametrize("side, mode", [(1.0, "forward"), (-1.0, "backward")])
def test_one_sided_jacobian_at_the_kink(side, mode):
    """At W = v_ref one square-wave point sits on u = v - W = 0: side = +1 gives the
    right (forward) derivative in v, side = -1 the left (backward) one; they differ."""
    v_ref = W = 0.3
    x0 = np.array([float(c) for c in equilibrium(v_ref, W, PAPER)])
    J = jacobian(v_ref, W, PAPER, side=side)[0]
    assert np.allclose(J, _fd_jacobian(x0, v_ref, W, 0.1, "square-velocity", mode), rtol=1e-4, atol=1e-4)
    assert not np.allclose(jacobian(v_ref, W, PAPER, side=-side)[0][:, 2], J[:, 2], rtol=1e-3)


def test_eigenvalues_agree_with_routh_hurwitz():
    """Characteristic polynomial l^3 - (a + d) l^2 + (1 + a d - b c) l - a (stability.py);
    Routh-Hurwitz: stable iff all coefficients > 0 and c2 c1 > c0."""
    Wg, vg = np.meshgrid(np.linspace(0, 0.8, 41), np.linspace(0.01, 0.6, 40), indexing="ij")
    J, _ = jacobian(vg, Wg, PAPER)
    a, b, c, d = J[..., 0, 0], J[..., 0, 2], J[..., 2, 0], J[..., 2, 2]
    c2, c1, c0 = -(a + d), 1 + a * d - b * c, -a
    rh_stable = (c2 > 0) & (c1 > 0) & (c0 > 0) & (c2 * c1 > c0)
    lam = max_real_eig(J)
    clear = np.abs(lam) > 1e-9
    assert np.array_equal((lam < 0)[clear], rh_stable[clear])
    assert rh_stable.any() and (~rh_stable).any()


def test_static_law_eigenvalues():
    """(e, v) system with slope F': roots of l^2 + F' l + 1."""
    for s in (-3.0, -0.5, 0.0, 0.004, 2.5):
        assert static_max_real_eig(s) == pytest.approx(np.roots([1, s, 1]).real.max(), abs=1e-12)


def test_labels_rule_on_the_engine_chart_arrays():
    """The engine's chart hands ``unstable`` / ``valid`` to the store's one labelling
    rule (DESIGN.md §1, connected components; its cases: tests/store/
    test_store_stability_labels.py). Rows W (row 0 = smallest), columns v_ref."""
    lam = np.array([[1.0, -1, 1, np.nan], [1, 1, -1, 1], [-1, 1, 1, 1], [1, 1, 1, 1]])
    unstable, valid = lam > 0, ~np.isnan(lam)
    lab = stability_labels(unstable, valid, w_axis=0, v_ref_axis=1)
    assert lab.tolist() == [[PU, STABLE, PU, NO_DATA], [PU, PU, STABLE, PU],
                            [STABLE, PU, PU, PU], [PU, PU, PU, PU]]
    c = stability_chart([0.0, 0.5], [0.1, 0.2], PAPER)
    assert np.array_equal(c["unstable"], c["max_real_eig"] > 0)
    assert np.array_equal(c["stable"], c["valid"] & ~c["unstable"])


def test_undithered_threshold_is_near_the_static_slope_condition():
    """Without dither the equilibrium is unstable where the friction slope is negative:
    rigid-bristle estimate g'(v) + sigma2 = 0 (Stribeck, delta = 2); the bristle
    dynamics move the threshold by < 1e-4."""
    static = brentq(lambda v: -100.0 * v * np.exp(-100.0 * v * v) + 0.004, 0.2, 0.4)
    for vd in (0.1, 0.01):
        lam = lambda v, vd=vd: max_real_eig(jacobian(v, 0.0, P.pack(vd=vd))[0])
        assert brentq(lam, 0.2, 0.4, xtol=1e-12) == pytest.approx(static, abs=1e-4)
        assert lam(0.01) > 0 and lam(0.29) > 0 and lam(0.31) < 0


W_AX = np.linspace(0.0, 0.6, 601)
V_AX = np.linspace(0.005, 0.295, 59)


def _chart(vd):
    c = stability_chart(W_AX, V_AX, P.pack(vd=vd))
    c["labels"] = stability_labels(c["unstable"], c["valid"], w_axis=0, v_ref_axis=1, W=W_AX)
    return c


@pytest.mark.parametrize("vd", [0.1, 0.01])
def test_fig9_primary_zone_for_both_vd(vd):
    """Fig. 9: in the v_ref range where the undithered system is unstable, a primary
    zone rises from W = 0 at every v_ref, and enough dither (W > v_ref) stabilises."""
    c = _chart(vd)
    assert np.all(c["labels"][0] == PU)
    top = np.array([W_AX[np.flatnonzero(c["labels"][:, j] == PU)].max() for j in range(V_AX.size)])
    assert np.all(top <= V_AX)
    assert np.all(c["stable"][W_AX > 0.55])


def test_fig9a_secondary_zone_at_higher_v_ref_for_vd_0_1():
    """Fig. 9(a), vd = 0.1: an SU island at the higher v_ref, W well above v_ref."""
    lab = _chart(0.1)["labels"]
    su_cols = [j for j in range(V_AX.size) if (lab[:, j] == SU).any()]
    assert su_cols and V_AX[su_cols[0]] > 0.15 and V_AX[su_cols[-1]] == V_AX[-1]
    j = V_AX.size - 1
    Wsu = W_AX[lab[:, j] == SU]
    assert Wsu.min() > V_AX[j] + 0.05 and Wsu.max() - Wsu.min() > 0.05


def test_fig9b_secondary_zone_gone_for_vd_0_01_except_slivers_at_the_diagonal():
    """Fig. 9(b), vd = 0.01: no broad SU zone; the only SU points are slivers within
    3 vd of the kink W = v_ref (the sigma1(v - W) bump of Fig. 5(b))."""
    lab_b, lab_a = _chart(0.01)["labels"], _chart(0.1)["labels"]
    Wg, vg = np.meshgrid(W_AX, V_AX, indexing="ij")
    su = lab_b == SU
    assert np.all(np.abs(Wg[su] - vg[su]) < 3 * 0.01)
    assert su.sum() < (lab_a == SU).sum() / 5
