"""What every gallery figure is drawn with: the size, the output folder, and the store in
which its scene sweeps run (so a later ``ditherlab map --scene`` finds them)."""
from __future__ import annotations

from dataclasses import dataclass
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

    def __post_init__(self):
        check_size(self.size)
        self.outdir = Path(self.outdir)

    @property
    def small(self) -> bool:
        return self.size == "small"

    def png(self, key: str) -> Path:
        return self.outdir / f"{key}.png"

    def spec(self, scene: str) -> dict:
        """The scene's spec at this size (the one source of the figure's parameters)."""
        return get_scene(scene).spec(self.size)

    def sweep(self, scene: str):
        """Run (or reuse) the scene's sweep at this size; its cube as an xarray.Dataset."""
        from ..api import open_sweep, run_sweep

        res = run_sweep(self.spec(scene), self.store, client=self.client,
                        workers=self.workers, progress=self.progress)
        if res.state != "done":
            raise RuntimeError(f"scene {scene} ({self.size}): sweep {res.sweep_id} ended "
                               f"{res.state} ({res.n_failed} failed points)")
        return open_sweep(res.sweep_id, self.store)
