"""Contact without inertia (paper Sec. 3, Fig. 1): the interface velocity is prescribed.

    u(t) = v_m + v_a cos(omega t)       (sine-velocity; on the cube v_ref plays v_m, W plays v_a)
    u(t) = v_m + v_a sq(omega t)        (square-velocity)
    u(t) = v_m                          (none)
    dz/dt = law(u, z)                   (the friction law's states), y = (z,) + quadratures

Parameters are dimensional SI (engine.params.CONTACT_DEFAULTS). ``sine-force`` has no
meaning without a mass and is refused. Quadrature states follow ``z`` when needed:
``y[QF]`` = running integral of F (``F_mean``), ``y[QX]`` = running integral of u (the
displacement, for ``v_mean`` / ``v_slow_p2p``); with a bristle law neither is under error
control. The static laws have no state here: ``F = g(u) sgn(u) + sigma2 u`` and, inside the
Karnopp band, the holding force 0 (nothing drives the contact); the quadratures are then
the only dynamics and are error-controlled (:meth:`Contact.error_size`).
"""
from __future__ import annotations

import math


from .. import params as P
from ..contract import MechanicalSystem, ModelError, SystemKernels
from ..dither import CODE, SINE_FORCE, SINE_VELOCITY, SQUARE_VELOCITY


def position_index(b) -> int:
    """Index of the running integral of u (the system's tail state), or -1 when no velocity
    observable is requested."""
    if not {"v_mean", "v_slow_p2p"} & set(b.scene.outputs):
        return -1
    return b.tail0


def make_speed(b):
    """njit ``speed(t, p, sq) -> u``, the prescribed interface velocity."""
    kind = CODE[b.scene.dither]
    if kind == SINE_FORCE:
        raise ModelError("dither: 'sine-force' needs a mass; the contact system takes "
                         "'none', 'square-velocity' or 'sine-velocity'")

    @b.jit(inline="always", error_model="numpy")
    def speed(t, p, sq):
        if kind == SQUARE_VELOCITY:
            return p[P.V_REF] + p[P.W] * sq
        if kind == SINE_VELOCITY:
            return p[P.V_REF] + p[P.W] * math.cos(p[P.OMEGA] * t)
        return p[P.V_REF]
    return speed


class Contact(MechanicalSystem):
    """The contact of Sec. 3 (module docstring) as a model of the contract: no states of
    its own; the displacement quadrature is its tail state."""

    name = "contact"
    state_names = ()
    defaults = P.CONTACT_DEFAULTS
    # SI: z ~ fc / sigma0 = 1e-5 m, so the levels' absolute atol (1e-3 rtol) held z to 1e-3
    # rtol / 1e-5 = 100 rtol: LuGre at v_m = 1e-3, v_a = 3e-3, omega = 1000 was 5.8e-6 off
    # in F_mean at reference, 3.4e-4 at standard (tests/accuracy/test_contact_levels.py)
    natural_atol = True

    def n_tail(self, scene) -> int:
        return 1 if {"v_mean", "v_slow_p2p"} & set(scene.outputs) else 0

    def error_size(self, scene, law, n_law: int, n_total: int) -> int:
        """A stateless law (Stribeck, Coulomb) leaves ``z`` unused, so the quadratures of
        ``F`` and ``u`` are the only dynamics: they are controlled too (without them the step
        grew unchecked and v_mean of a sine-dithered Stribeck contact came out 6.5 % off).
        With a bristle law ``z`` alone sets the step."""
        return n_total if getattr(law, "stateless", False) else n_law

    def build(self, b):
        speed = make_speed(b)
        qx = position_index(b)

        @b.jit(inline="always", error_model="numpy")
        def drive(t, y, p, sq):
            return speed(t, p, sq), 0.0, 0.0

        @b.jit(inline="always", error_model="numpy")
        def dynamics(t, y, p, sq, u, fext, F, dy):
            if qx >= 0:
                dy[qx] = u

        @b.jit(inline="always", error_model="numpy")
        def position(t, y, p):
            """The integral of u (0.0 when not tracked)."""
            return y[qx] if qx >= 0 else 0.0

        @b.jit(inline="always", error_model="numpy")
        def velocity(t, y, p, sq):
            return speed(t, p, sq)

        @b.jit(inline="always", error_model="numpy")
        def init(p, y):
            pass

        qf, m = b.qf, b.n_err

        @b.jit(inline="always", error_model="numpy")
        def scales(p, out):
            """The force integral ``~ fc t_end`` (N s) and the displacement ``~ max(|v_m|,
            v_a) t_end`` (m), where controlled (a stateless law: Contact.error_size; the law
            scales z: ``fc / sigma0``, metres). Without ``t_end`` (before 2026-11-30) the
            scales assumed a run of 1 s, but the contact's runs last milliseconds, so atol
            outweighed rtol: a Stribeck contact at omega 1e6 was 1.3e-6 off in F_mean at
            reference."""
            fc = abs(p[P.FC]) if p[P.FC] != 0.0 else 1.0
            vs = max(abs(p[P.V_REF]), abs(p[P.W]))
            span = p[P.T_END] if p[P.T_END] > 0.0 else 1.0
            if 0 <= qf < m:
                out[qf] = fc * span
            if 0 <= qx < m:
                out[qx] = (vs if vs > 0.0 else 1.0) * span

        return SystemKernels(drive, dynamics, position, velocity, init, scales)
