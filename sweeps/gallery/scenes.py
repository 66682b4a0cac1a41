"""The paper's sweeps as named scenes: one registry, parameters read from ``specs/``.

A scene names a spec file of ``specs/`` (the one source of a figure's parameters) and says
how to shrink it: ``small`` (seconds, for tests) overrides only grid counts (a range's
``num``, or how many values of a list to keep, evenly spread), ``full`` is the spec as
written (the paper's figure). A *variant* (``fig14-lam0.5``) also overrides named
``[params]`` of the same file, for a question beyond the paper; nothing else is copied.

    >>> spec_dict("fig14", "small")["grid"]["W"]["num"]        # doctest: +SKIP
    7
"""
from __future__ import annotations

import copy
import tomllib
from dataclasses import dataclass, field
from pathlib import Path

from ..errors import RefusedError

SPECS = Path(__file__).resolve().parents[1] / "specs"   # sweeps/specs (the checkout's specs/)
SIZES = ("small", "full")


@dataclass(frozen=True)
class GalleryScene:
    """A named sweep of the paper.

    name : scene name (``fig14``); the sweep is named ``name`` (full) or ``name-small``.
    ref : where the paper has it (figure, section, equations).
    spec_file : file name in ``specs/``.
    small : grid counts of the small size, axis -> count.
    params : parameter overrides of a variant (empty for the paper's own scenes).
    refine : the spec's ``refine`` for the scene (sweeps.refine): Fig. 14's zone map is
        computed refined, which reproduces the exhaustive map cell for cell at 31 x 31
        (README, scripts/bench_maps.py) at an eighth of the points.
    """

    name: str
    ref: str
    spec_file: str
    small: dict = field(default_factory=dict)
    params: dict = field(default_factory=dict)
    refine: bool = False

    def spec(self, size: str = "full") -> dict:
        """The spec as a dict (``sweeps.load_spec`` takes it) at ``size``."""
        check_size(size)
        data = read_spec_file(self.spec_file)
        data["name"] = self.name if size == "full" else f"{self.name}-{size}"
        if self.params:
            data["params"] = {**data.get("params", {}), **self.params}
        if self.refine:
            data["refine"] = True
        if size == "small":
            for axis, count in self.small.items():
                data["grid"][axis] = shrink(data["grid"][axis], count)
        return data

    def n_points(self, size: str = "full") -> int:
        n = 1
        for values in self.spec(size).get("grid", {}).values():
            n *= values["num"] if isinstance(values, dict) else len(values)
        return n


REGISTRY: dict[str, GalleryScene] = {s.name: s for s in (
    GalleryScene("fig01", "Figs. 1-2, Sec. 3, Eqs. 3.1-3.3, App. A (contact model, HBM)",
                 "fig01-hbm.toml", small={"omega": 11}),
    GalleryScene("fig09", "Fig. 9, Sec. 6, Eqs. 6.4-6.7 (averaged stability chart)",
                 "fig09.toml", small={"W": 61, "v_ref": 60}),
    GalleryScene("fig10", "Fig. 10, Sec. 6, Eqs. 6.1-6.3 (LuGre slider, square dither)",
                 "fig10.toml", small={"v_d": 1}),
    GalleryScene("fig14", "Fig. 14, Sec. 7, Eqs. 2.3, 2.6-2.7 (elasto-plastic, sine dither)",
                 "fig14.toml", small={"W": 7, "omega": 7}, refine=True),
    GalleryScene("fig14-lam0.5", "beyond Fig. 14: lam = z_ba/z_ss = 0.5 (Eq. 2.6)",
                 "fig14.toml", small={"W": 7, "omega": 7}, params={"lam": 0.5}, refine=True),
)}


def check_size(size: str) -> None:
    if size not in SIZES:
        raise RefusedError(f"--size: must be one of {', '.join(SIZES)}, got {size!r}")


def get_scene(name: str) -> GalleryScene:
    """The scene called ``name``; a refusal listing the known names otherwise."""
    try:
        return REGISTRY[name]
    except KeyError:
        raise RefusedError(f"unknown scene {name!r}; known scenes: "
                           f"{', '.join(REGISTRY)} (`ditherlab scenes` lists them)") from None


def read_spec_file(file_name: str) -> dict:
    path = SPECS / file_name
    try:
        with open(path, "rb") as fh:
            return tomllib.load(fh)
    except OSError as exc:
        raise RefusedError(f"scene spec {path} cannot be read ({exc.strerror or exc}); it "
                           "ships with ditherlab: reinstall the package") from None


def shrink(axis, count: int):
    """An axis with ``count`` values: a range keeps start/stop and takes ``num = count``;
    a list keeps ``count`` of its values, evenly spread, first and last included."""
    if isinstance(axis, dict):
        return {**axis, "num": min(count, axis["num"])}
    values = list(axis)
    if count >= len(values):
        return copy.copy(values)
    if count == 1:
        return values[:1]
    step = (len(values) - 1) / (count - 1)
    return [values[round(i * step)] for i in range(count)]
