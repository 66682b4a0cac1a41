"""The gallery's independent references (sweeps/gallery/reference.py): converged, equal to
the paper's closed forms where there are some, and equal to the engine's computations of
the same quantities (so that, in the gallery, a gap means a wrong engine model)."""
import numpy as np
import pytest
from scipy.integrate import quad

from engine import params as P
from engine.analysis import effective_friction, sine_force_simplified
from engine.analysis.stability import jacobian
from engine.analysis import max_real_eig
from sweeps.gallery import reference as R

V = np.linspace(-1.2, 1.2, 97)


@pytest.mark.long
@pytest.mark.parametrize("vd", [0.1, 0.01])
def test_sine_average_is_converged_and_equals_scipy_quad(vd):
    p = {**R.SEC5, "vd": vd}
    a = R._averages(V, 0.75, p, "sine")
    assert np.max(np.abs(R._averages(V, 0.75, p, "sine", m=1024) - a)) < 1e-13
    for v in (0.0, 0.3, 0.74, 0.76, 1.1):       # adaptive quad split at u's zero crossings
        t1 = np.arcsin(np.clip(-v / 0.75, -1, 1))
        pts = sorted({t1 % (2 * np.pi), (np.pi - t1) % (2 * np.pi)})
        ref = [quad(lambda th, k=k: R._integrands(np.array(v + 0.75 * np.sin(th)), p)[k],
                    0, 2 * np.pi, points=pts, epsabs=1e-13, epsrel=1e-12, limit=500)[0]
               / (2 * np.pi) for k in range(3)]
        got = R._averages(np.array([v]), 0.75, p, "sine")[:, 0]
        assert np.max(np.abs(got - ref)) < 1e-12, v


def test_square_no_damping_is_eq_5_12():
    """Eq. 5.12 written out: 2 v / (|v+W|/g(v+W) + |v-W|/g(v-W)) + sigma2 v."""
    W, v = 0.5, V[V != 0]
    g = lambda u: 1.0 + 0.5 * np.exp(-(u / 0.1) ** 2)
    eq512 = 2 * v / (np.abs(v + W) / g(v + W) + np.abs(v - W) / g(v - W)) + 0.004 * v
    got = R.effective_friction(v, W, model="no-damping")
    assert np.max(np.abs(got - eq512)) < 1e-14


def test_simplified_sine_is_eq_5_20():
    got = R.effective_friction(V, 0.75, dither="sine-force", model="no-damping", law="coulomb")
    assert np.max(np.abs(got - sine_force_simplified(V, 0.75, 1.0, 0.004))) < 1e-12


@pytest.mark.parametrize("dither, W", [("square-velocity", 0.5), ("sine-force", 0.75)])
@pytest.mark.parametrize("vd", [0.1, 0.01])
def test_the_engine_computes_the_reference_effective_friction(dither, W, vd):
    eng = effective_friction(V, W, P.pack(vd=vd), dither=dither)
    assert np.max(np.abs(eng - R.effective_friction(V, W, vd=vd, dither=dither))) < 1e-7


def test_a_perturbed_g_is_seen():
    eng = effective_friction(V, 0.5, P.pack(fs=1.6))
    assert np.max(np.abs(eng - R.effective_friction(V, 0.5))) > 1e-3


def test_averaged_stability_equals_the_engine_off_the_kink():
    v = np.array([0.05, 0.1, 0.2, 0.5, 0.9])
    for W in (0.0, 0.03, 0.3, 0.7):
        for vd in (0.1, 0.01):
            keep = np.abs(v - W) > 1e-3
            eng = max_real_eig(jacobian(v[keep], np.full(keep.sum(), W), P.pack(vd=vd))[0])
            ref = [R.averaged_max_eig(x, W, vd) for x in v[keep]]
            assert np.max(np.abs(eng - ref)) < 1e-5, (W, vd)


def test_contact_asymptote_has_no_bristle_harmonics():
    """At omega -> infinity z is frozen: F - sigma1(u) dz/dt is the constant Y."""
    Y, F, amps = R.contact_asymptote(sigma1=0.0)
    assert np.allclose(F, Y) and np.max(amps) < 1e-15
