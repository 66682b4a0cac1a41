"""Slider on a spring whose far end moves at v_ref (paper Secs. 4-7, DESIGN.md §1).

State ``y = (e, v, z)`` (indices :data:`E`, :data:`V`, :data:`Z`), ``e`` the spring stretch:

    de/dtau = v_ref - v
    dv/dtau = e - F(u, z) + f_slow(tau) + f_dither(tau)
    dz/dtau = law(u, z)                      (the friction law's states, from index Z on)

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

import math


from .. import params as P
from ..contract import MechanicalSystem, SystemKernels
from ..dither import CODE, SINE_FORCE, SINE_VELOCITY, SQUARE_VELOCITY

E, V, Z = 0, 1, 2     # Z: the first state of the friction law (engine.contract layout)


def make_drive(b, slow: bool):
    """njit ``drive(t, y, p, sq) -> (u, fext, hold)``: interface velocity, non-friction
    force on the mass and the stick-holding force."""
    kind = CODE[b.scene.dither]

    @b.jit(inline="always", error_model="numpy")
    def drive(t, y, p, sq):
        fext = y[E]
        if slow:
            fext += p[P.SLOW_A] * math.sin(p[P.SLOW_OMEGA] * t)
        u = y[V]
        hold = 0.0
        if kind == SQUARE_VELOCITY:
            u += p[P.W] * sq
        elif kind == SINE_VELOCITY:
            wt = p[P.OMEGA] * t
            u += p[P.W] * math.sin(wt)
            hold = p[P.W] * p[P.OMEGA] * math.cos(wt)
        elif kind == SINE_FORCE:
            fext += p[P.W] * p[P.OMEGA] * math.sin(p[P.OMEGA] * t)
        return u, fext, fext + hold
    return drive


class Slider(MechanicalSystem):
    """The paper's slider (module docstring) as a model of the contract (engine.contract)."""

    name = "slider"
    state_names = ("e", "v")
    defaults = P.PAPER_DEFAULTS

    def build(self, b):
        drive = make_drive(b, b.scene.slow_force)

        @b.jit(inline="always", error_model="numpy")
        def dynamics(t, y, p, sq, u, fext, F, dy):
            dy[E] = p[P.V_REF] - y[V]
            dy[V] = fext - F

        @b.jit(inline="always", error_model="numpy")
        def position(t, y, p):
            """v_ref t - e, the slider displacement (up to a constant)."""
            return p[P.V_REF] * t - y[E]

        @b.jit(inline="always", error_model="numpy")
        def velocity(t, y, p, sq):
            """v, the slider velocity (dither not included)."""
            return y[V]

        @b.jit(inline="always", error_model="numpy")
        def init(p, y):
            y[E], y[V] = p[P.E0], p[P.V0]

        @b.jit(inline="always", error_model="numpy")
        def scales(p, out):
            """``fc`` (the spring force at break-away) and ``max(|v_ref|, W)`` (1 when both
            are 0), for ``Settings(atol_units="natural")``; the law scales its own states."""
            fc = abs(p[P.FC])
            vs = max(abs(p[P.V_REF]), abs(p[P.W]))
            out[E] = fc if fc > 0.0 else 1.0
            out[V] = vs if vs > 0.0 else 1.0

        return SystemKernels(drive, dynamics, position, velocity, init, scales)


def make_interface(scene):
    """njit ``interface(t, y, p, sq) -> (u, F, alpha)`` of a slider scene (for plots)."""
    from . import make_system
    return make_system(scene).interface
