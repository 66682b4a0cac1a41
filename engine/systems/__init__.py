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
    update_modes: Callable | None  # update_modes(t, y, p, sq, landed) -> bool, or None
    outputs: object       # the system's own observables (engine.contract.SystemOutputs)


def build_context(scene, jit=njit) -> tuple:
    """``(law, system, Build)`` of ``scene``: its models and their layout in y and p."""
    for ref, digest in scene.digests:
        here = registry.source_digest(ref)
        if here != digest:
            raise ModelError(f"{ref}: this process's copy of the module (source {here}) is not "
                             f"the one the sweep was planned with (source {digest}); run the "
                             "workers with the same file")
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

    m0 = b.m0

    @njit(error_model="numpy")
    def rhs(t, y, p, sq, dy):
        u, fext, hold = drive(t, y, p, sq)
        F = rates(u, y, dy, hold, p)
        dynamics(t, y, p, sq, u, fext, F, dy)
        if qf >= 0:
            dy[qf] = F
        for i in range(m0, n):   # modes change only in update_modes, never by a rate
            dy[i] = 0.0

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
        def update_modes(t, y, p, sq, landed):
            u, _, hold = drive(t, y, p, sq)
            return law_update(u, y, hold, p, landed)

    return System(
        n=n, n_err=b.n_err, rhs=rhs, n_events=n_events, events=events,
        interface=interface, position=sk.position, velocity=sk.velocity, init=init, qf=qf,
        scales=scales, event_jumps=bool(law.switch_jumps), z_index=b.z0,
        phases=law.phases, update_modes=update_modes, outputs=sk.outputs,
    )


__all__ = ["System", "build_context", "make_system"]


SENTINEL = 1.2345678e300   # a value no rate or state takes: what a model did not write


def probe(scene, p) -> None:
    """Compile ``scene``'s system and take its first evaluation: ModelError (one line, the
    user's file and line where known) when a model does not compile, writes outside its
    states or leaves one unwritten (a wrong number of states), or gives a NaN or an infinity
    at the first step. Used for models a user brings, before anything is written."""
    import numpy as np

    try:
        system = make_system(scene)
        n, extra = system.n, 8
        y = np.full(n + extra, SENTINEL)
        dy = np.full(n + extra, SENTINEL)
        system.init(p, y[:n])
        system.rhs(0.0, y[:n], p, 1.0, dy[:n])
        u, F, a = system.interface(0.0, y[:n], p, 1.0)
        g = np.full(max(system.n_events, 1) + extra, SENTINEL)
        system.events(0.0, y[:n], p, 1.0, g[:max(system.n_events, 1)])
    except ModelError:
        raise
    except Exception as exc:   # noqa: BLE001  (user code: any fault is one line)
        raise ModelError(compile_line(scene, exc)) from None
    who = f"friction {scene.friction!r} on system {scene.system!r}"
    if (y[n:] != SENTINEL).any() or (dy[n:] != SENTINEL).any():
        raise ModelError(f"{who}: writes beyond the {n} states it declares (n_states, "
                         "n_modes, state_names): check its number of states")
    unset = np.flatnonzero(dy[:n] == SENTINEL)
    if unset.size:
        raise ModelError(f"{who}: gives no rate for state {int(unset[0])} of {n}: check its "
                         "number of states (n_states) and that rates writes dy for each")
    if system.n_events and (g[system.n_events:] != SENTINEL).any():
        raise ModelError(f"{who}: its switches write more than the {system.n_events} values "
                         "it declares (LawKernels.n_switches)")
    bad = [name for name, v in (("a state", y[:n]), ("a rate", dy[:n]), ("the force", [F]),
                                ("alpha", [a]), ("the interface velocity", [u]))
           if not np.isfinite(np.asarray(v, dtype=float)).all()]
    if bad:
        raise ModelError(f"{who}: {bad[0]} is NaN or infinite at the first step (t = 0, "
                         "the initial state): check its equations and parameters")


def compile_line(scene, exc: BaseException) -> str:
    """One line for a model that numba cannot compile (or that raised while building): the
    first line of the error and the user's file and line."""
    import re

    text = str(exc)
    first = next((ln.strip() for ln in text.splitlines() if ln.strip()), type(exc).__name__)
    where = ""
    refs = [r for r in (scene.friction, scene.system) if registry.is_import_path(r)]
    for m in re.finditer(r'File "([^"]+)", line (\d+)', text):
        path = m.group(1)
        if not any(s in path for s in ("/engine/", "/numba/", "site-packages")):
            where = f" (at {path.rsplit('/', 1)[-1]} line {m.group(2)})"
            break
    if not where:
        import traceback
        for frame in reversed(traceback.extract_tb(exc.__traceback__)):
            if not any(s in frame.filename for s in ("/engine/", "/numba/", "site-packages")):
                where = f" (at {frame.filename.rsplit('/', 1)[-1]} line {frame.lineno})"
                break
    kind = "numba cannot compile" if type(exc).__module__.startswith("numba") else \
        f"{type(exc).__name__} while building"
    return (f"{kind} {' / '.join(refs) or scene.friction}: {first[:200]}{where}")


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
