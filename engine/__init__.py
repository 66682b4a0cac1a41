"""ditherlab's numerics: friction laws, dither, systems, integrators, observables.

Explicit re-exports of the public entry points (see docs/ARCHITECTURE.md).
"""
from .api import Simulation, simulate
from .batch import POINT_AXES, BlockResult, run_block
from .integrators import METHODS
from .params import pack, unpack
from .provenance import fingerprint
from .scene import Scene
from .settings import Settings

__all__ = [
    "METHODS", "POINT_AXES", "BlockResult", "Scene", "Settings", "Simulation", "fingerprint",
    "pack", "run_block", "simulate", "unpack",
]
