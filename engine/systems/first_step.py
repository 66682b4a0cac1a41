"""The checks a model a user brings passes before anything runs (engine.registry; spec load):
its kernels compiled and called one by one with the types of their returns checked, then the
composed system's first evaluation (writes within its states, a rate for each, finite
values). Each fault is one :class:`ModelError` line with the user's file and line."""
from __future__ import annotations

from .. import registry
from ..contract import ModelError
from ..user_code import USER_FAULTS
from . import build_context, make_system


SENTINEL = 1.2345678e300   # a value no rate or state takes: what a model did not write


def probe(scene, p) -> None:
    """Compile ``scene``'s system and take its first evaluation: ModelError (one line, the
    user's file and line where known) when a model does not compile, writes outside its
    states or leaves one unwritten (a wrong number of states), or gives a NaN or an infinity
    at the first step. Used for models a user brings, before anything is written."""
    import numpy as np

    scales = _probe_parts(scene, p)
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
    except USER_FAULTS as exc:   # user code: any fault, sys.exit too, is one line
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
    try:   # last: a missing rate or state says more than the scale it lacks too
        for args in scales:
            _probe_scales(*args, p)
    except ModelError:
        raise
    except USER_FAULTS as exc:   # user code: any fault, sys.exit too, is one line
        raise ModelError(compile_line(scene, exc)) from None


def _probe_parts(scene, p) -> list:
    """A brought model's kernels compiled and called one by one (so that numba's complaint
    names the user's function, not the engine code it is inlined into), their writes checked
    against the model's own slots of the state vector, and the types of what they return
    checked against the contract. Returns the arguments of the scales checks, made last
    (:func:`_probe_scales`)."""
    law, sysm, b = build_context(scene)
    n_modes = int(law.n_modes(b.size))   # (a whole number: build_context checked it)
    scales = []
    try:
        if registry.is_import_path(scene.friction):
            scales.append(_probe_law(scene, law, b, n_modes, p))
        if registry.is_import_path(scene.system):
            scales.append(_probe_system(scene, sysm, b, n_modes, p))
        return scales
    except ModelError:
        raise
    except USER_FAULTS as exc:   # user code: any fault, sys.exit too, is one line
        raise ModelError(compile_line(scene, exc)) from None


def _probe_law(scene, law, b, n_modes: int, p) -> tuple:
    """A brought law's init and rates write only its states (init: and its modes), rates
    returns a number, force two with alpha in [0, 1]; returns its scales check's arguments."""
    import numpy as np

    n = b.m0 + n_modes + 8
    y, dy, g = np.full(n, SENTINEL), np.full(n, SENTINEL), np.zeros(max(1, 1 + n))
    lk = law.build(b)
    lk.init(p, y)
    strays = _strays(y, (b.z0, b.z0 + b.n_law), (b.m0, b.m0 + n_modes))
    y[y == SENTINEL] = 0.0
    where = lk.init
    if strays is None:
        F = lk.rates(0.1, y, dy, 0.0, p)
        where = lk.rates
        strays = _strays(dy, (b.z0, b.z0 + b.n_law))
    if strays is not None:
        # inside the system's vector, so no bounds fault: before, a write to the slot
        # after the law's states went to the F quadrature or a mode (which the system
        # then overwrote), and the numbers were wrong without a word
        raise ModelError(f"{scene.friction}: {_name(where)} writes slot {strays} of the "
                         f"state vector, outside its {b.n_law} states (slots {b.z0} to "
                         f"{b.z0 + b.n_law - 1}) and {n_modes} modes: index them from b.z0 "
                         f"and check n_states{_def_at(where)}")
    if not isinstance(F, float):
        raise ModelError(f"{scene.friction}: rates must return the friction force (a "
                         f"number), got {type(F).__name__}{_def_at(where)}")
    where = lk.force
    Fa = lk.force(0.1, y, 0.0, p)
    if not (isinstance(Fa, tuple) and len(Fa) == 2 and all(isinstance(v, float) for v in Fa)):
        raise ModelError(f"{scene.friction}: force must return (F, alpha), two numbers, "
                         f"got {type(Fa).__name__}{_def_at(where)}")
    if not 0.0 <= Fa[1] <= 1.0:   # (the phase observables bin it: outside, other slots)
        raise ModelError(f"{scene.friction}: force gives alpha = {Fa[1]!r} at the first step; "
                         f"alpha is the phase, in [0, 1] (0 stick, 1 slip){_def_at(where)}")
    if lk.switches is not None and lk.n_switches:
        lk.switches(0.1, y, 0.0, p, g)
    if lk.update_modes is not None:   # it sets the modes only (docs/MODELS.md rule 5)
        where, before = lk.update_modes, y.copy()
        lk.update_modes(0.1, y, 0.0, p, -1)
        moved = [int(i) for i in np.flatnonzero(y != before)
                 if not b.m0 <= i < b.m0 + n_modes and not np.isnan(before[i])]
        if moved:
            raise ModelError(f"{scene.friction}: update_modes writes slot {moved[0]} of the "
                             f"state vector, outside its {n_modes} modes (slots {b.m0} to "
                             f"{b.m0 + n_modes - 1}): it sets the modes y[m0 + i] only"
                             f"{_def_at(where)}")
    return scene.friction, lk.scales, n, b.n_err, ((b.z0, b.z0 + b.n_law),)


def _probe_system(scene, sysm, b, n_modes: int, p) -> tuple:
    """A brought system's init and dynamics write only its own slots: its states (from 0)
    and its tail (quadratures, from b.tail0). Before, a write into the law's first state
    stayed inside the vector and was overwritten or added silently: wrong numbers."""
    import numpy as np

    n = b.m0 + n_modes + 8
    y, dy = np.full(n, SENTINEL), np.full(n, SENTINEL)
    own = ((0, b.z0), (b.tail0, b.m0))
    sk = sysm.build(b)
    sk.init(p, y)
    where, strays = sk.init, _strays(y, *own)
    y[y == SENTINEL] = 0.0
    if strays is None:
        where = sk.drive
        drive = sk.drive(0.0, y, p, 1.0)
        if not (isinstance(drive, tuple) and len(drive) == 3
                and all(isinstance(v, float) for v in drive)):
            got = (f"a tuple of {len(drive)}" if isinstance(drive, tuple) else
                   type(drive).__name__)
            raise ModelError(f"{scene.system}: drive must return (u, fext, hold), three "
                             f"numbers, got {got}{_def_at(where)}")
        where = sk.dynamics
        sk.dynamics(0.0, y, p, 1.0, drive[0], drive[1], 0.1, dy)
        strays = _strays(dy, *own)
    if strays is None and sk.outputs is not None:
        _probe_system_outputs(scene, sk.outputs, y, p)
    if strays is not None:
        tail = (f" and its {b.m0 - b.tail0} tail states (slots {b.tail0} to {b.m0 - 1})"
                if b.m0 > b.tail0 else "")
        slots = f" (slots 0 to {b.z0 - 1})" if b.z0 else ""
        raise ModelError(f"{scene.system}: {_name(where)} writes slot {strays} of the state "
                         f"vector, outside its {b.z0} states{slots}{tail}; the friction "
                         f"law's states start at b.z0 = {b.z0}: check state_names and "
                         f"n_tail{_def_at(where)}")
    return scene.system, sk.scales, n, b.n_err, own


def _probe_scales(ref: str, scales, n: int, n_err: int, own: tuple, p) -> None:
    """A model's ``scales(p, out)`` writes only its own slots, and a finite scale for each of
    them under error control (the first ``n_err``). In the kernel ``out`` is the atol,
    filled with ``atol`` and scaled by atol after ``scales``: a slot left unwritten ran at
    atol squared (``atol_units = "natural"``; measured: 184 steps a point, not 173), a
    tolerance nobody asked for, without a word."""
    import numpy as np

    out = np.full(n, SENTINEL)
    scales(p, out)
    strays = _strays(out, *own)
    if strays is not None:
        raise ModelError(f"{ref}: scales writes slot {strays}, outside its own "
                         f"{_slots_text(own)}{_def_at(scales)}")
    for lo, hi in own:
        for i in range(lo, min(hi, n_err)):
            if out[i] == SENTINEL or not np.isfinite(out[i]):
                what = "no scale" if out[i] == SENTINEL else f"the scale {out[i]!r}"
                raise ModelError(f"{ref}: scales gives {what} for slot {i}, a state under "
                                 f"error control: write a finite natural scale for each of "
                                 f"its {_slots_text(own)}{_def_at(scales)}")


def _slots_text(own) -> str:
    return " and ".join(f"slots {lo} to {hi - 1}" for lo, hi in own if hi > lo) or "no slots"


def _probe_system_outputs(scene, so, y, p) -> None:
    """A brought system's own observables (engine.contract.SystemOutputs): its hooks write
    only the ``size`` accumulator slots it declares, and ``finish`` a value for each of its
    outputs and nothing after them. In the kernel ``o`` and ``out`` are views into longer
    arrays: a write past them went into the engine's alpha_hist columns or past the
    accumulator's end, without a bounds check."""
    import numpy as np

    n_slots, names = int(so.size), tuple(so.names)
    o = np.full(n_slots + 8, SENTINEL)
    hooks = [(so.start, (0.0, y, p, 1.0, o)), (so.observe, (0.0, y, 0.5, y, y, p, 1.0, o))]
    if so.stop is not None:
        hooks.append((so.stop, (0.5, y, p, True, o)))
    for hook, args in hooks:
        hook(*args)
        strays = _strays(o, (0, n_slots))
        if strays is not None:
            raise ModelError(f"{scene.system}: {_name(hook)} writes accumulator slot "
                             f"{strays}, past its {n_slots} (SystemOutputs size)"
                             f"{_def_at(hook)}")
    out = np.full(len(names) + 8, SENTINEL)
    so.finish(1.0, y, p, o, out, 1.0)
    strays = _strays(out, (0, len(names)))
    if strays is not None:
        raise ModelError(f"{scene.system}: finish writes out[{strays}], past its "
                         f"{len(names)} outputs ({', '.join(names)}){_def_at(so.finish)}")
    unset = [name for name, v in zip(names, out) if v == SENTINEL]
    if unset:
        raise ModelError(f"{scene.system}: finish gives no value for its output "
                         f"{unset[0]!r}{_def_at(so.finish)}")


def _name(fn) -> str:
    return getattr(getattr(fn, "py_func", fn), "__name__", "a kernel")


def _strays(values, *allowed) -> int | None:
    """The first slot of ``values`` written (no longer SENTINEL) outside the ``allowed``
    half-open ranges, or None."""
    import numpy as np

    inside = np.zeros(values.size, dtype=bool)
    for lo, hi in allowed:
        inside[lo:hi] = True
    written = np.flatnonzero((values != SENTINEL) & ~inside)
    return int(written[0]) if written.size else None


def _def_at(fn) -> str:
    code = getattr(getattr(fn, "py_func", fn), "__code__", None)
    return f" (at {code.co_filename.rsplit('/', 1)[-1]} line {code.co_firstlineno})" \
        if code else ""


def compile_line(scene, exc: BaseException) -> str:
    """One line for a model that numba cannot compile (or that raised while building): the
    first line of the error and the user's file and line."""
    import re

    text = str(exc)
    lines = [ln.strip() for ln in text.splitlines()
             if ln.strip() and not ln.strip().startswith("Failed in ")]
    first = lines[0] if lines else type(exc).__name__
    if first.endswith(":") and len(lines) > 1:   # "No implementation ... for signature:"
        first = f"{first} {lines[1]}"
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
