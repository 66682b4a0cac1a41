"""Independent references for the gallery's rules: the paper's formulas written out again
from the paper's numbers with numpy and scipy, sharing no code with ``engine/`` (not its
``g``, ``sigma1``, quadrature or parameter vector), so that an error in the engine's
friction law cannot pass both the engine and the reference.

* :func:`effective_friction`: ``<F>(v)`` of the averaged LuGre slider, Eqs. 5.9-5.10
  (``Y = v / A``, ``<F> = Y (1 - C) + B + sigma2 v`` with ``A = <|u|/g>``, ``B = <sigma1(u) u>``,
  ``C = <sigma1(u) |u|/g>`` over ``u = v + W s(theta)``); ``model="no-damping"`` is Eq. 5.12
  (``<F> = Y + sigma2 v``), ``law="coulomb"`` the simplified model of Sec. 5.2 (``g = fc``,
  Eq. 5.20's model). The square wave is its two-point average; a sine is averaged over
  ``theta`` in ``[0, 2 pi]`` split at the zero crossings of ``u`` into two smooth pieces,
  each by Gauss-Legendre with :data:`GAUSS_NODES` nodes (numpy's ``leggauss``), vectorised
  over ``v``. Convergence: 256 against 1024 nodes differ by < 1e-13 on Figs. 6-8's curves
  (128 nodes: 1e-11 where u touches 0, |v| = W, vd = 0.01;
  tests/sweeps/gallery/test_reference.py); against scipy's adaptive ``quad`` by < 1e-12.
* :func:`contact_asymptote`: the ``omega -> infinity`` friction of the Sec. 3 contact model.
"""
from __future__ import annotations

import numpy as np

#: the paper's Sec. 5 numbers (non-dimensional; Fig. 5 and Sec. 5.1), written out again
SEC5 = {"sigma1": 10.0, "sigma2": 0.004, "vs": 0.1, "fc": 1.0, "fs": 1.5, "delta": 2.0,
        "delta_d": 2.0}
#: Fig. 2's caption (SI units); Sec. 3: "delta = 1 in Eq. (2.4)"
SEC3 = {"sigma0": 1e5, "sigma1": 1e3, "sigma2": 0.0, "fs": 1.5, "fc": 1.0, "vs": 1e-3,
        "vd": 1e-3, "delta": 1.0, "delta_d": 2.0}
GAUSS_NODES = 256


def g(u, p):
    """Eq. 2.4."""
    return p["fc"] + (p["fs"] - p["fc"]) * np.exp(-np.abs(u / p["vs"]) ** p["delta"])


def sigma1(u, p):
    """Eq. 2.5."""
    return p["sigma1"] * np.exp(-np.abs(u / p["vd"]) ** p["delta_d"])


def _integrands(u, p):
    """``|u|/g``, ``sigma1(u) u``, ``sigma1(u) |u|/g`` (stacked on a new first axis)."""
    gu, s1 = g(u, p), sigma1(u, p)
    return np.stack([np.abs(u) / gu, s1 * u, s1 * np.abs(u) / gu])


def _averages(v, W, p, dither, m=GAUSS_NODES):
    """``(A, B, C)`` at the slow velocities ``v`` (shape ``(3, nv)``)."""
    v = np.asarray(v, float)
    if dither == "square-velocity":
        return 0.5 * (_integrands(v + W, p) + _integrands(v - W, p))
    # two smooth pieces per v: between the zero crossings of u = v + W sin(theta), or the
    # two half periods when u keeps its sign
    t1 = np.where(W > np.abs(v), np.arcsin(np.clip(-v / W if W else 0.0, -1, 1)), 0.0)
    t2 = np.where(W > np.abs(v), np.pi - t1, np.pi)
    lo = np.stack([t1, t2], axis=-1)[..., None]            # (nv, 2, 1)
    hi = np.stack([t2, t1 + 2 * np.pi], axis=-1)[..., None]
    x, w = np.polynomial.legendre.leggauss(m)
    th = lo + (hi - lo) * (x + 1) / 2                        # (nv, 2, m)
    vals = _integrands(v[:, None, None] + W * np.sin(th), p)  # (3, nv, 2, m)
    return np.sum(vals * w * (hi - lo) / 2, axis=(-1, -2)) / (2 * np.pi)


def effective_friction(v, W, *, vd=0.1, dither="square-velocity", model="lugre",
                       law="stribeck", **over) -> np.ndarray:
    """``<F>(v)`` on the slow velocities ``v`` (module docstring); ``over`` replaces any of
    :data:`SEC5`; ``law="coulomb"`` sets ``g = fc`` (Sec. 5.2's simplified model)."""
    p = {**SEC5, "vd": vd, **over}
    if law == "coulomb":
        p["fs"] = p["fc"]
    v = np.atleast_1d(np.asarray(v, float))
    A, B, C = _averages(v, W, p, dither)
    with np.errstate(invalid="ignore", divide="ignore"):
        Y = np.where(A > 0, v / A, 0.0)
    if model == "no-damping":
        return Y + p["sigma2"] * v
    return Y * (1.0 - C) + B + p["sigma2"] * v


def on_samples(vf, W, *, n=2001, **kw):
    """:func:`effective_friction` at many samples ``vf``: computed on ``n`` equispaced slow
    velocities over their range and interpolated linearly (RMS interpolation error ~1e-5 on
    Figs. 6, 8). Returns ``(values at vf, grid, values on the grid)``."""
    grid = np.linspace(float(np.min(vf)), float(np.max(vf)), n)
    on_grid = effective_friction(grid, W, **kw)
    return np.interp(vf, grid, on_grid), grid, on_grid


def contact_asymptote(v_m=1e-3, v_a=1e-3, n=4096, **over):
    """The omega -> infinity friction of the Sec. 3 contact model. The bristle state freezes
    at Z, and <dz/dt> = 0 gives Y = sigma0 Z = v_m / <|u|/g(u)> (average over one period,
    n-point periodic trapezoid: spectrally accurate); F = Y + sigma1(u) (u - |u| Y / g(u))
    with u = v_m + v_a cos(theta). Returns ``(Y, F samples, harmonic amplitudes |F_1..F_5|)``
    (N)."""
    p = {**SEC3, **over}
    th = 2 * np.pi * np.arange(n) / n
    u = v_m + v_a * np.cos(th)
    gu = g(u, p)
    Y = v_m / np.mean(np.abs(u) / gu)
    F = Y + sigma1(u, p) * (u - np.abs(u) * Y / gu) + p["sigma2"] * u
    amps = 2 * np.abs(np.fft.rfft(F)) / n
    return Y, F, amps[1:6]


def averaged_rhs(x, v_ref, W, p):
    """Right-hand side of the averaged tracking system, Eqs. 6.4-6.6 (square wave; W = 0:
    Eqs. 6.1-6.3 without dither), state ``x = (Z, e, v)``; Eq. 6.6's second bracket with
    sigma1(v - W) (the paper prints v + W)."""
    Z, e, v = x
    us = (v + W, v - W) if W else (v,)
    rates = [u - p["sigma0"] * abs(u) * Z / g(u, p) for u in us]
    damping = np.mean([sigma1(u, p) * r for u, r in zip(us, rates)])
    F = p["sigma0"] * Z + damping + p["sigma2"] * v
    return np.array([np.mean(rates), v_ref - v, e - F])


def averaged_max_eig(v_ref, W, vd, **over) -> float:
    """Largest real part of the eigenvalues of the averaged system's Jacobian at its
    equilibrium (v = v_ref, Z from <dZ/dt> = 0, e = <F>): central differences (step 1e-7,
    relative) and ``numpy.linalg.eigvals``; good to ~1e-6, so signs are judged only where
    ``|max eig| > 1e-4``."""
    p = {"sigma0": 100.0, **SEC5, "vd": vd, **over}
    us = (v_ref + W, v_ref - W) if W else (v_ref,)
    Z = v_ref / (p["sigma0"] * np.mean([abs(u) / g(u, p) for u in us]))
    x0 = np.array([Z, 0.0, v_ref])
    x0[1] = -averaged_rhs(x0, v_ref, W, p)[2]     # e such that dv/dt = 0 (e = <F>)
    J = np.empty((3, 3))
    for k in range(3):
        h = np.zeros(3)
        h[k] = 1e-7 * max(1.0, abs(x0[k]))
        J[:, k] = ((averaged_rhs(x0 + h, v_ref, W, p) - averaged_rhs(x0 - h, v_ref, W, p))
                   / (2 * h[k]))
    return float(np.linalg.eigvals(J).real.max())
