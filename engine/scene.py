"""Scene: the compile-time choices of a kernel (what to simulate, not with which numbers).

Kernels are specialised per Scene, so an effect a scene does not call for (Stribeck,
bristle damping, viscous term, slow force, an observable) costs nothing at run time.
"""
from __future__ import annotations

from dataclasses import dataclass, replace

from . import params as P
from . import registry
from .dither import KINDS as DITHER_KINDS
PATHS = ("simulate", "averaged", "hbm")   # how a point is answered (a spec's ``method``)
ANALYSIS_PATHS = ("averaged", "hbm")      # no time integration
FOLDED_EXPONENTS = (1.0, 2.0)             # Stribeck exponents with a pow-free kernel


def _folded(value) -> float | None:
    return float(value) if value in FOLDED_EXPONENTS else None


@dataclass(frozen=True)
class Scene:
    """The problem (system, friction, dither, effects, observables), the path that answers it
    and, on the simulate path, the time integrator.

    ``path`` -- ``"simulate"`` (time integration), ``"averaged"`` or ``"hbm"`` (engine.analysis);
    a sweep spec calls it ``method``. ``integrator`` -- a name of
    :data:`engine.integrators.METHODS`; off the simulate path it is cleared to ``""``.
    ``system``, ``friction`` -- a built-in name (:data:`engine.registry.SYSTEM_NAMES`,
    :data:`engine.registry.LAW_NAMES`) or an import path ``"module:Name"`` of a model of the
    contract (engine.contract); ``sizes`` -- the lengths of the models' vector parameters
    (``(("alpha", 4), ("k", 4))`` for a 4-element GMS), which set their numbers of states;
    ``digests`` -- the source digest of each model brought by import path, taken where the
    Scene is made (the submitter): a worker whose copy of the module differs refuses to
    build its kernels (engine.systems.build_context) instead of computing other numbers.
    ``delta``, ``delta_d`` -- the exponents of Eqs. 2.4 and 2.5 folded into the simulate
    kernels when they are 1 or 2 (no run-time test per evaluation); None reads them from
    ``p``. A parameter vector must then carry the same values (:meth:`check_params`).
    """

    system: str = "slider"
    friction: str = "lugre"
    dither: str = "square-velocity"
    path: str = "simulate"
    integrator: str = "dopri5"
    stribeck: bool = True
    bristle_damping: bool = True
    viscous: bool = True
    slow_force: bool = True
    outputs: tuple[str, ...] = ()
    delta: float | None = None
    delta_d: float | None = None
    sizes: tuple = ()
    digests: tuple = ()

    def __post_init__(self):
        registry.system(self.system)     # ModelError (a ValueError) naming what is wrong
        registry.law(self.friction)
        object.__setattr__(self, "sizes", tuple(sorted(tuple(kv) for kv in self.sizes)))
        if not self.digests:   # the source of each brought model, as this process reads it
            object.__setattr__(self, "digests", tuple(
                (ref, registry.source_digest(ref)) for ref in (self.friction, self.system)
                if registry.is_import_path(ref)))
        if self.dither not in DITHER_KINDS:
            raise ValueError(f"dither must be one of {DITHER_KINDS}, got {self.dither!r}")
        if self.path not in PATHS:
            raise ValueError(f"path must be one of {PATHS}, got {self.path!r}")
        for name in ("delta", "delta_d"):
            if getattr(self, name) not in FOLDED_EXPONENTS + (None,):
                raise ValueError(f"{name} must be one of {FOLDED_EXPONENTS} or None (read "
                                 f"from p at run time), got {getattr(self, name)!r}")
        if self.path != "simulate":
            # one Scene per analysis problem; the analysis kernels read the exponents from p
            object.__setattr__(self, "integrator", "")
            object.__setattr__(self, "delta", None)
            object.__setattr__(self, "delta_d", None)

    @property
    def n_params(self) -> int:
        """The length of this scene's parameter vector (engine.registry.layout)."""
        return registry.scene_layout(self).n_params

    def check_params(self, p) -> None:
        """ValueError when ``p`` contradicts an exponent folded into the kernels."""
        for name, index in (("delta", P.DELTA), ("delta_d", P.DELTA_D)):
            fixed = getattr(self, name)
            if fixed is not None and p[index] != fixed:
                raise ValueError(f"p[{name}] = {p[index]!r} but the scene's kernels were "
                                 f"compiled for {name} = {fixed!r}; build the scene with "
                                 f"Scene.from_params(p, ...) or {name}=None")

    @classmethod
    def from_params(cls, p, *, system="slider", friction="lugre", dither="square-velocity",
                    path="simulate", integrator="dopri5", outputs=(), grid_vd=None,
                    sizes=()) -> Scene:
        """Scene whose effect flags are off exactly where ``p`` makes them vanish.

        ``grid_vd`` -- the swept vd values, if any (bristle damping matters when
        sigma1_hat != 0 whatever vd is; vd only scales it).
        """
        return cls(
            system=system, friction=friction, dither=dither, path=path, integrator=integrator,
            stribeck=bool(p[P.FS] != p[P.FC]),
            bristle_damping=bool(p[P.SIGMA1] != 0.0),
            viscous=bool(p[P.SIGMA2] != 0.0),
            slow_force=bool(p[P.SLOW_A] != 0.0 and system == "slider"),
            outputs=tuple(outputs),
            delta=_folded(p[P.DELTA]), delta_d=_folded(p[P.DELTA_D]), sizes=tuple(sizes),
        )

    def with_(self, **changes) -> Scene:
        return replace(self, **changes)
