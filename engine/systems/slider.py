"""Slider on a spring whose far end moves at v_ref (paper Secs. 4-7, DESIGN.md §1).

State ``y = (e, v, z)`` (indices :data:`E`, :data:`V`, :data:`Z`), ``e`` the spring stretch:

    de/dtau = v_ref - v
    dv/dtau = e - F(u, z) + f_slow(tau) + f_dither(tau)
    dz/dtau = law(u, z)                                   (engine.friction.laws)

    f_slow = A_s sin(Omega_s tau)                  (scene.slow_force)
    square-velocity:  u = v + W sq,  sq = sign(sin(omega tau)) supplied by the integrator
    sine-velocity:    u = v + W sin(omega tau)
    sine-force:       u = v,  f_dither = W omega sin(omega tau)   (a Omega^2 with a = W/omega)
    none:             u = v

When ``F_mean`` is requested a quadrature state ``y[QF]`` with ``dQ/dtau = F`` follows
(not under error control). The "hold" force of the static laws' stick law is the
friction that makes ``du/dtau = 0``: ``e + f_slow + f_dither`` (+ ``W omega cos(omega tau)``
for sine-velocity, whose interface velocity also moves through the dither).
Slider displacement ``x = v_ref tau - e`` (so means of ``v`` over any window are exact
from two values of ``e``).
"""
from __future__ import annotations

import numpy as np

from .. import params as P
from ..dither import CODE, SINE_FORCE, SINE_VELOCITY, SQUARE_VELOCITY
from ..friction.laws import make_kinks, make_law
from ..jit import njit

E, V, Z = 0, 1, 2
N_BASE = 3


def quadrature_index(scene) -> int:
    """Index of the running integral of F, or -1 when ``F_mean`` is not requested."""
    return N_BASE if "F_mean" in scene.outputs else -1


def make_drive(scene):
    """njit ``drive(t, y, p, sq) -> (u, fext, hold)``: interface velocity, non-friction
    force on the mass and the stick-holding force."""
    kind = CODE[scene.dither]
    slow = scene.slow_force

    @njit(inline="always", error_model="numpy")
    def drive(t, y, p, sq):
        fext = y[E]
        if slow:
            fext += p[P.SLOW_A] * np.sin(p[P.SLOW_OMEGA] * t)
        u = y[V]
        hold = 0.0
        if kind == SQUARE_VELOCITY:
            u += p[P.W] * sq
        elif kind == SINE_VELOCITY:
            wt = p[P.OMEGA] * t
            u += p[P.W] * np.sin(wt)
            hold = p[P.W] * p[P.OMEGA] * np.cos(wt)
        elif kind == SINE_FORCE:
            fext += p[P.W] * p[P.OMEGA] * np.sin(p[P.OMEGA] * t)
        return u, fext, fext + hold
    return drive


def make_rhs(scene):
    """njit ``rhs(t, y, p, sq, dy)`` of the slider for ``scene`` (see module docstring)."""
    drive = make_drive(scene)
    law = make_law(scene)
    qf = quadrature_index(scene)

    @njit(error_model="numpy")
    def rhs(t, y, p, sq, dy):
        u, fext, hold = drive(t, y, p, sq)
        dz, F, _ = law(u, y[Z], hold, p)
        dy[E] = p[P.V_REF] - y[V]
        dy[V] = fext - F
        dy[Z] = dz
        if qf >= 0:
            dy[qf] = F
    return rhs


def make_interface(scene):
    """njit ``interface(t, y, p, sq) -> (u, F, alpha)`` for observables."""
    drive = make_drive(scene)
    law = make_law(scene)

    @njit(inline="always", error_model="numpy")
    def interface(t, y, p, sq):
        u, _, hold = drive(t, y, p, sq)
        _, F, a = law(u, y[Z], hold, p)
        return u, F, a
    return interface


def make_events(scene):
    """``(n_events, events(t, y, p, sq, g))``: the law's kink functions along the trajectory."""
    drive = make_drive(scene)
    n_events, kinks = make_kinks(scene)

    @njit(error_model="numpy")
    def events(t, y, p, sq, g):
        u, _, hold = drive(t, y, p, sq)
        kinks(u, y[Z], hold, p, g)
    return n_events, events


def make_position(scene):
    """njit ``position(t, y, p) = v_ref t - e``, the slider displacement (up to a constant)."""
    @njit(inline="always", error_model="numpy")
    def position(t, y, p):
        return p[P.V_REF] * t - y[E]
    return position


def make_velocity(scene):
    """njit ``velocity(t, y, p, sq) = v``, the slider velocity (dither not included)."""
    @njit(inline="always", error_model="numpy")
    def velocity(t, y, p, sq):
        return y[V]
    return velocity


def error_size(scene) -> int:
    """Leading components under error control: ``(e, v, z)``; the quadrature of F is not."""
    return N_BASE


def make_scales(scene):
    """njit ``scales(p, out)``: natural scales of ``(e, v, z)`` -- ``fc`` (the spring force
    at break-away), ``max(|v_ref|, W)`` (1 when both are 0), ``fc / sigma0`` (the bristle
    deflection at the Coulomb level); used by ``Settings(atol_units="natural")``."""
    @njit(error_model="numpy")
    def scales(p, out):
        fc = abs(p[P.FC])
        vs = max(abs(p[P.V_REF]), abs(p[P.W]))
        out[E] = fc if fc > 0.0 else 1.0
        out[V] = vs if vs > 0.0 else 1.0
        out[Z] = out[E] / p[P.SIGMA0] if p[P.SIGMA0] > 0.0 else 1.0
    return scales


def make_init(scene):
    """njit ``init(p, y)``: ``(e0, v0, z0)`` from ``p``, quadrature states zeroed."""
    n = N_BASE + (quadrature_index(scene) >= 0)

    @njit(inline="always", error_model="numpy")
    def init(p, y):
        y[:] = 0.0
        y[E], y[V], y[Z] = p[P.E0], p[P.V0], p[P.Z0]
    return n, init
