"""Harmonic balance of the Sec. 3 contact model (Appendix A) against an independent
time-domain periodic steady state (scipy DOP853, rtol 1e-11, periodic initial state by
shooting: the z equation is linear, so z* = z_T(0) / (1 - (z_T(1) - z_T(0)))), the
paper's Bessel-function coefficients (Eq. A.4), and the Fig. 1 / Fig. 2 claims.
Parameters: Fig. 1 (engine.params.CONTACT_DEFAULTS), v_m = v_a = 1e-3 m/s."""
import numpy as np
import pytest
from scipy.integrate import quad, solve_ivp
from scipy.special import iv

from engine import params as P
from engine import status as ST
from engine.analysis.hbm import contact_hbm, galerkin_terms

PC = P.pack(P.CONTACT_DEFAULTS)
S0, S1, FC, FS, VS, VD = 1e5, 1e3, 1.0, 1.5, 1e-3, 1e-3
VM = VA = 1e-3


def _g(u):
    return FC + (FS - FC) * np.exp(-np.abs(u) / VS)          # delta = 1 (Sec. 3)


def _friction(u, z):
    return S0 * z + S1 * np.exp(-(u / VD) ** 2) * (u - S0 * np.abs(u) * z / _g(u))


def _time_domain(omega, t, v_m=VM, v_a=VA):
    T = 2 * np.pi / omega
    rhs = lambda s, z: v_m + v_a * np.cos(omega * s) - S0 * np.abs(v_m + v_a * np.cos(omega * s)) * z / _g(v_m + v_a * np.cos(omega * s))
    kw = {"method": "DOP853", "rtol": 1e-11, "atol": 1e-18}
    z0 = solve_ivp(rhs, (0, T), [0.0], **kw).y[0, -1]
    z1 = solve_ivp(rhs, (0, T), [1e-5], **kw).y[0, -1]
    zstar = z0 / (1 - (z1 - z0) / 1e-5)
    z = solve_ivp(rhs, (0, T), [zstar], dense_output=True, **kw).sol(t)[0]
    u = v_m + v_a * np.cos(omega * t)
    return _friction(u, z)


@pytest.mark.parametrize("omega", [3.0, 100.0, 3000.0])
def test_hbm_matches_time_domain_steady_state(omega):
    r = contact_hbm(VM, VA, omega, PC)
    assert r.status == ST.OK
    F_ref = _time_domain(omega, r.t[::64])
    assert np.abs(r.F[::64] - F_ref).max() < 1e-7 * np.abs(F_ref).max()


def test_hbm_with_velocity_reversal_converges_algebraically_to_time_domain():
    """v_a = 2 v_m: |u| has kinks, convergence is algebraic; the default tolerance is
    met by H = 1024 only loosely, the returned 'change' bounds the error."""
    omega = 100.0
    r = contact_hbm(VM, 2 * VA, omega, PC, rtol=1e-5)
    assert r.status == ST.OK
    F_ref = _time_domain(omega, r.t[::64], v_a=2 * VA)
    assert np.abs(r.F[::64] - F_ref).max() < 2 * r.change + 1e-9
    assert contact_hbm(VM, 2 * VA, omega, PC, rtol=1e-12, H_max=64, n_eval=258).status == ST.FAILED


def test_fourier_terms_are_appendix_a_bessel_coefficients():
    """Eq. A.4 (Q_n) and g's expansion e^{p cos} = I_0(p) + 2 sum I_n(p) cos(n wt),
    p = -v_a/v_s, p1 = -v_m/v_s, alpha0 = fc, alpha1 = fs - fc."""
    H, p, p1, a1 = 6, -VA / VS, -VM / VS, FS - FC
    G, _K, R = galerkin_terms(H, VM, VA, PC)
    I = lambda n: iv(n, p)
    Q = [VM * FC + a1 * VM * np.exp(p1) * I(0) + a1 * VA * np.exp(p1) * I(1),
         VA * FC + 2 * a1 * VM * np.exp(p1) * I(1) + a1 * VA * np.exp(p1) * (I(2) + I(0))]
    Q += [a1 * VM * np.exp(p1) * 2 * I(n) + a1 * VA * np.exp(p1) * (I(n + 1) + I(n - 1))
          for n in range(2, H + 1)]
    assert np.allclose([R[H].real] + [2 * R[H + n].real for n in range(1, H + 1)], Q, rtol=1e-12, atol=1e-16)
    assert G[2 * H].real == pytest.approx(FC + a1 * np.exp(p1) * I(0), rel=1e-13)
    assert np.allclose(G[2 * H + 1:2 * H + 6].real, a1 * np.exp(p1) * I(np.arange(1, 6)), rtol=1e-12)


def test_appendix_a_corrected_R0_and_Sn():
    """sigma0 |u| z for the HBM z: cosine/sine coefficients are DESIGN.md's corrected
    R_0 = sigma0 v_m X_0 + sigma0 (v_a/2) X_1 and S_n = -sigma0 v_m Y_n - sigma0 (v_a/2)
    (Y_{n-1} U(n-1) + Y_{n+1}), with z = X_0 + sum X_n cos - sum Y_n sin (Eq. A.8)."""
    r = contact_hbm(VM, VA, 100.0, PC)
    X, Y = r.z_coef.real, r.z_coef.imag
    prod = np.fft.rfft(S0 * np.abs(r.u) * r.z) / r.z.size
    R0, S = prod[0].real, -2 * prod.imag                    # sin coefficient = -2 Im
    assert R0 == pytest.approx(S0 * VM * X[0] + S0 * VA / 2 * X[1], rel=1e-12)
    n = np.arange(1, 8)
    Sn = -S0 * VM * Y[n] - S0 * VA / 2 * (Y[n - 1] * (n > 1) + Y[n + 1])
    assert np.allclose(S[n], Sn, rtol=1e-9, atol=1e-12 * np.abs(Sn).max())


OMEGAS = np.logspace(0, 5, 11)


@pytest.fixture(scope="module")
def sweep():
    return [contact_hbm(VM, VA, w, PC) for w in OMEGAS]


def test_fig1_loop_grows_then_shrinks(sweep):
    """Fig. 1: 'the size of the loop initially increases with the frequency and then
    gradually shrinks down'."""
    area = np.array([r.loop(w, VA)["loop_area"] for r, w in zip(sweep, OMEGAS)])
    k = int(np.argmax(area))
    assert 0 < k < OMEGAS.size - 1
    assert np.all(np.diff(area[:k + 1]) > 0) and np.all(np.diff(area[k:]) < 0)
    assert area[k] > 5 * area[0] and area[k] > 100 * area[-1]


def test_fig1_friction_near_zero_velocity_falls_with_frequency(sweep):
    """Fig. 1: 'the friction force near zero velocity uniformly decreases with the
    increasing frequency' (F at the instant of least velocity, u = 0)."""
    f0 = np.array([r.loop(w, VA)["F_at_vmin"] for r, w in zip(sweep, OMEGAS)])
    assert np.all(np.diff(f0) < 0)


def test_fig1_asymptotic_characteristic_at_high_frequency():
    """Fig. 1: an asymptotic characteristic with vanishing loop: for omega -> infinity
    z freezes at its average Z = v_m / (sigma0 <|u|/g(u)>) and F -> F_inf(u), a
    single-valued function of u; the distance falls ~1/omega."""
    avg = quad(lambda th: np.abs(VM + VA * np.cos(th)) / _g(VM + VA * np.cos(th)), 0, np.pi,
               epsabs=1e-14, epsrel=1e-13)[0] / np.pi
    Z = VM / (S0 * avg)
    dist = []
    for w in (1e3, 1e4, 1e5):
        r = contact_hbm(VM, VA, w, PC)
        dist.append(np.abs(r.F - _friction(r.u, Z)).max())
    assert dist[2] < 1e-3 and 8 < dist[0] / dist[1] < 12 and 8 < dist[1] / dist[2] < 12


def test_fig2_fundamental_and_total_ripple_attenuate(sweep):
    """Fig. 2 (holds in part): the fundamental and the total AC content of F fall with
    frequency ..."""
    f1 = np.array([abs(r.F_coef[1]) for r in sweep])
    rms = np.array([r.F.std() for r in sweep])
    assert np.all(np.diff(f1) < 0) and rms[-1] < rms[0] / 5


def test_fig2_higher_harmonics_survive_with_bristle_damping(sweep):
    """... but not every higher harmonic: with sigma1 = 1e3 the asymptotic F_inf(u) is
    nonlinear in u, so harmonics 3 and 4 end larger than at omega = 1 rad/s; with
    sigma1 = 0 it is constant and all harmonics vanish."""
    lo, hi = np.abs(sweep[0].F_coef[1:5]), np.abs(sweep[-1].F_coef[1:5])
    assert hi[2] > lo[2] and hi[3] > lo[3]
    p0 = P.pack(P.CONTACT_DEFAULTS, sigma1=0.0)
    lo0 = np.abs(contact_hbm(VM, VA, 1.0, p0).F_coef[1:5])
    hi0 = np.abs(contact_hbm(VM, VA, 1e5, p0).F_coef[1:5])
    assert np.all(hi0 < 1e-3 * lo0)


def test_bad_arguments():
    with pytest.raises(ValueError, match="omega must be > 0"):
        contact_hbm(VM, VA, 0.0, PC)
    with pytest.raises(ValueError, match="n_eval must be even"):
        contact_hbm(VM, VA, 1.0, PC, n_eval=101)


@pytest.mark.long
@pytest.mark.parametrize("omega", [100.0, 3000.0])
def test_hbm_matches_the_engines_contact_system(omega):
    """The engine's own time integration of the contact system (engine.api.simulate,
    dopri5, rtol 1e-10, 1 s of transient = ~80 bristle relaxation times): F_mean over the
    following 10 periods and z(t) at every accepted step of them."""
    from engine import api   # imported plainly: a broken engine.api fails here, never skips
    from engine.scene import Scene
    from engine.settings import Settings
    T = 2 * np.pi / omega
    p = P.pack(P.CONTACT_DEFAULTS, W=VA, v_ref=VM, omega=omega, t_transient=1.0, t_end=1.0 + 10 * T)
    scene = Scene(system="contact", friction="lugre", dither="sine-velocity", integrator="dopri5",
                  outputs=("F_mean",))
    sim = api.simulate(scene, p, Settings(rtol=1e-10, atol=1e-16), record=True)
    r = contact_hbm(VM, VA, omega, PC)
    assert sim.status == ST.OK
    assert sim.outputs["F_mean"] == pytest.approx(r.loop(omega, VA)["F_mean"], rel=1e-9)
    keep = sim.t >= 1.0
    n = np.arange(r.z_coef.size)
    z_hbm = np.real(np.exp(1j * omega * np.outer(sim.t[keep], n[:64])) @ r.z_coef[:64])
    assert np.abs(sim.y[keep, 0] - z_hbm).max() < 1e-8 * np.abs(z_hbm).max()
