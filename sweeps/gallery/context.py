"""What every gallery figure is drawn with: the size, the output folder, and the store in
which its scene sweeps run (so a later ``ditherlab map --scene`` finds them)."""
from __future__ import annotations

from contextlib import ExitStack, contextmanager
from dataclasses import dataclass, field
from pathlib import Path

from .scenes import check_size, get_scene


@dataclass
class Context:
    """``size`` small|full; ``outdir`` where the PNGs go; ``store`` the sweep store (None:
    ``$DITHERLAB_STORE`` or ``./ditherlab-store``); ``workers`` of the local dask cluster;
    ``client`` an existing dask client (reused by every sweep, left open)."""

    size: str = "small"
    outdir: Path = Path("gallery")
    store: str | Path | None = None
    workers: int = 2
    client: object = None
    progress: bool = False
    #: a deliberately wrong model for the rules' own tests (tests/sweeps/gallery/test_wrong_models):
    #: parameter overrides for every engine computation (simulation and averaged theory
    #: alike: a shared error), ``W_scale`` multiplying every dither amplitude the engine sees
    model: dict = field(default_factory=dict)
    #: overrides for the averaged theory only (e.g. a perturbed g: ``{"fs": 1.6}``)
    theory: dict = field(default_factory=dict)

    #: set by :meth:`shared_cluster`: where the gallery's own cluster is kept open
    _stack: ExitStack | None = field(default=None, repr=False)

    def __post_init__(self):
        check_size(self.size)
        self.outdir = Path(self.outdir)

    @property
    def physics(self) -> dict:
        """The model overrides that are parameters (``W_scale`` is not)."""
        return {k: v for k, v in self.model.items() if k != "W_scale"}

    @property
    def W_scale(self) -> float:
        return float(self.model.get("W_scale", 1.0))

    @property
    def run_model(self) -> tuple:
        """The model overrides as a hashable tuple (trajectories.run's ``model``)."""
        return tuple(sorted(self.model.items()))

    def pack(self, defaults=None, **values):
        """``engine.params.pack`` with the model's overrides (a simulation's parameters)."""
        from engine import params as P

        if "W" in values:
            values["W"] = values["W"] * self.W_scale
        return P.pack(defaults, **{**values, **self.physics})

    def theory_pack(self, defaults=None, **values):
        """Parameters of the averaged theory: the model's and the theory's overrides (the
        theory takes W as an argument: scale it with :attr:`W_scale` where it is passed)."""
        from engine import params as P

        return P.pack(defaults, **{**values, **self.physics, **self.theory})

    @property
    def small(self) -> bool:
        return self.size == "small"

    def png(self, key: str) -> Path:
        return self.outdir / f"{key}.png"

    def spec(self, scene: str) -> dict:
        """The scene's spec at this size (the one source of the figure's parameters), with
        the model's parameter overrides (none but in the rules' own tests)."""
        spec = get_scene(scene).spec(self.size)
        if self.physics:
            spec["params"] = {**spec.get("params", {}), **self.physics}
            spec["name"] += "-wrong-model"
        return spec

    @contextmanager
    def shared_cluster(self):
        """Within it, the first simulated sweep starts a LocalCluster of ``workers`` that
        every later sweep reuses (Fig. 14 and its lam = 0.5 twin: one cluster start and one
        kernel compilation on the workers, not one per sweep); closed on leaving. Without a
        simulated sweep no cluster starts. An existing ``client`` is used as it is."""
        own = self.client is None
        with ExitStack() as stack:
            self._stack = stack if own else None
            try:
                yield self
            finally:
                self._stack = None
                if own:
                    self.client = None

    def sweep(self, scene: str):
        """Run (or reuse) the scene's sweep at this size; its cube as an xarray.Dataset."""
        from ..api import open_sweep, run_sweep

        spec = self.spec(scene)
        if self.client is None and self._stack is not None and spec.get("method") == "simulate":
            from ..workers.cluster import dask_client

            self.client = self._stack.enter_context(dask_client(None, self.workers))
        res = run_sweep(spec, self.store, client=self.client,
                        workers=self.workers, progress=self.progress)
        if res.state != "done":
            raise RuntimeError(f"scene {scene} ({self.size}): sweep {res.sweep_id} ended "
                               f"{res.state} ({res.n_failed} failed points)")
        return open_sweep(res.sweep_id, self.store)
