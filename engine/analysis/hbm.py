"""Harmonic balance for the Sec. 3 contact model (Eqs. 3.1-3.3, Appendix A).

The interface velocity is prescribed, ``u(t) = v_m + v_a cos(omega t)`` (SI units,
engine.params.CONTACT_DEFAULTS; on the cube's axes v_ref plays v_m and W plays v_a),
and the LuGre bristle state obeys Eq. A.2::

    g(u) dz/dt + sigma0 |u| z = u g(u),      F = sigma0 z + sigma1(u) dz/dt + sigma2 u

with the Stribeck curve of Eq. 2.4 (``delta = 1`` in Sec. 3). The equation is *linear*
in z with periodic coefficients, so the harmonic balance is a linear system, as in
Eq. A.7. We set it up in complex exponentials: with ``z = sum_n c_n e^{i n omega t}``,
``|n| <= H``, and the Fourier coefficients ``G_m``, ``K_m``, ``R_m`` of ``g(u(t))``,
``sigma0 |u(t)|`` and ``u g(u)``, Galerkin projection onto ``e^{i k omega t}`` gives::

    sum_n (i n omega G_{k-n} + K_{k-n}) c_n = R_k,      |k| <= H.

For ``v_a <= v_m`` this is the paper's system (its Bessel-function coefficients are the
exact ``G_m, K_m, R_m``; with DESIGN.md's fixes ``R0 ∋ X1`` and ``S_n = -sigma0 v_m Y_n
...``); here ``G, K, R`` come from an FFT on ``M >= 8H`` samples, which is exact to
rounding for these entire functions and also covers ``v_a > v_m`` (``|u|`` kinks,
algebraic convergence: the max change of F falls ~4x per doubling of H, e.g. ~1e-6 N
at H = 1024 for v_a = 2 v_m, omega = 100 rad/s). H is doubled from ``H0`` until the friction on a fixed grid of
``n_eval`` instants changes by less than ``rtol * max|F| + atol``; otherwise FAILED.

The friction uses ``dz/dt`` from Eq. A.2 (the right-hand side at the converged z)
rather than the differentiated truncated series, which converges one order slower.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .. import params as P
from .. import status as ST
from ..friction.lugre import dz as bristle_rate
from ..friction.lugre import make_force
from ..friction.stribeck import g, sigma1
from ..jit import njit

_force = make_force(bristle_damping=True, viscous=True)


@njit(cache=True, error_model="numpy", entry=True)
def _g(u, p):
    """g(u) (Eq. 2.4) over an array."""
    out = np.empty(u.size)
    for i in range(u.size):
        out[i] = g(u[i], p)
    return out


@njit(cache=True, error_model="numpy", entry=True)
def _friction_force(u, z, p):
    """F = sigma0 z + sigma1(u) dz + sigma2 u with dz/dt of Eq. A.2 (the LuGre bristle
    rate), over arrays of u and z."""
    F = np.empty(u.size)
    for i in range(u.size):
        dz = bristle_rate(u[i], z[i], g(u[i], p), p[P.SIGMA0], 1.0)
        F[i] = _force(z[i], dz, u[i], sigma1(u[i], p), p)
    return F


@dataclass(frozen=True)
class HBMResult:
    """Periodic steady state of the contact model by harmonic balance.

    ``t``, ``u``, ``z``, ``F`` sample one period at ``n_eval`` instants
    ``t_j = j T / n_eval`` (``T = 2 pi / omega``); ``z_coef[n]`` and ``F_coef[n]``,
    ``n = 0..``, are the one-sided complex Fourier coefficients (``x(t) = Re sum_n
    x_n e^{i n omega t}`` with ``x_0`` the mean and ``x_n`` twice the two-sided value,
    so ``|F_coef[n]|`` is the amplitude of harmonic n). ``H`` is the harmonic order used,
    ``change`` the last max change of F between successive H, ``status`` an engine.status code.
    """

    t: np.ndarray
    u: np.ndarray
    z: np.ndarray
    F: np.ndarray
    z_coef: np.ndarray
    F_coef: np.ndarray
    H: int
    change: float
    status: int

    def loop(self, omega: float, v_a: float) -> dict[str, float]:
        """Loop quantities (engine.outputs.HBM): F_mean, F_min, F_max, F_at_vmin, loop_area.

        ``F_at_vmin`` is F at ``omega t = pi`` (least velocity, sample ``n_eval/2``);
        ``loop_area = closed integral of F du`` over one period in time order,
        ``= int_0^T F(t) u'(t) dt`` with ``u' = -v_a omega sin(omega t)`` (periodic
        trapezoid rule, spectrally accurate); positive when the loop runs clockwise
        in the (u, F) plane.
        """
        n = self.F.size
        du = -v_a * omega * np.sin(omega * self.t)
        return {
            "F_mean": float(self.F.mean()),
            "F_min": float(self.F.min()),
            "F_max": float(self.F.max()),
            "F_at_vmin": float(self.F[n // 2]),
            "loop_area": float(np.sum(self.F * du) * (2 * np.pi / omega) / n),
        }


def _coefficients(f_samples: np.ndarray, m_max: int) -> np.ndarray:
    """Two-sided Fourier coefficients f_m, m = -m_max..m_max, from equispaced samples."""
    c = np.fft.fft(f_samples) / f_samples.size
    return c[np.arange(-m_max, m_max + 1) % f_samples.size]


def galerkin_terms(H, v_m, v_a, p):
    """Two-sided Fourier coefficients ``G_m, K_m`` (``|m| <= 2H``) of ``g(u(t))`` and
    ``sigma0 |u(t)|`` and ``R_k`` (``|k| <= H``) of ``u g(u)``, by FFT on ``max(8H, 256)``
    samples. For ``v_a <= v_m``, ``2 Re R_n`` are the paper's ``Q_n`` (Eq. A.4)."""
    M = max(8 * H, 256)
    u = v_m + v_a * np.cos(2 * np.pi * np.arange(M) / M)
    gu = _g(u, p)
    return (_coefficients(gu, 2 * H), _coefficients(p[P.SIGMA0] * np.abs(u), 2 * H),
            _coefficients(u * gu, H))


def _solve(H, v_m, v_a, omega, p):
    """z coefficients c_{-H..H} of the Galerkin system (module docstring)."""
    G, K, R = galerkin_terms(H, v_m, v_a, p)
    n = np.arange(-H, H + 1)
    diff = (n[:, None] - n[None, :]) + 2 * H        # index of m = k - n in G, K
    Amat = 1j * omega * n[None, :] * G[diff] + K[diff]
    return np.linalg.solve(Amat, R)


def _friction(c, H, v_m, v_a, omega, p, n_eval):
    """Sample z and F = sigma0 z + sigma1(u) dz + sigma2 u on n_eval instants."""
    spec = np.zeros(n_eval // 2 + 1, complex)
    spec[:H + 1] = c[H:] * n_eval                   # c[H] is c_0
    z = np.fft.irfft(spec, n_eval)
    t = 2 * np.pi * np.arange(n_eval) / (n_eval * omega)
    u = v_m + v_a * np.cos(omega * t)
    F = _friction_force(u, z, p)
    return t, u, z, F


def contact_hbm(v_m, v_a, omega, p, *, H0=8, H_max=1024, rtol=1e-9, atol=0.0,
                n_eval=8192) -> HBMResult:
    """Periodic LuGre friction of the contact model by harmonic balance (Sec. 3).

    Parameters
    ----------
    v_m, v_a : float
        Mean velocity and velocity amplitude, m/s (Fig. 1: both 1e-3).
    omega : float
        Angular frequency of the velocity variation, rad/s (> 0).
    p : (N_PARAMS,) ndarray
        Parameter vector, SI units (``engine.params.pack(CONTACT_DEFAULTS)``).
    H0, H_max : int
        First and largest number of harmonics (H doubles from H0).
    rtol, atol : float
        Convergence test on F between successive H (N).
    n_eval : int
        Even number of instants per period at which z and F are returned.

    Returns
    -------
    HBMResult (status FAILED if not converged by ``H_max``, NON_FINITE on NaN/inf).
    """
    if not omega > 0:
        raise ValueError(f"omega must be > 0 rad/s, got {omega}")
    if n_eval % 2 or n_eval < 4 * H_max + 2:
        raise ValueError(f"n_eval must be even and >= 4 H_max + 2 = {4 * H_max + 2}, got {n_eval}")
    prev, H, change = None, int(H0), np.inf
    while True:
        c = _solve(H, v_m, v_a, omega, p)
        t, u, z, F = _friction(c, H, v_m, v_a, omega, p, n_eval)
        if not np.all(np.isfinite(F)):
            return _result(t, u, z, F, H, change, ST.NON_FINITE)
        if prev is not None:
            change = float(np.max(np.abs(F - prev)))
            if change <= rtol * np.max(np.abs(F)) + atol:
                return _result(t, u, z, F, H, change, ST.OK)
        if 2 * H > H_max:
            return _result(t, u, z, F, H, change, ST.FAILED)
        prev, H = F, 2 * H


def _result(t, u, z, F, H, change, status):
    n = F.size
    one_sided = lambda x: np.fft.rfft(x) / n * np.r_[1.0, 2.0 * np.ones(n // 2)]
    return HBMResult(t=t, u=u, z=z, F=F, z_coef=one_sided(z), F_coef=one_sided(F),
                     H=H, change=change, status=status)
