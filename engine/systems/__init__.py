"""Mechanical systems, and the composition of a system with a friction law into the right-hand
side, events and observers' view of one scene (engine.contract).

:func:`make_system` builds the scene's models (engine.registry) in one :class:`Build` context
and joins them into a :class:`System`:

    rhs(t, y, p, sq, dy):   u, fext, hold = drive(t, y, p, sq)
                            F = law.rates(u, y, dy, hold, p)         (the law's states)
                            dynamics(t, y, p, sq, u, fext, F, dy)    (the system's states)
                            dy[qf] = F                               (F_mean's quadrature)
                            dy[m0:] = 0                              (the law's modes)
"""
from __future__ import annotations

from collections.abc import Callable
from functools import partial
from typing import NamedTuple

from .. import registry
from ..contract import Build, ModelError
from ..jit import njit
from ..user_code import hook
from ..phase_book import N_HIST, O_ON, O_SIZE, O_T0


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
    update_modes: Callable | None  # update_modes(t, y, p, sq, landed) -> bool, or None
    outputs: object       # the system's own observables (engine.contract.SystemOutputs)


def probed(scene) -> bool:
    """A model of ``scene`` is brought: engine.systems.first_step calls its parts and the
    composed system's from Python, so they compile as entries (``njit(entry=True)``, with
    CPython wrappers, cached; engine.kernel_parts)."""
    return registry.is_import_path(scene.friction) or registry.is_import_path(scene.system)


def build_context(scene, jit=None) -> tuple:
    """``(law, system, Build)`` of ``scene``: its models and their layout in y and p."""
    if jit is None:
        jit = partial(njit, entry=True) if probed(scene) else njit
    law, sysm = registry.law(scene.friction), registry.system(scene.system)
    for ref, digest in scene.digests:
        # the source this process imported (a long-lived serve keeps the module it imported
        # first: an edit since then must not be run under the new source's sweep id)
        here = registry.IMPORTED.get(ref)
        if here != digest:
            raise ModelError(f"{ref}: this process runs the module's source {here}, not the "
                             f"one the sweep was planned with ({digest}); run the workers "
                             "with the same file, and restart a serve after an edit")
    if scene.dither not in sysm.dithers:
        raise ModelError(f"dither: {scene.dither!r} is not one the {sysm.name} system takes "
                         f"({', '.join(sysm.dithers)})")
    lay = registry.scene_layout(scene)
    size = lay.size
    n_sys = hook(scene.system, "n_states", sysm.n_states, scene, count=True)
    n_law = hook(scene.friction, "n_states", law.n_states, size, count=True)
    n_modes = hook(scene.friction, "n_modes", law.n_modes, size, count=True)
    for what, k in (("states", n_law), ("modes", n_modes)):
        if not 0 <= k <= registry.MAX_STATES:
            raise ModelError(f"friction {scene.friction!r}: {k} {what}; 0 to "
                             f"{registry.MAX_STATES} allowed")
    qf = n_sys + n_law if "F_mean" in scene.outputs else -1
    tail0 = n_sys + n_law + (qf >= 0)
    m0 = tail0 + hook(scene.system, "n_tail", sysm.n_tail, scene, count=True)
    b = Build(jit=jit, scene=scene, ix=lay.ix, size=size, z0=n_sys, n_law=n_law, m0=m0,
              qf=qf, tail0=tail0)
    b.n_err = hook(scene.system, "error_size", sysm.error_size, scene, law, n_law, m0,
                   count=True)
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
    entry = probed(scene)   # (its parts are called from Python: engine.systems.first_step)
    m0 = b.m0

    @njit(error_model="numpy", entry=entry)
    def rhs(t, y, p, sq, dy):
        u, fext, hold = drive(t, y, p, sq)
        F = rates(u, y, dy, hold, p)
        dynamics(t, y, p, sq, u, fext, F, dy)
        if qf >= 0:
            dy[qf] = F
        for i in range(m0, n):   # modes change only in update_modes, never by a rate
            dy[i] = 0.0

    @njit(inline="always", error_model="numpy", entry=entry)
    def interface(t, y, p, sq):
        u, _, hold = drive(t, y, p, sq)
        F, a = force(u, y, hold, p)
        return u, F, a

    if n_events:
        @njit(error_model="numpy", entry=entry)
        def events(t, y, p, sq, g):
            u, _, hold = drive(t, y, p, sq)
            switches(u, y, hold, p, g)
    else:
        @njit(error_model="numpy", entry=entry)
        def events(t, y, p, sq, g):
            pass

    @njit(inline="always", error_model="numpy", entry=entry)
    def init(p, y):
        y[:] = 0.0
        sys_init(p, y)
        law_init(p, y)

    @njit(error_model="numpy", entry=entry)
    def scales(p, out):
        sys_scales(p, out)
        law_scales(p, out)

    update_modes = None
    if lk.update_modes is not None:
        law_update = lk.update_modes

        @njit(inline="always", error_model="numpy")
        def update_modes(t, y, p, sq, landed):
            u, _, hold = drive(t, y, p, sq)
            return law_update(u, y, hold, p, landed)

    return System(
        n=n, n_err=b.n_err, rhs=rhs, n_events=n_events, events=events,
        interface=interface, position=sk.position, velocity=sk.velocity, init=init, qf=qf,
        scales=scales, event_jumps=bool(law.switch_jumps), z_index=b.z0,
        phases=law.phases, update_modes=update_modes, outputs=sk.outputs,
    )




def with_system_outputs(hooks, finish, so, k, hist):
    """The hooks and finish of the engine's observables, followed by the system's on the
    slots ``obs[O_SIZE:]``; its outputs go after the engine's ``k`` scalars (alpha_hist after
    them all)."""
    init, start, observe, stop = hooks
    s_start, s_observe, s_finish, m = so.start, so.observe, so.finish, len(so.names)
    s_stop = so.stop
    if s_stop is None:
        @njit(inline="always", error_model="numpy")
        def s_stop(t, y, p, is_period, o):
            pass

    @njit(inline="always", error_model="numpy")
    def start2(t, y, p, sq, obs):
        start(t, y, p, sq, obs)
        s_start(t, y, p, sq, obs[O_SIZE:])

    @njit(inline="always", error_model="numpy")
    def observe2(t0, y0, t1, y1, ymid, p, sq, obs):
        observe(t0, y0, t1, y1, ymid, p, sq, obs)
        if obs[O_ON] != 0.0:
            s_observe(t0, y0, t1, y1, ymid, p, sq, obs[O_SIZE:])

    @njit(inline="always", error_model="numpy")
    def finish2(t, y, p, obs, out):
        finish(t, y, p, obs, out)
        if hist:   # the engine's finish wrote the histogram after its own k scalars
            for j in range(N_HIST - 1, -1, -1):
                out[k + m + j] = out[k + j]
        s_finish(t, y, p, obs[O_SIZE:], out[k:k + m], t - obs[O_T0])

    @njit(inline="always", error_model="numpy")
    def stop2(t, y, p, is_period, obs):
        stop(t, y, p, is_period, obs)
        if obs[O_ON] != 0.0:
            s_stop(t, y, p, is_period, obs[O_SIZE:])

    return (init, start2, observe2, stop2), finish2


def describe_states(scene) -> str:
    """The state vector of ``scene`` in words (``ditherlab plan``): the system's, the law's
    (with the modes it keeps) and the quadratures."""
    law, sysm, b = build_context(scene)
    parts = [f"{', '.join(sysm.state_names)} ({sysm.name})"] if sysm.state_names else []
    n_modes = int(law.n_modes(b.size))
    if b.n_law:
        what = "z" if b.n_law == 1 else f"z_1..z_{b.n_law}"
        parts.append(f"{what} ({law.name}{f', {n_modes} stick/slip modes' if n_modes else ''})")
    extra = (b.qf >= 0) + int(sysm.n_tail(scene))
    if extra:
        parts.append(f"{extra} quadrature{'s' if extra > 1 else ''}")
    return " + ".join(parts) + f"; {b.n_err} under error control"


def probe(scene, p) -> None:
    """Compile a brought model and take its first step (engine.systems.first_step.probe)."""
    from .first_step import probe as _probe
    _probe(scene, p)


__all__ = ["System", "build_context", "make_system", "probe", "with_system_outputs"]
