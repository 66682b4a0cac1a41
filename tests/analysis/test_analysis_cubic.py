"""The averaged stability's eigenvalue step (engine.analysis.cubic, stability's
jacobian_max_real_eig) against LAPACK (``np.linalg.eigvals``), an independent method.

Tolerance. Both are accurate to their first-order error bounds at the eigenvalue ``lam`` of
largest real part: LAPACK's ``eps ||J||_F kappa`` (backward error times the eigenvalue
condition number ``kappa = |x| |y| / |y^H x|``, right / left eigenvectors) and the
polynomial's ``eps sum_k |c_k| |lam|**k / |P'(lam)|`` (coefficients to an ulp, Horner).
The two differ by at most the sum; :data:`BOUND_FACTOR` = 8 covers the rounding constants
the first-order bounds leave out (largest ratio measured: 3.7 on random matrices, 0.08 on
the Fig. 9 grids, whose largest difference is 2.9e-14, ~ eps ||J||_F with ||J|| <= 160).
Near a double (triple) root both bounds blow up and both methods are only ``eps**(1/2)``
(``eps**(1/3)``) accurate: there the tests compare each with the exact roots the matrix
was built from.
"""
import tomllib
from pathlib import Path

import numpy as np
import pytest

from engine import params as P
from engine.analysis.cubic import max_real_root, max_root, plus_det2
from engine.analysis.stability import jacobian_max_real_eig, linearisation, max_real_eig
from engine.blocks import run_block
from engine.scene import Scene

EPS = np.finfo(float).eps
BOUND_FACTOR = 8.0
SPEC = Path(__file__).resolve().parents[2] / "specs" / "fig09.toml"


def _structured(a, b, c, d):
    a, b, c, d = np.broadcast_arrays(*(np.asarray(x, float) for x in (a, b, c, d)))
    J = np.zeros(a.shape + (3, 3))
    J[..., 0, 0], J[..., 0, 2], J[..., 2, 0], J[..., 2, 2] = a, b, c, d
    J[..., 1, 2], J[..., 2, 1] = -1.0, 1.0
    return J


def _lapack_and_tolerance(J):
    """LAPACK's max Re lam and BOUND_FACTOR times the sum of both methods' bounds."""
    w, V = np.linalg.eig(J)
    i = np.argmax(w.real, axis=-1)
    lam = np.take_along_axis(w, i[:, None], 1)[:, 0]
    x = np.take_along_axis(V, i[:, None, None], 2)[:, :, 0]
    y = np.take_along_axis(np.linalg.inv(V), i[:, None, None], 1)[:, 0, :]   # y x = 1
    kappa = np.linalg.norm(x, axis=1) * np.linalg.norm(y, axis=1)
    a, b, c, d = J[:, 0, 0], J[:, 0, 2], J[:, 2, 0], J[:, 2, 2]
    coef = (np.ones_like(a), -(a + d), 1 + a * d - b * c, -a)
    L = np.abs(lam)
    size = sum(np.abs(ck) * L ** (3 - k) for k, ck in enumerate(coef))
    dP = np.abs((3 * lam + 2 * coef[1]) * lam + coef[2])
    bound = EPS * (np.linalg.norm(J, axis=(1, 2)) * kappa + size / dP)
    return lam.real, BOUND_FACTOR * bound


# -- the Fig. 9 charts -----------------------------------------------------------------

@pytest.fixture(scope="module", params=[0.1, 0.01], ids=["vd=0.1", "vd=0.01"])
def fig09(request):
    """specs/fig09.toml's averaged scene and (W, v_ref) ranges at 400 x 400, one vd,
    through engine.blocks.run_block as a sweep computes it."""
    vd = request.param
    grid = tomllib.loads(SPEC.read_text())["grid"]
    assert vd in grid["v_d"]
    W = np.linspace(grid["W"]["start"], grid["W"]["stop"], 400)
    v_ref = np.linspace(grid["v_ref"]["start"], grid["v_ref"]["stop"], 400)
    Wg, vg = (x.ravel() for x in np.meshgrid(W, v_ref, indexing="ij"))
    p = P.pack(vd=vd)
    scene = Scene.from_params(p, path="averaged", integrator="",
                              outputs=("F_eff", "max_real_eig", "stable"))
    points = np.column_stack([Wg, np.zeros_like(Wg), vg, np.full_like(Wg, vd)])
    res = run_block(scene, points, p)
    J, F, lam = linearisation(vg, Wg, p, vd=vd)
    return {"res": res, "J": J, "F": F, "lam": lam}


def test_fig09_block_is_the_fused_kernel(fig09):
    """run_block's averaged path returns the kernel's lam and F, bit for bit."""
    out = fig09["res"].outputs
    assert np.array_equal(out["max_real_eig"], fig09["lam"])
    assert np.array_equal(out["F_eff"], fig09["F"])
    assert np.array_equal(max_real_eig(fig09["J"]), fig09["lam"])


def test_fig09_max_real_eig_matches_lapack(fig09):
    """Every point of the 400 x 400 chart within the bounds; largest difference 2.9e-14."""
    lap, tol = _lapack_and_tolerance(fig09["J"])
    diff = np.abs(fig09["lam"] - lap)
    assert np.all(diff <= tol), np.max(diff / tol)
    assert diff.max() < 1e-13


def test_fig09_stable_classification_is_lapacks(fig09):
    """``stable`` (lam < 0) is LAPACK's at every point; no point is within 1e-12 of the
    threshold (the nearest: |lam| = 6.1e-7 at vd = 0.1, 1.9e-7 at vd = 0.01), so the
    agreement does not hang on the last digits."""
    lap = np.linalg.eigvals(fig09["J"]).real.max(axis=-1)
    assert np.array_equal(fig09["res"].outputs["stable"], (lap < 0).astype(float))
    assert np.count_nonzero(np.abs(lap) < 1e-12) == 0


# -- random matrices of the Jacobian's structure ---------------------------------------

@pytest.mark.parametrize("decades", [1, 3, 8, 15])
def test_random_structured_matrices_match_lapack(decades):
    """a, b, c, d of random sign and magnitude 10**U(-decades, decades)."""
    rng = np.random.default_rng(decades)
    n = 20000
    J = _structured(*(rng.choice([-1.0, 1.0], n) * 10.0 ** rng.uniform(-decades, decades, n)
                      for _ in range(4)))
    lap, tol = _lapack_and_tolerance(J)
    diff = np.abs(max_real_eig(J) - lap)
    assert np.all(diff <= tol), np.max(diff / tol)


def test_general_matrices_go_to_lapack_and_bad_rows_to_nan():
    """max_real_eig: a matrix without the fixed entries is LAPACK's; NaN / inf -> NaN."""
    rng = np.random.default_rng(7)
    G = rng.normal(size=(5, 3, 3))
    S = _structured([-2.0, 0.5], [1.0, -3.0], [-4.0, 2.0], [0.3, -1.0])
    bad = np.concatenate([S[:1], S[:1]])
    bad[0, 0, 2], bad[1, 2, 1] = np.nan, np.inf   # inside / outside the fixed entries
    got = max_real_eig(np.concatenate([G, S, bad]))
    assert np.array_equal(got[:5], np.linalg.eigvals(G).real.max(axis=-1))
    assert np.array_equal(got[5:7], [jacobian_max_real_eig(*S[i, [0, 0, 2, 2], [0, 2, 0, 2]])
                                     for i in range(2)])
    assert np.isnan(got[7:]).all()
    assert max_real_eig(S.reshape(2, 1, 3, 3)).shape == (2, 1)


# -- constructed hard cases ------------------------------------------------------------

def _with_roots(r1, r2, r3):
    """(a, b, c, d) with b = 1 whose characteristic polynomial has the roots r1, r2, r3."""
    c2 = -(r1 + r2 + r3)
    c1 = r1 * r2 + r1 * r3 + r2 * r3
    c0 = -r1 * r2 * r3
    a = float(np.real(-c0))
    d = float(np.real(-c2)) - a
    return a, 1.0, 1.0 + a * d - float(np.real(c1)), d


# (roots, order of the root of largest real part: 1 simple, 2 double, 3 triple)
HARD = {
    "triple -1/2 (binary exact)": ((-0.5, -0.5, -0.5), 3),
    "triple 2 (binary exact)": ((2.0, 2.0, 2.0), 3),
    "triple -0.3": ((-0.3, -0.3, -0.3), 3),
    "triple zero": ((0.0, 0.0, 0.0), 3),
    "double -1/2 is the max": ((-0.5, -0.5, -1.0), 2),
    "double 0.7 is the max": ((0.7, 0.7, -1.9), 2),
    "double -2 below a simple -1/4": ((-2.0, -2.0, -0.25), 1),
    "zero root is the max": ((0.0, -1.0, -2.0), 1),
    "zero root beside 1 and -2": ((0.0, 1.0, -2.0), 1),
    "purely imaginary pair +-2i": ((2j, -2j, -1.0), 1),
    "purely imaginary pair +-i/2, real -64": ((0.5j, -0.5j, -64.0), 1),
    "pair 0.1 +- 3i": ((0.1 + 3j, 0.1 - 3j, -0.2), 1),
}


@pytest.mark.parametrize("name", list(HARD))
def test_constructed_hard_cases_against_their_exact_roots(name):
    """Simple: within 8 eps ||J||. Double / triple: both methods within
    8 (eps)**(1/m) ||J|| of the exact root (an m-fold root moves by delta**(1/m));
    the binary-exact constructions come out exact here."""
    roots, order = HARD[name]
    a, b, c, d = _with_roots(*roots)
    J = _structured(a, b, c, d)
    exact = max(np.real(r) for r in roots)
    tol = 8.0 * EPS ** (1.0 / order) * np.linalg.norm(J)
    ours = jacobian_max_real_eig(a, b, c, d)
    lap = np.linalg.eigvals(J).real.max()
    assert abs(ours - exact) <= tol and abs(lap - exact) <= tol
    if "binary exact" in name or "zero" in name:
        assert ours == exact


def test_not_finite_in_nan_out():
    for args in [(np.nan, 1.0, 1.0, 1.0), (1.0, np.inf, 1.0, 1.0), (1.0, 1.0, -np.inf, 1.0),
                 (1.0, 1.0, 1.0, np.nan)]:
        assert np.isnan(jacobian_max_real_eig(*args))
    assert np.isnan(max_real_root(np.nan, 1.0, 1.0)) and np.isnan(max_real_root(1.0, np.inf, 0.0))


# -- scales ---------------------------------------------------------------------------

@pytest.mark.parametrize("k", [-330, -250, -100, 0, 100, 250, 330])
def test_cubic_is_scale_covariant_over_the_exponent_range(k):
    """Roots of l**3 + c2 s l**2 + c1 s**2 l + c0 s**3 are s times those of the
    unscaled cubic (s = 2**k, exact): the power-of-two scaling loses nothing and no
    intermediate overflows or underflows, from root scales 1e-99 to 1e99."""
    rng = np.random.default_rng(3)
    s = 2.0 ** k
    for c2, c1, c0 in rng.normal(size=(200, 3)) * 10.0 ** rng.uniform(-2, 2, (200, 3)):
        ref = max_real_root(c2, c1, c0)
        got = max_real_root(c2 * s, c1 * s * s, c0 * s * s * s) / s
        assert got == pytest.approx(ref, rel=4 * EPS, abs=4 * EPS * max(abs(c2), 1.0))


def test_matrix_scales_balancing_and_huge_entries():
    """A similarity diag(2**j, 1, 1) moves b <-> c and keeps the eigenvalues: the answer
    is the same with b, c 600 decades apart (np.linalg.eigvals returns 3 for the second
    matrix instead of 2.4656: its balancing loses the coupling b c = -1). Entries near the
    largest double are scaled, not overflowed."""
    for a, b, c, d in [(-2.0, 1.5, 0.75, 0.25), (3.0, 1.0, -1.0, 1.0), (0.0, 3.0, -5.0, -1.0)]:
        ref = jacobian_max_real_eig(a, b, c, d)
        assert ref == pytest.approx(np.linalg.eigvals(_structured(a, b, c, d)).real.max(),
                                    abs=8 * EPS * 10)
        for j in (-1000, -200, 200, 1000):
            assert jacobian_max_real_eig(a, b * 2.0 ** j, c * 2.0 ** -j, d) == pytest.approx(
                ref, rel=4 * EPS, abs=4 * EPS)
    # l**3 - 4 l**2 + 5 l - 3: one real root 2.46557123...
    assert jacobian_max_real_eig(3.0, 1e308, -1e-308, 1.0) == pytest.approx(
        np.roots([1, -4, 5, -3]).real.max(), rel=4 * EPS)
    # decoupled (b c = 0): eigenvalues a and the roots of l**2 - d l + 1
    assert jacobian_max_real_eig(1e300, 0.0, 1e300, -1e300) == 1e300
    assert jacobian_max_real_eig(-1e300, 0.0, 1e300, 1.7e308) == pytest.approx(1.7e308, rel=4 * EPS)
    assert jacobian_max_real_eig(1e-300, 1e-300, 1e-300, 1e-300) == pytest.approx(1e-300,
                                                                                rel=4 * EPS)


def test_plus_det2_keeps_a_cancelling_sum_to_an_ulp():
    """1 + a d - b c cancelling to 1e-12 of its terms: within an ulp of the exact value
    (fractions), where the plain expression keeps only ~4 digits."""
    from fractions import Fraction
    rng = np.random.default_rng(5)
    plain = []
    for a, d, b in rng.uniform(1.0, 2.0, (100, 3)):
        c = (1 + a * d) / b * (1 + 1e-12)
        exact = float(1 + Fraction(a) * Fraction(d) - Fraction(b) * Fraction(c))
        assert abs(plus_det2(1.0, a, b, c, d) - exact) <= EPS * abs(exact)
        plain.append(abs(1 + a * d - b * c - exact) / abs(exact))
    assert max(plain) > 1e-6


def test_max_root_says_whether_the_largest_is_real():
    assert max_root(-6.0, 12.0, -8.0) == (2.0, True)            # (l - 2)**3
    assert max_root(1.0, 4.0, 4.0) == (0.0, False)              # (l + 1)(l**2 + 4)
    assert max_root(0.0, 0.0, 0.0) == (0.0, True)
