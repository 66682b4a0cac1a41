"""Shared scene builders for the engine tests (one compiled kernel per distinct Scene, so
tests reuse the same Scenes wherever they can)."""
from engine.outputs import SIMULATE
from engine.scene import Scene

ALL = tuple(SIMULATE)


def scene(friction="lugre", dither="square-velocity", integrator="dopri5", slow=False,
          system="slider", outputs=ALL):
    """Scene with every simulate observable (kernels shared across test modules)."""
    return Scene(system=system, friction=friction, dither=dither, integrator=integrator,
                 slow_force=slow, outputs=outputs)
