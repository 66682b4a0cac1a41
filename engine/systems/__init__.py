"""Mechanical systems, and the composition of a system with a friction law into the right-hand
side, events and observers' view of one scene (engine.contract).

:func:`make_system` builds the scene's models (engine.registry) in one :class:`Build` context
and joins them into a :class:`System`:

    rhs(t, y, p, sq, dy):   u, fext, hold = drive(t, y, p, sq)
                            F = law.rates(u, y, dy, hold, p)         (the law's states)
                            dynamics(t, y, p, sq, u, fext, F, dy)    (the system's states)
                            dy[qf] = F                               (F_mean's quadrature)
"""
from __future__ import annotations

from collections.abc import Callable
from typing import NamedTuple

from .. import registry
from ..contract import Build, ModelError
from ..jit import njit


class System(NamedTuple):
    """A scene's compiled system pieces (njit functions and sizes)."""

    n: int                # state size incl. quadrature states and modes
    n_err: int            # components under error control
    rhs: Callable         # rhs(t, y, p, sq, dy)
    n_events: int
    events: Callable      # events(t, y, p, sq, g)
    interface: Callable   # interface(t, y, p, sq) -> (u, F, alpha)
    position: Callable    # position(t, y, p): displacement (its rate is the body velocity)
    velocity: Callable    # velocity(t, y, p, sq): body velocity
    init: Callable        # init(p, y): initial state
    qf: int               # index of the running integral of F, -1 if absent
    scales: Callable      # scales(p, out): natural scale of each error-controlled component
    event_jumps: bool     # the events mark jumps of rhs (static laws' Karnopp band edges)
    z_index: int          # index of the friction law's first state in y
    phases: str           # how the law's phases are read (engine.contract.FrictionLaw)
    update_modes: Callable | None  # update_modes(t, y, p, sq) -> bool, or None (no modes)
    outputs: object       # the system's own observables (engine.contract.SystemOutputs)


def build_context(scene, jit=njit) -> tuple:
    """``(law, system, Build)`` of ``scene``: its models and their layout in y and p."""
    law, sysm = registry.law(scene.friction), registry.system(scene.system)
    if scene.dither not in sysm.dithers:
        raise ModelError(f"dither: {scene.dither!r} is not one the {sysm.name} system takes "
                         f"({', '.join(sysm.dithers)})")
    lay = registry.scene_layout(scene)
    size = lay.size
    n_sys = int(sysm.n_states(scene))
    n_law = int(law.n_states(size))
    n_modes = int(law.n_modes(size))
    for what, k in (("states", n_law), ("modes", n_modes)):
        if not 0 <= k <= registry.MAX_STATES:
            raise ModelError(f"friction {scene.friction!r}: {k} {what}; 0 to "
                             f"{registry.MAX_STATES} allowed")
    qf = n_sys + n_law if "F_mean" in scene.outputs else -1
    tail0 = n_sys + n_law + (qf >= 0)
    m0 = tail0 + int(sysm.n_tail(scene))
    b = Build(jit=jit, scene=scene, ix=lay.ix, size=size, z0=n_sys, n_law=n_law, m0=m0,
              qf=qf, tail0=tail0)
    b.n_err = int(sysm.error_size(scene, law, n_law, m0))
    return law, sysm, b


def make_system(scene) -> System:
    """Build the :class:`System` of ``scene`` (module docstring)."""
    law, sysm, b = build_context(scene)
    lk, sk = law.build(b), sysm.build(b)
    n = b.m0 + int(law.n_modes(b.size))
    drive, dynamics, rates, force = sk.drive, sk.dynamics, lk.rates, lk.force
    sys_init, law_init, qf = sk.init, lk.init, b.qf
    sys_scales, law_scales = sk.scales, lk.scales
    n_events = lk.n_switches if lk.switches is not None else 0
    switches = lk.switches

    @njit(error_model="numpy")
    def rhs(t, y, p, sq, dy):
        u, fext, hold = drive(t, y, p, sq)
        F = rates(u, y, dy, hold, p)
        dynamics(t, y, p, sq, u, fext, F, dy)
        if qf >= 0:
            dy[qf] = F

    @njit(inline="always", error_model="numpy")
    def interface(t, y, p, sq):
        u, _, hold = drive(t, y, p, sq)
        F, a = force(u, y, hold, p)
        return u, F, a

    if n_events:
        @njit(error_model="numpy")
        def events(t, y, p, sq, g):
            u, _, hold = drive(t, y, p, sq)
            switches(u, y, hold, p, g)
    else:
        @njit(error_model="numpy")
        def events(t, y, p, sq, g):
            pass

    @njit(inline="always", error_model="numpy")
    def init(p, y):
        y[:] = 0.0
        sys_init(p, y)
        law_init(p, y)

    @njit(error_model="numpy")
    def scales(p, out):
        sys_scales(p, out)
        law_scales(p, out)

    update_modes = None
    if lk.update_modes is not None:
        law_update = lk.update_modes

        @njit(inline="always", error_model="numpy")
        def update_modes(t, y, p, sq):
            u, _, hold = drive(t, y, p, sq)
            return law_update(u, y, hold, p)

    return System(
        n=n, n_err=b.n_err, rhs=rhs, n_events=n_events, events=events,
        interface=interface, position=sk.position, velocity=sk.velocity, init=init, qf=qf,
        scales=scales, event_jumps=bool(law.switch_jumps), z_index=b.z0,
        phases=law.phases, update_modes=update_modes, outputs=sk.outputs,
    )


__all__ = ["System", "build_context", "make_system"]
