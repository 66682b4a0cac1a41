"""Friction laws and systems by name: the built-in ones, and those a user brings by import path.

A spec names a model as a built-in name (``"lugre"``, ``"slider"``) or as an import path,
``"package.module:Name"`` or ``"path/to/file.py:Name"`` (a file path is read relative to the
current folder; the spec loader makes it absolute). ``Name`` is a :class:`FrictionLaw` or
:class:`MechanicalSystem` subclass (instantiated without arguments) or an instance.
Anything wrong with a user's module is a :class:`engine.contract.ModelError`: one line
naming the module, never a traceback (:func:`resolve`, :func:`check_first_step`).

The parameter vector of a scene (:func:`layout`) is the shared set of :mod:`engine.params`
followed by the law's own parameters and then the system's, in declaration order, a vector
parameter taking as many slots as its length (``Scene.sizes``).
"""
from __future__ import annotations

import difflib
import functools
import hashlib
import importlib
import importlib.util
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from . import params as P
from .contract import FrictionLaw, MechanicalSystem, ModelError, Param
from .user_code import USER_FAULTS
from .user_code import import_module as _import
from .user_code import one_line as _one_line
from .user_code import short as _short
from .user_code import where as _where

MAX_STATES = 64


def _builtin_laws() -> dict:
    from .friction import dahl, gms, laws
    return {law.name: law for law in (*laws.BUILTIN, dahl.Dahl(), gms.GMS())}


def _builtin_systems() -> dict:
    from .systems import contact, servo, slider
    return {s.name: s for s in (slider.Slider(), contact.Contact(), servo.Servo())}


LAW_NAMES = ("coulomb", "stribeck", "lugre", "elastoplastic", "dahl", "gms")
SYSTEM_NAMES = ("slider", "contact", "servo")
KIND = {"friction": (FrictionLaw, LAW_NAMES), "system": (MechanicalSystem, SYSTEM_NAMES)}


def is_import_path(ref: str) -> bool:
    return ":" in ref


def law(ref: str) -> FrictionLaw:
    return resolve("friction", ref)


def system(ref: str) -> MechanicalSystem:
    return resolve("system", ref)


#: import path -> digest of the source this process imported it from (set by :func:`resolve`)
IMPORTED: dict[str, str | None] = {}


@functools.cache
def resolve(kind: str, ref: str):
    """The model ``ref`` names (a built-in name or an import path), or ModelError."""
    base, names = KIND[kind]
    if not isinstance(ref, str) or not ref:
        raise ModelError(f"{kind}: expected a name or 'module:Name', got {ref!r}")
    if not is_import_path(ref):
        table = _builtin_laws() if kind == "friction" else _builtin_systems()
        if ref in table:
            return table[ref]
        hint = difflib.get_close_matches(ref, names, n=1)
        raise ModelError(f"{kind}: got {_short(ref)}; must be one of "
                         f"{', '.join(repr(n) for n in names)}"
                         + (f" (did you mean {hint[0]!r}?)" if hint else "")
                         + ", or an import path 'module:Name' of your own")
    module_name, _, attr = ref.rpartition(":")
    module = _import(kind, ref, module_name)
    IMPORTED[ref] = source_digest(ref)   # the source this process runs (engine.systems)
    if not hasattr(module, attr):
        public = [n for n in dir(module) if not n.startswith("_")]
        hint = difflib.get_close_matches(attr, public, n=1)
        raise ModelError(f"{kind} {ref!r}: module {module_name!r} has no {attr!r}"
                         + (f" (did you mean {hint[0]!r}?)" if hint else ""))
    obj = getattr(module, attr)
    if isinstance(obj, type):
        if not issubclass(obj, base):
            raise ModelError(f"{kind} {ref!r}: {attr} is not a subclass of "
                             f"engine.contract.{base.__name__} (docs/MODELS.md rule 1)")
        try:
            obj = obj()
        except USER_FAULTS as exc:   # user code: any fault, sys.exit too, is one line
            raise ModelError(f"{kind} {ref!r}: {attr}() failed: {_one_line(exc)}"
                             f"{_where(exc, module)}") from None
    if not isinstance(obj, base):
        raise ModelError(f"{kind} {ref!r}: {attr} is not a {base.__name__} "
                         "(docs/MODELS.md rule 1)")
    _check_declarations(kind, ref, obj)
    return obj


def _check_declarations(kind: str, ref: str, obj) -> None:
    name = getattr(obj, "name", "")
    if not isinstance(name, str) or not name.isidentifier():
        raise ModelError(f"{kind} {ref!r}: its name must be an identifier, got {name!r}")
    if name in KIND[kind][1]:   # (accepted before: plan and the states then read as the built-in's)
        raise ModelError(f"{kind} {ref!r}: its name {name!r} is a built-in {kind}'s; give it "
                         "another")
    params = getattr(obj, "params", {})
    if not isinstance(params, dict) or not all(isinstance(v, Param) for v in params.values()):
        raise ModelError(f"{kind} {ref!r}: params must be a dict of engine.contract.Param")
    clash = sorted(set(params) & set(P.NAMES))
    if clash:
        raise ModelError(f"{kind} {ref!r}: parameter {clash[0]!r} is a shared parameter "
                         "(engine.params); give it another name")
    for pname, par in params.items():
        try:
            bad = not (float(par.lo) <= float(par.hi))
        except (TypeError, ValueError):
            bad = True
        if bad:
            raise ModelError(f"{kind} {ref!r}: parameter {pname!r}: lo and hi must be numbers "
                             f"with lo <= hi, got lo={par.lo!r}, hi={par.hi!r}")
    group = getattr(obj, "group", None)
    if group is not None and not (isinstance(group, str) and group.isidentifier()):
        raise ModelError(f"{kind} {ref!r}: its group must be None or an identifier, got "
                         f"{group!r}")
    phases = getattr(obj, "phases", None)
    if kind == "friction" and phases not in ("band", "alpha"):   # ("elasto": built-in only)
        raise ModelError(f"{kind} {ref!r}: phases must be 'band' or 'alpha' (docs/MODELS.md "
                         f"rule 6), got {phases!r}")
    flag = "switch_jumps" if kind == "friction" else "natural_atol"
    if not isinstance(getattr(obj, flag, False), bool):
        raise ModelError(f"{kind} {ref!r}: {flag} must be True or False, got "
                         f"{_short(getattr(obj, flag))}")


def source_digest(ref: str) -> str | None:
    """sha256 (12 hex) of a brought model's source: every ``.py`` file of its top-level
    package (paths and contents) when the module is in one, so that an edit of a helper
    module it imports makes a new sweep too (before, only the named module's file was
    hashed); the file alone for a top-level module or a file path. None for a built-in
    (the engine's fingerprint covers those)."""
    if not is_import_path(ref):
        return None
    module_name = ref.rpartition(":")[0]
    if module_name.endswith(".py") or "/" in module_name:
        path = Path(module_name)
    else:
        try:
            top = importlib.util.find_spec(module_name.split(".")[0])
            spec = importlib.util.find_spec(module_name)
        except (ImportError, ValueError):
            top = spec = None
        folders = list(getattr(top, "submodule_search_locations", None) or [])
        if folders:   # a package: all of it
            from .provenance import source_hash

            try:
                return source_hash(folders[0])
            except OSError:
                return None
        if spec is None or not spec.origin:
            return None
        path = Path(spec.origin)
    try:
        return hashlib.sha256(path.read_bytes()).hexdigest()[:12]
    except OSError:
        return None


# --- the parameter vector of a scene --------------------------------------------------------

@dataclass(frozen=True)
class Layout:
    """Where each parameter of a scene lives in ``p``: the shared ones (engine.params), then
    the law's and the system's own (``extras``: name -> (index, length))."""

    extras: tuple            # ((name, index, length, Param, owner), ...)
    n_params: int

    @property
    def ix(self) -> dict:
        return {**P.INDEX, **{name: i for name, i, _, _, _ in self.extras}}

    @property
    def size(self) -> dict:
        return {name: k for name, _, k, par, _ in self.extras if par.vector}


def own_params(model) -> dict:
    return dict(getattr(model, "params", {}) or {})


def check_pair(friction: str, system_: str) -> None:
    """A law and a system whose own parameters (or parameter tables) share a name are
    refused: one slot of ``p`` and one spec key cannot hold two values (before, the later
    one silently set both)."""
    law_, sys_ = law(friction), system(system_)
    both = sorted(set(own_params(law_)) & set(own_params(sys_)))
    if both:
        raise ModelError(f"parameter {both[0]!r} is declared by both friction {friction!r} and "
                         f"system {system_!r}: rename it in one of the two models")
    group = getattr(law_, "group", None)
    if group and group == getattr(sys_, "group", None):
        raise ModelError(f"friction {friction!r} and system {system_!r} both take their "
                         f"parameters as the table {group!r}: rename one group")


@functools.cache
def layout(friction: str, system_: str, sizes: tuple) -> Layout:
    check_pair(friction, system_)
    sized = dict(sizes)
    extras, i = [], P.N_PARAMS
    for owner in (law(friction), system(system_)):
        for name, par in own_params(owner).items():
            k = int(sized.get(name, len(par.default) if par.vector and par.default else 1))
            extras.append((name, i, k, par, owner.name))
            i += k
    return Layout(tuple(extras), i)


def scene_layout(scene) -> Layout:
    return layout(scene.friction, scene.system, scene.sizes)


def sizes_of(friction: str, system_: str, values: dict) -> tuple:
    """``Scene.sizes`` for the models' own parameter ``values`` (vector lengths)."""
    out = []
    for owner in (law(friction), system(system_)):
        for name, par in own_params(owner).items():
            if par.vector:
                v = values.get(name, par.default)
                out.append((name, len(v) if v is not None else 0))
    return tuple(sorted(out))


def check_values(friction: str, system_: str, values: dict) -> dict:
    """The models' own parameter values, checked (unknown name, type, range, required):
    name -> list of floats. ModelError names the first fault."""
    check_pair(friction, system_)
    known: dict[str, tuple[Param, str]] = {}
    for owner in (law(friction), system(system_)):
        for name, par in own_params(owner).items():
            known[name] = (par, owner.name)
    for name in values:
        if name not in known:
            hint = difflib.get_close_matches(name, list(known), n=1)
            takes = ", ".join(known) or "no parameters of their own"
            raise ModelError(f"params: unknown parameter {_short(name)} for friction {friction!r} "
                             f"and system {system_!r} (they take {takes})"
                             + (f"; did you mean {hint[0]!r}?" if hint else ""))
    out = {}
    for name, (par, owner) in known.items():
        value = values.get(name, par.default)
        if value is None:
            raise ModelError(f"params: {owner} needs {name!r} ({par.doc or par.unit})")
        out[name] = par.check(f"params.{name}", value)
    for owner in (law(friction), system(system_)):
        check = getattr(owner, "check", None)
        if check is not None:
            mine = {n: out[n] for n in own_params(owner)}
            try:
                check(mine)
            except ModelError:
                raise
            except USER_FAULTS as exc:   # user code: any fault, sys.exit too, is one line
                raise ModelError(f"{owner.name}.check failed: {_one_line(exc)}{_where(exc)}") \
                    from None
    return out


def pack(friction: str = "lugre", system_: str = "slider", values: dict | None = None,
         defaults: dict | None = None, **shared) -> np.ndarray:
    """The parameter vector of a scene: ``engine.params.pack(defaults, **shared)`` followed
    by the models' own parameters (``values``, checked; their defaults elsewhere)."""
    values = values or {}
    sysm = system(system_)
    base = P.pack(defaults if defaults is not None else (sysm.defaults or P.PAPER_DEFAULTS),
                  **shared)
    lay = layout(friction, system_, sizes_of(friction, system_, values))
    if not lay.extras:
        return base
    checked = check_values(friction, system_, values)
    p = np.empty(lay.n_params)
    p[:P.N_PARAMS] = base
    for name, i, k, _, _ in lay.extras:
        p[i:i + k] = checked[name]
    return p


def finite(x) -> bool:
    return all(math.isfinite(float(v)) for v in np.ravel(x))
