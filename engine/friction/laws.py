"""The friction laws as compile-time specialised njit closures, shared by both systems.

``make_law(scene) -> law(u, z, hold, p) -> (dz, F, alpha)``

- ``lugre`` (Eq. 2.3, alpha = 1): ``dz = u - sigma0 |u| z / g(u)``,
  ``F = sigma0 z + sigma1(u) dz + sigma2 u``. ``alpha`` is reported as 0 when
  ``|u| < p[STICK_BAND]`` (LuGre has no stick phase of its own; this is the
  stick indicator of the observables) and 1 otherwise.
- ``elastoplastic`` (Eqs. 2.3, 2.6, 2.7 with |z|, docs/MODEL.md): ``dz = u - alpha sigma0 |u| z / g``.
- ``stribeck`` / ``coulomb`` (Eq. 2.2, static): while sliding, ``F = g(u) sgn(u) + sigma2 u``
  (coulomb: ``g = fc``). **Stick law (Karnopp band)**: when ``|u| < p[STICK_BAND]`` the
  friction is the force that holds ``u`` still, ``hold`` (given by the system, e.g.
  ``e + f_slow + f_dither`` for the slider), clipped to ``+-f_break`` with
  ``f_break = fs`` (stribeck) or ``fc`` (coulomb). Inside the band ``du/dt = 0`` while
  ``|hold| <= f_break`` (stick, alpha = 0); beyond it the surplus accelerates ``u`` out
  of the band (breakaway). ``z`` is unused (``dz = 0``).

Effect flags of the Scene fold at compile time: ``stribeck=False`` uses ``g = fc``
without an exp, ``bristle_damping=False`` drops ``sigma1(u)``, ``viscous=False``
drops ``sigma2 u``; ``Scene.delta`` / ``delta_d`` fold the Stribeck exponents. The pieces
(g, sigma1, the bristle rate, alpha, the force) are the functions of :mod:`.stribeck`,
:mod:`.lugre` and :mod:`.elastoplastic`, which the averaged and harmonic-balance paths call
too.
"""
from __future__ import annotations

from .. import params as P
from ..contract import FrictionLaw, LawKernels
from ..jit import njit
from .elastoplastic import alpha as ep_alpha
from .lugre import dz as bristle_rate
from .lugre import make_force
from .stribeck import make_g, make_sigma1

STATIC_LAWS = ("coulomb", "stribeck")   # no bristle state; a Karnopp band, whose edges are jumps


def make_law(scene):
    """njit ``law(u, z, hold, p) -> (dz, F, alpha)`` for ``scene.friction``."""
    maker = {"lugre": _bristle_law, "elastoplastic": _bristle_law,
             "stribeck": _static_law, "coulomb": _static_law}[scene.friction]
    return maker(scene)


def _bristle_law(scene):
    g = make_g(scene.stribeck, scene.delta)
    sigma1 = make_sigma1(scene.bristle_damping, scene.delta_d)
    force = make_force(scene.bristle_damping, scene.viscous)
    elasto = scene.friction == "elastoplastic"

    @njit(inline="always", error_model="numpy")
    def law(u, z, hold, p):
        sigma0 = p[P.SIGMA0]
        gu = g(u, p)
        if elasto:
            a = ep_alpha(z, u, gu, sigma0, p[P.LAM])
            dz = bristle_rate(u, z, gu, sigma0, a)
        else:
            a = 0.0 if abs(u) < p[P.STICK_BAND] else 1.0   # the stick indicator only
            dz = bristle_rate(u, z, gu, sigma0, 1.0)
        return dz, force(z, dz, u, sigma1(u, p), p), a
    return law


def _static_law(scene):
    stribeck = scene.friction == "stribeck" and scene.stribeck
    g = make_g(stribeck, scene.delta)
    viscous = scene.viscous

    @njit(inline="always", error_model="numpy")
    def law(u, z, hold, p):
        if abs(u) < p[P.STICK_BAND]:
            fb = p[P.FS] if stribeck else p[P.FC]
            return 0.0, min(max(hold, -fb), fb), (0.0 if abs(hold) <= fb else 1.0)
        F = g(u, p) * (1.0 if u > 0.0 else -1.0)
        if viscous:
            F += p[P.SIGMA2] * u
        return 0.0, F, 1.0
    return law


def make_kinks(scene):
    """``(n_events, kinks(u, z, hold, p, g))``: functions whose sign changes mark the
    corners of the law (see engine.integrators protocol).

    - lugre: ``u`` (the ``|u|`` in dz);
    - elastoplastic: ``u``, ``|z| - z_ba(u)``, ``|z| - z_ss(u)`` (Eq. 2.7 boundaries);
    - static laws: ``u - band``, ``u + band`` (Karnopp band edges), ``f_break - |hold|``
      (breakaway, inside the band only; +1 outside).
    """
    if scene.friction == "lugre":
        @njit(inline="always", error_model="numpy")
        def kinks(u, z, hold, p, out):
            out[0] = u
        return 1, kinks
    if scene.friction == "elastoplastic":
        gfun = make_g(scene.stribeck, scene.delta)

        @njit(inline="always", error_model="numpy")
        def kinks(u, z, hold, p, out):
            zss = gfun(u, p) / p[P.SIGMA0]
            out[0] = u
            out[1] = abs(z) - p[P.LAM] * zss
            out[2] = abs(z) - zss
        return 3, kinks
    stribeck = scene.friction == "stribeck" and scene.stribeck

    @njit(inline="always", error_model="numpy")
    def kinks(u, z, hold, p, out):
        band = p[P.STICK_BAND]
        out[0] = u - band
        out[1] = u + band
        # breakaway matters only inside the band; outside it the law has no hold kink
        out[2] = ((p[P.FS] if stribeck else p[P.FC]) - abs(hold)) if abs(u) < band else 1.0
    return 3, kinks


# --- the built-in laws as models of the contract (engine.contract) --------------------------

class _Builtin(FrictionLaw):
    """LuGre, elasto-plastic, Stribeck and Coulomb through the contract: their one bristle
    state at ``b.z0`` (the static laws keep it, unused, with rate 0, so that the state
    layout of every system is the same for every built-in law), the kernels of
    :func:`make_law` and :func:`make_kinks`."""

    def __init__(self, name, phases, stateless=False, averaged=None):
        self.name, self.phases, self.stateless = name, phases, stateless
        self.switch_jumps = stateless
        self.averaged = averaged

    def build(self, b):
        scene = b.scene
        law = make_law(scene)
        n_switches, kinks = make_kinks(scene)
        Z = b.z0

        @b.jit(inline="always", error_model="numpy")
        def rates(u, y, dy, hold, p):
            dz, F, _ = law(u, y[Z], hold, p)
            dy[Z] = dz
            return F

        @b.jit(inline="always", error_model="numpy")
        def force(u, y, hold, p):
            _, F, a = law(u, y[Z], hold, p)
            return F, a

        @b.jit(inline="always", error_model="numpy")
        def switches(u, y, hold, p, g):
            kinks(u, y[Z], hold, p, g)

        init, scales = bristle_state(b)
        return LawKernels(rates, force, n_switches, switches, init, scales)

    def build_steady(self, b):
        return steady_curve(b, b.scene.stribeck and self.name != "coulomb")

    def effects(self, scene):
        return {"elasto-plastic phases": True} if self.name == "elastoplastic" else {}


def bristle_state(b):
    """njit ``(init, scales)`` of one bristle deflection at ``b.z0``: ``z0`` from ``p``, and
    its natural scale ``fc / sigma0`` (1 where either vanishes)."""
    Z = b.z0

    @b.jit(inline="always", error_model="numpy")
    def init(p, y):
        y[Z] = p[P.Z0]

    @b.jit(inline="always", error_model="numpy")
    def scales(p, out):
        fc = abs(p[P.FC])
        fc = fc if fc > 0.0 else 1.0
        out[Z] = fc / p[P.SIGMA0] if p[P.SIGMA0] > 0.0 else 1.0

    return init, scales


def steady_curve(b, stribeck: bool):
    """njit ``steady(u, p) = g(u) sgn(u) [+ sigma2 u]``, the friction at constant sliding
    velocity ``u`` (``g = fc`` without the Stribeck effect): the averaged path's curve of the
    laws whose bristles settle at ``z_ss`` (engine.analysis.steady)."""
    g = make_g(stribeck, b.scene.delta)
    viscous = b.scene.viscous

    @b.jit(error_model="numpy")
    def steady(u, p):
        F = g(u, p) * (1.0 if u > 0.0 else (-1.0 if u < 0.0 else 0.0))
        if viscous:
            F += p[P.SIGMA2] * u
        return F
    return steady


BUILTIN = (
    _Builtin("coulomb", "alpha", stateless=True, averaged="static"),
    _Builtin("stribeck", "alpha", stateless=True, averaged="static"),
    _Builtin("lugre", "band", averaged="lugre"),
    _Builtin("elastoplastic", "elasto"),
)
