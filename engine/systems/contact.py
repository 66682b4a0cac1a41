"""Contact without inertia (paper Sec. 3, Fig. 1): the interface velocity is prescribed.

    u(t) = v_m + v_a cos(omega t)       (sine-velocity; on the cube v_ref plays v_m, W plays v_a)
    u(t) = v_m + v_a sq(omega t)        (square-velocity)
    u(t) = v_m                          (none)
    dz/dt = law(u, z)                   (engine.friction.laws), state y = (z,)

Parameters are dimensional SI (engine.params.CONTACT_DEFAULTS). ``sine-force`` has no
meaning without a mass and is refused. Quadrature states follow ``z`` when needed:
``y[QF]`` = running integral of F (``F_mean``), ``y[QX]`` = running integral of u (the
displacement, for ``v_mean`` / ``v_slow_p2p``); with a bristle law neither is under error
control. The static laws have no state here: ``F = g(u) sgn(u) + sigma2 u`` and, inside the
Karnopp band, the holding force 0 (nothing drives the contact); the quadratures are then
the only dynamics and are error-controlled (:func:`error_size`).
"""
from __future__ import annotations

import numpy as np

from .. import params as P
from ..dither import CODE, SINE_FORCE, SINE_VELOCITY, SQUARE_VELOCITY
from ..friction.laws import STATIC_LAWS, make_kinks, make_law
from ..jit import njit

Z = 0
N_BASE = 1


def error_size(scene) -> int:
    """Leading components under error control. A static law leaves ``z`` unused, so the
    quadratures of ``F`` and ``u`` are the only dynamics: they are controlled too (without
    them the step grew unchecked and v_mean of a sine-dithered Stribeck contact came out
    6.5 % off). With a bristle law ``z`` alone sets the step."""
    n, _ = make_init(scene)
    return n if scene.friction in STATIC_LAWS else N_BASE


def make_scales(scene):
    """njit ``scales(p, out)``: natural scales of the controlled components (used by
    ``Settings(atol_units="natural")``): ``z ~ fc / sigma0`` (metres: the bristle
    deflection at the Coulomb level), the force integral ``~ fc`` (N s), the displacement
    ``~ max(|v_m|, v_a)`` (m)."""
    qf, qx = quadrature_index(scene), position_index(scene)
    m = error_size(scene)

    @njit(error_model="numpy")
    def scales(p, out):
        fc = abs(p[P.FC]) if p[P.FC] != 0.0 else 1.0
        out[Z] = fc / p[P.SIGMA0] if p[P.SIGMA0] > 0.0 else 1.0
        vs = max(abs(p[P.V_REF]), abs(p[P.W]))
        if 0 <= qf < m:
            out[qf] = fc
        if 0 <= qx < m:
            out[qx] = vs if vs > 0.0 else 1.0
    return scales


def quadrature_index(scene) -> int:
    """Index of the running integral of F, or -1 when ``F_mean`` is not requested."""
    return N_BASE if "F_mean" in scene.outputs else -1


def position_index(scene) -> int:
    """Index of the running integral of u, or -1 when no velocity observable is requested."""
    if not {"v_mean", "v_slow_p2p"} & set(scene.outputs):
        return -1
    return N_BASE + (quadrature_index(scene) >= 0)


def make_speed(scene):
    """njit ``speed(t, p, sq) -> u``, the prescribed interface velocity."""
    kind = CODE[scene.dither]
    if kind == SINE_FORCE:
        raise ValueError("dither: 'sine-force' needs a mass; the contact system takes "
                         "'none', 'square-velocity' or 'sine-velocity'")

    @njit(inline="always", error_model="numpy")
    def speed(t, p, sq):
        if kind == SQUARE_VELOCITY:
            return p[P.V_REF] + p[P.W] * sq
        if kind == SINE_VELOCITY:
            return p[P.V_REF] + p[P.W] * np.cos(p[P.OMEGA] * t)
        return p[P.V_REF]
    return speed


def make_rhs(scene):
    """njit ``rhs(t, y, p, sq, dy)`` of the contact for ``scene``."""
    speed = make_speed(scene)
    law = make_law(scene)
    qf, qx = quadrature_index(scene), position_index(scene)

    @njit(error_model="numpy")
    def rhs(t, y, p, sq, dy):
        u = speed(t, p, sq)
        dz, F, _ = law(u, y[Z], 0.0, p)
        dy[Z] = dz
        if qf >= 0:
            dy[qf] = F
        if qx >= 0:
            dy[qx] = u
    return rhs


def make_interface(scene):
    """njit ``interface(t, y, p, sq) -> (u, F, alpha)``."""
    speed = make_speed(scene)
    law = make_law(scene)

    @njit(inline="always", error_model="numpy")
    def interface(t, y, p, sq):
        u = speed(t, p, sq)
        _, F, a = law(u, y[Z], 0.0, p)
        return u, F, a
    return interface


def make_events(scene):
    """``(n_events, events(t, y, p, sq, g))``: the law's kink functions."""
    speed = make_speed(scene)
    n_events, kinks = make_kinks(scene)

    @njit(error_model="numpy")
    def events(t, y, p, sq, g):
        kinks(speed(t, p, sq), y[Z], 0.0, p, g)
    return n_events, events


def make_position(scene):
    """njit ``position(t, y, p)``: integral of u (0.0 when not tracked)."""
    qx = position_index(scene)

    @njit(inline="always", error_model="numpy")
    def position(t, y, p):
        return y[qx] if qx >= 0 else 0.0
    return position


def make_velocity(scene):
    """njit ``velocity(t, y, p, sq) = u(t)``."""
    speed = make_speed(scene)

    @njit(inline="always", error_model="numpy")
    def velocity(t, y, p, sq):
        return speed(t, p, sq)
    return velocity


def make_init(scene):
    """``(n, init(p, y))``: ``z0`` from ``p``, quadrature states zeroed."""
    n = N_BASE + (quadrature_index(scene) >= 0) + (position_index(scene) >= 0)

    @njit(inline="always", error_model="numpy")
    def init(p, y):
        y[:] = 0.0
        y[Z] = p[P.Z0]
    return n, init
