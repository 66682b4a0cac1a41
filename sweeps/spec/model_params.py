"""A spec's friction law and system as models (engine.registry, docs/MODELS.md): their own
parameters from ``[params]``, the lengths of their vector parameters, and the source digests
of the models the spec brings by import path (part of the sweep id)."""
from __future__ import annotations

from .messages import show


def resolved(kind: str, ref: str) -> str:
    """``ref`` when it names a model (a built-in name or an import path that imports and
    holds one), else the registry's one-line ModelError."""
    from engine import registry

    registry.resolve(kind, ref)
    return ref


def values(spec) -> dict:
    """The models' own parameters from ``[params]``: flat keys, and the keys of the table
    named after a model's ``group`` (``gms = {...}``)."""
    from engine import registry

    extra = dict(spec.params.model_extra or {})
    out = {}
    for owner in (registry.law(spec.friction), registry.system(spec.system)):
        group = getattr(owner, "group", None)
        if group and group in extra:
            table = extra.pop(group)
            if not isinstance(table, dict):
                raise ValueError(f"params.{group}: expected a table of {owner.name}'s "
                                 f"parameters ({', '.join(registry.own_params(owner))}), "
                                 f"got {show(table)}")
            out.update(table)
    out.update(extra)
    return out


def sizes(spec) -> tuple:
    """``engine.Scene.sizes``: the lengths of the models' vector parameters."""
    from engine import registry

    return registry.sizes_of(spec.friction, spec.system, values(spec))


def brought(spec) -> dict:
    """Import path -> digest of its module's source, for the models the spec brings (empty
    for the built-in ones, which the engine's fingerprint covers)."""
    from engine import registry

    return {ref: registry.source_digest(ref) for ref in (spec.friction, spec.system)
            if registry.is_import_path(ref)}


def problems(spec) -> list[str]:
    """The models' own parameters checked against their declarations: one line per fault
    (unknown name, type, range, required, the model's own cross-checks)."""
    from engine import registry
    from engine.contract import ModelError

    try:
        registry.check_values(spec.friction, spec.system, values(spec))
    except (ModelError, ValueError) as exc:
        return [str(exc)]
    return []


def atol_units(spec) -> str:
    """The atol units the accuracy levels (and an explicit accuracy that names none) take on
    the spec's system: ``"natural"`` where the system asks for them
    (engine.contract.MechanicalSystem ``natural_atol``: the contact, whose states are SI),
    else ``"absolute"``."""
    from engine import registry

    return "natural" if registry.system(spec.system).natural_atol else "absolute"
