"""Mechanical systems: njit right-hand sides specialised per Scene at compile time.

:func:`make_system` gathers a system module's factories into a :class:`System`.
"""
from __future__ import annotations

from collections.abc import Callable
from typing import NamedTuple

from ..friction.laws import STATIC_LAWS
from . import contact, slider

MODULES = {"slider": slider, "contact": contact}


class System(NamedTuple):
    """A scene's compiled system pieces (njit functions and sizes)."""

    n: int                # state size incl. quadrature states
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
    z_index: int          # index of the bristle deflection z in y


def make_system(scene) -> System:
    """Build the :class:`System` of ``scene.system`` for ``scene``."""
    mod = MODULES[scene.system]
    n, init = mod.make_init(scene)
    n_events, events = mod.make_events(scene)
    return System(
        n=n, n_err=mod.error_size(scene), rhs=mod.make_rhs(scene), n_events=n_events,
        events=events,
        interface=mod.make_interface(scene), position=mod.make_position(scene),
        velocity=mod.make_velocity(scene), init=init, qf=mod.quadrature_index(scene),
        scales=mod.make_scales(scene), event_jumps=scene.friction in STATIC_LAWS,
        z_index=mod.Z,
    )


__all__ = ["MODULES", "System", "contact", "make_system", "slider"]
