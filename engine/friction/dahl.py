"""Dahl's friction law (P. R. Dahl, 1968; the form of issue 35), through the model contract.

    dz/dt = u sgn(r) |r|**dahl_alpha,    r = 1 - sigma0 z sgn(u) / fc
    F     = sigma0 z + sigma2 u                          (sigma2 u only with the viscous effect)

``u`` is the interface velocity (``v + W sin(omega tau)`` on the slider with velocity dither).
With ``dahl_alpha = 1``, ``dz/dt = u - sigma0 |u| z / fc``: LuGre with ``g = fc`` and
``sigma1 = 0`` (tests/engine/test_models_dahl.py checks it). The deflection relaxes onto
``z_ss = fc sgn(u) / sigma0`` asymptotically for ``dahl_alpha >= 1`` (the allowed range:
below 1 it would reach it in finite time, where the rate is not Lipschitz). One switch: ``u``,
the corner of ``sgn(u)`` (the rate's slope in ``u`` jumps from ``|r|**a`` to ``(2 - r)**a``
there: from ~0 to ~2**a where ``z`` is saturated). Not ``r = 0``: ``z`` only approaches
``z_ss``, and the rate is C1 in ``r`` there for ``dahl_alpha >= 1``. Phases as LuGre's: stick
is ``|u| < stick_band``.
Steady state: ``F_ss(u) = fc sgn(u) + sigma2 u`` (the averaged path's curve).
"""
from __future__ import annotations

from .. import params as P
from ..contract import FrictionLaw, LawKernels, Param
from .laws import bristle_state, steady_curve


class Dahl(FrictionLaw):
    name = "dahl"
    # dahl_alpha < 1 (z reaching z_ss in finite time, the rate not Lipschitz at r = 0) would
    # need a saturated mode to hold r = 0 without chattering: refused until it has one
    params = {"dahl_alpha": Param(1.0, "1", "Dahl's shape exponent (1: LuGre with g = fc, "
                                  "sigma1 = 0)", lo=1.0, hi=10.0)}
    phases = "band"
    # the corner at u = 0 is probed for grazing too (engine.integrators.events): where z is
    # saturated and u dips below zero and back inside one step, DP5 saw neither end of the
    # dip and passed the corner unseen -- the servo under sine-velocity dither (W 0.3,
    # omega 100, v_ref 0.1, dahl_alpha 1.5) took F_mean 1.8e-4 off at rtol 1e-8 and the same
    # wrong answer, 1.2e-6 off, at 1e-10 and 1e-11 (tests/engine/test_models_reference.py,
    # case dahl-a1.5-servo). Under a sine dither it also caps a step at a quarter of the
    # dither's period (engine.kernels.period_cap: a step sees one dip at most). Both cost
    # 0.95-1.20x the time (docs/ACCURACY.md 9).
    switch_jumps = True

    def effects(self, scene):
        return {"stribeck": False, "bristle damping": False}   # Dahl has neither

    def relaxation_factor(self, values):
        # d(rate)/dz = -a sigma0 |u| |r|**(a - 1) / fc, and |r| reaches 2 right after a
        # reversal of a saturated z: a 2**(a - 1) times LuGre's rate (RK4 at draft went
        # non-finite at dahl_alpha 10 without it: tests/sweeps/spec/test_fixed_step_laws.py)
        a = max(values["dahl_alpha"])
        return a * 2.0 ** (a - 1.0)

    def build(self, b):
        Z, ia, viscous = b.z0, b.ix["dahl_alpha"], b.scene.viscous

        @b.jit(inline="always", error_model="numpy")
        def rate(u, z, p):
            su = 1.0 if u > 0.0 else (-1.0 if u < 0.0 else 0.0)
            r = 1.0 - p[P.SIGMA0] * z * su / p[P.FC]
            sr = 1.0 if r > 0.0 else (-1.0 if r < 0.0 else 0.0)
            a, ar = p[ia], abs(r)
            # the common exponents without pow (the same numbers: |r|**1, |r|**2 are exact)
            w = ar if a == 1.0 else (ar * ar if a == 2.0 else ar ** a)
            return u * sr * w

        @b.jit(inline="always", error_model="numpy")
        def force_of(u, z, p):
            F = p[P.SIGMA0] * z
            if viscous:
                F += p[P.SIGMA2] * u
            return F

        @b.jit(inline="always", error_model="numpy")
        def rates(u, y, dy, hold, p):
            dy[Z] = rate(u, y[Z], p)
            return force_of(u, y[Z], p)

        @b.jit(inline="always", error_model="numpy")
        def force(u, y, hold, p):
            return force_of(u, y[Z], p), (0.0 if abs(u) < p[P.STICK_BAND] else 1.0)

        @b.jit(inline="always", error_model="numpy")
        def switches(u, y, hold, p, g):
            g[0] = u

        init, scales = bristle_state(b)
        return LawKernels(rates, force, 1, switches, init, scales)

    def build_steady(self, b):
        return steady_curve(b, stribeck=False)   # fc sgn(u) + sigma2 u
