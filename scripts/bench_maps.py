"""Maps at the speed of thought (issue 11): full grid against adaptive refinement, in one run.

For Fig. 14 (the elasto-plastic zone map, specs/fig14.toml, standard accuracy) at 31x31 and
61x61 and for Fig. 9 (the averaged stability chart, 400x400 over (v_ref, W), v_d = 0.1) it
prints: points computed, wall time (``ditherlab submit`` as a subprocess, process start to
exit: imports, cluster start and compute), the ratio, and the share of cells whose class
(zone, or stable / PU / SU label) agrees with the full grid.

Targets (issue 11): refined Fig. 14 31x31 <= 25 % of points, >= 99 % agreement, <= 30 s;
61x61 <= 12 %; Fig. 9 400x400 end to end <= 2 s, refined labels identical.

    python scripts/bench_maps.py                 # everything (the full 61x61 takes long)
    python scripts/bench_maps.py --skip-full 61  # the 61x61 full grid from its plan estimate
    python scripts/bench_maps.py --skip-full 61 --full-from STORE   # ... agreement with a
                                                 # full 61x61 cube computed before in STORE
"""
from __future__ import annotations

import argparse
import json
import os
import platform
import subprocess
import sys
import tempfile
import time
import tomllib
import warnings
from pathlib import Path

import numpy as np
import xarray as xr

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

import store   # noqa: E402
from machine import cpu_model  # noqa: E402
import sweeps  # noqa: E402

# the benchmark compares classes, which inferred points settle; their values are not read
warnings.simplefilter("ignore", sweeps.InferredPointsWarning)


def fig14(n: int, refine: bool) -> dict:
    spec = tomllib.loads((ROOT / "specs" / "fig14.toml").read_text())
    spec["grid"]["W"]["num"] = spec["grid"]["omega"]["num"] = n
    spec["name"] = f"bench-fig14-{n}" + ("-refined" if refine else "")
    return {**spec, "refine": True} if refine else spec


def fig09(refine: bool) -> dict:
    spec = {"name": "bench-fig09-400" + ("-refined" if refine else ""), "friction": "lugre",
            "dither": "square-velocity", "method": "averaged",
            "outputs": ["F_eff", "max_real_eig", "stable"],
            "grid": {"W": {"start": 0.0, "stop": 1.2, "num": 400},
                     "v_ref": {"start": 0.005, "stop": 1.2, "num": 400}, "v_d": [0.1]}}
    return {**spec, "refine": True} if refine else spec


def submit(spec: dict, root: Path) -> tuple[float, str, float]:
    """Wall seconds of `ditherlab submit` (a fresh process), the sweep id, and the longest
    time its progress display sat still while points were computed: the gap between two
    writes of the progress bar (tqdm, to stderr), from its first to its last."""
    path = root / f"{spec['name']}.json"
    path.write_text(json.dumps(spec))
    t0 = time.perf_counter()
    proc = subprocess.Popen([sys.executable, "-m", "sweeps.cli", "submit", str(path),
                             "--store", str(root / "store")],
                            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    writes = []
    while chunk := os.read(proc.stderr.fileno(), 65536):
        if b"point" in chunk:                 # a progress-bar update ("12/961 [...point/s]")
            writes.append(time.perf_counter())
    if proc.wait() != 0:
        raise RuntimeError(f"ditherlab submit {path} failed (exit {proc.returncode})")
    still = float(np.max(np.diff(writes))) if len(writes) > 1 else float("nan")
    return time.perf_counter() - t0, sweeps.load_spec(spec).sweep_id, still


def classes(ds, kind: str) -> np.ndarray:
    if kind == "zone":
        return store.zone_map(ds).values
    return store.stability_chart(ds, sel={"v_d": 0.1}).values


def computed(ds) -> int:
    return int((ds["provenance"].values == 0).sum()) if "provenance" in ds \
        else int(ds["status"].size)


def estimate_s(spec: dict) -> float:
    from sweeps.estimates.time_estimate import estimates

    level = spec.get("accuracy", "standard")
    return next(e.wall_s for e in estimates(sweeps.load_spec(spec)) if e.level == level)


def same_spec(spec: dict, stores: list[Path]) -> Path | None:
    """The cube of a sweep of ``spec`` (under any name, by any engine version) in
    ``stores``: e.g. the gallery's fig14 is the 31x31 full grid."""
    def key(s: dict) -> dict:
        return {k: v for k, v in json.loads(sweeps.load_spec(s).to_json()).items()
                if k not in ("name", "description")}

    want = key(spec)
    for sweep in (d for where in stores for d in sorted(where.iterdir())):
        spec_file, cube = sweep / "spec.json", sweep / "cube.nc"
        if spec_file.exists() and cube.exists() and \
                key(json.loads(spec_file.read_text())) == want:
            return cube
    return None


def row(label: str, kind: str, full_spec: dict, ref_spec: dict, root: Path, skip_full: bool,
        full_from: list[Path] | None = None):
    t_ref, ref_id, still = submit(ref_spec, root)
    ref = sweeps.open_sweep(ref_id, root / "store")
    n = int(ref["status"].size)
    if skip_full:
        t_full, agree = estimate_s(full_spec), float("nan")
        note = "full: plan estimate (not run)"
        cube = same_spec(full_spec, full_from or [])
        if cube is not None:   # a full grid computed earlier: its classes, not its time
            with xr.open_dataset(cube, engine="h5netcdf") as full:
                full = full.load()
            if (full["status"].values == 0).all():   # not a cube still being computed
                agree = float(np.mean(classes(full, kind) == classes(ref, kind)))
                note += f"; agreement with {cube}"
    else:
        t_full, full_id, still_full = submit(full_spec, root)
        still = max(still, still_full)
        full = sweeps.open_sweep(full_id, root / "store")
        agree = float(np.mean(classes(full, kind) == classes(ref, kind)))
        note = ""
    k = computed(ref)
    print(f"{label:<22}{n:>8}{k:>10}{k / n:>8.1%}{t_full:>10.1f}{t_ref:>10.1f}"
          f"{t_full / t_ref:>8.1f}x{agree:>10.2%}{still:>9.1f}  {note}", flush=True)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--skip-full", type=int, nargs="*", default=[],
                    help="Fig. 14 sizes whose full grid is estimated, not run (e.g. 61)")
    ap.add_argument("--sizes", type=int, nargs="*", default=[31, 61])
    ap.add_argument("--full-from", type=Path, nargs="*", default=[],
                    help="stores holding full grids computed earlier (the same spec under "
                         "any name, e.g. the gallery's fig14 for 31): the sizes in "
                         "--skip-full are compared with them for agreement")
    args = ap.parse_args()
    print(f"Python {platform.python_version()}; 2 dask workers (default); 'still s': the "
          f"longest time a progress display sat still while points were computed")
    print(f"CPU: {cpu_model()}; load average at start {os.getloadavg()[0]:.2f}")
    print(f"{'map':<22}{'points':>8}{'computed':>10}{'share':>8}{'full s':>10}{'refined s':>10}"
          f"{'ratio':>9}{'agree':>10}{'still s':>9}")
    with tempfile.TemporaryDirectory() as tmp:
        root = Path(tmp)
        for n in args.sizes:
            row(f"Fig. 14 {n}x{n} standard", "zone", fig14(n, False), fig14(n, True), root,
                n in args.skip_full, args.full_from)
        row("Fig. 9 400x400 averaged", "chart", fig09(False), fig09(True), root, False)


if __name__ == "__main__":
    main()
