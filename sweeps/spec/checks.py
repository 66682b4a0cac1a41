"""Checks of a well-typed spec that pydantic cannot make field by field: the combination
of choices (method, system, friction, dither, outputs, refinement, fs >= fc) and the
values of the grid's axes (finite, in range, no repeats). Called by
:func:`sweeps.spec.parse_spec` once the grid is known to be within the point budget."""
from __future__ import annotations

import numpy as np

from .grid import AXES, system_defaults
from .methods import CLASS_OUTPUT, PLANES, allowed_outputs, resolve_outputs
from . import model_params
from .messages import show
from .models import Range, Spec


PAPER_LAWS = ("coulomb", "stribeck", "lugre", "elastoplastic")   # the paper's theory covers


def check_choices(spec: Spec) -> list[str]:
    """Faults in the combination of choices, without the grid's values."""
    problems = model_params.problems(spec)
    allowed = allowed_outputs(spec.method, spec.system)
    for name in spec.outputs or ():
        if name not in allowed:
            problems.append(f"outputs: {show(name)} is not produced by method={spec.method!r}; "
                            f"allowed: {', '.join(allowed)}")
    if spec.method == "hbm" and spec.system != "contact":
        problems.append("method: 'hbm' solves the Sec. 3 contact model; set system = 'contact'")
    if spec.system == "contact" and spec.method == "averaged":
        problems.append("method: 'averaged' applies to the slider system; use 'simulate' or "
                        "'hbm' for system = 'contact'")
    elif spec.system not in ("slider", "contact") and spec.method != "simulate":
        problems.append(f"method: {spec.method!r} has a theory for the paper's slider and "
                        f"contact only; use method = 'simulate' for system = {spec.system!r}")
    if spec.system == "contact" and spec.dither == "sine-force":
        problems.append("dither: 'sine-force' needs a mass; the contact system (no inertia) "
                        "takes 'sine-velocity', 'square-velocity' or 'none'")
    if spec.refine is not False:
        problems += _check_refine(spec)
    if spec.method == "averaged" and spec.grid.omega is not None:
        problems.append("grid.omega: the averaged theory is the limit omega -> infinity and "
                        "has no dither frequency; drop grid.omega (the cube's omega is inf) or "
                        "use method = 'simulate'")
    theory = {"averaged": ("coulomb", "stribeck", "lugre"), "hbm": ("lugre",)}
    if spec.method == "averaged" and spec.friction not in PAPER_LAWS:
        from engine import registry
        from engine.analysis.steady import has_steady

        if not has_steady(registry.law(spec.friction)):
            problems.append(f"friction: method='averaged' needs the law's steady-state "
                            f"friction curve (build_steady, docs/MODELS.md rule 7), and "
                            f"{spec.friction!r} declares none; use method = 'simulate'")
    elif spec.method in theory and spec.friction not in theory[spec.method]:
        problems.append(f"friction: method={spec.method!r} has no theory for {spec.friction!r} "
                        f"(it covers {', '.join(theory[spec.method])}); use method = 'simulate'")
    defaults = system_defaults(spec.system)
    fc = spec.params.fc if spec.params.fc is not None else defaults["fc"]
    fs = spec.params.fs if spec.params.fs is not None else defaults["fs"]
    if fs < fc:
        problems.append(f"params: fs must be >= fc (static level above Coulomb level), got "
                        f"fs={fs!r}, fc={fc!r}" + ("" if spec.params.fs is not None and
                                                    spec.params.fc is not None
                                                    else " (one of them the default)"))
    return problems


def _check_refine(spec: Spec) -> list[str]:
    """Refinement needs a class to refine on (sweeps.spec.methods.CLASS_OUTPUT)."""
    if spec.method not in CLASS_OUTPUT:
        return [f"refine: the {spec.method} path draws no zone map or stability chart; "
                "drop refine"]
    need = CLASS_OUTPUT[spec.method]
    if need not in resolve_outputs(spec.method, spec.outputs, spec.system):
        return [f"refine: refining the {spec.method} map needs the output {need!r} (its "
                f"classes); add it to outputs"]
    a, b = PLANES[spec.method]
    return [] if getattr(spec.grid, a) is not None or getattr(spec.grid, b) is not None \
        else [f"refine: sweep {a} or {b} (the map's plane) to refine"]


def check_grid(spec: Spec) -> list[str]:
    """Faults in the axis values (built here: the size was checked before)."""
    problems = []
    for axis in AXES:
        raw = getattr(spec.grid, axis)
        if raw is None:
            continue   # a default value (the averaged path's omega is inf by design)
        values = spec.grid_facts.coords[axis]
        bad = values[~np.isfinite(values)]
        if bad.size:
            why = " (the range's span overflows)" if isinstance(raw, Range) else ""
            problems.append(f"grid.{axis}: values must be finite, got {show(bad[0])}{why}")
            continue
        low = float(values.min())
        if axis == "v_d" and low <= 0:
            problems.append(f"grid.{axis}: must be > 0, got {show(low)}")
        elif axis == "W" and low < 0:
            problems.append(f"grid.W: dither amplitude must be >= 0, got {show(low)}")
        elif axis == "omega" and spec.dither != "none" and low <= 0:
            problems.append(f"grid.omega: dither frequency must be > 0, got {show(low)}")
        repeated = _repeated(values)
        if repeated is not None:
            how = ("the range gives it more than once (start == stop, or more points than "
                   "floats between them)" if isinstance(raw, Range) else "list it once")
            problems.append(f"grid.{axis}: repeats the value {show(repeated)}; a cube axis "
                            f"needs distinct values ({how})")
    return problems


def _repeated(values: np.ndarray) -> float | None:
    """A value that occurs more than once in ``values``, or None."""
    if values.size < 2:
        return None
    ordered = np.sort(values)
    same = np.flatnonzero(ordered[1:] == ordered[:-1])
    return float(ordered[same[0]]) if same.size else None
