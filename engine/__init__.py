"""ditherlab's numerics: friction laws, dither, systems, integrators, observables.

Explicit re-exports of the public entry points (see docs/ARCHITECTURE.md), loaded on first
use: ``engine.provenance`` (hashlib only) must not pay for numba's import.
"""
import lazy_loader as _lazy

__getattr__, __dir__, __all__ = _lazy.attach(
    __name__,
    submodules=["analysis", "blocks", "dither", "friction", "integrators", "jit", "observables",
                "outputs", "params", "provenance", "scene", "settings", "status", "systems"],
    submod_attrs={
        "api": ["Simulation", "simulate"],
        "blocks": ["POINT_AXES", "BlockResult", "run_block"],
        "integrators": ["METHODS"],
        "params": ["pack", "unpack"],
        "provenance": ["fingerprint"],
        "scene": ["Scene"],
        "settings": ["Settings"],
    },
)
