"""Restructuring without changing a bit: record the engine's numbers, then compare.

    .venv/bin/python scripts/bit_identical.py record out/bits-before.npz     # before the change
    .venv/bin/python scripts/bit_identical.py compare out/bits-before.npz    # after it
    .venv/bin/python scripts/bit_identical.py diff before.npz after.npz      # two records

To record the code before a change, run this script with the ``PYTHONPATH`` of a worktree of
that commit (``git worktree add /tmp/bits-before <commit>``; ``PYTHONPATH=/tmp/bits-before
.venv/bin/python /tmp/bits-before/scripts/bit_identical.py record ...``): the editable install's
finder comes after ``PYTHONPATH`` and the local dask workers inherit it. For a commit before
a9db7bc run it from the worktree's folder (``cd /tmp/bits-before``): Python 3.11's fork
server imports from its current directory first, and those commits forked their workers
from it even in another checkout (sweeps.workers.local_start). The first line printed
names the folder the packages were imported from.

What is recorded (every float64 array, compared bit for bit; NaN equals NaN):

- **every cube of ``specs/``**, run at its full grid into a temporary store through the Python
  API (``sweeps.run_sweep``), all data variables except the wall-clock ``cost_s``;
- **engine probes**: one trajectory per compile-time scene variant that the simulate path can
  take (each friction law x each dither on the slider, each integrator, the contact system
  with each law, each effect flag switched off; Dahl and GMS on the slider and the contact
  system, the servo with LuGre and GMS), with its steps recorded (t, y), its outputs,
  final state and step counters;
- **the hard cases** of ``tests/hard`` run in CI (stiff contacts, tiny velocities, fast
  dither), at the tolerances of their tests, recorded step by step.

``--quick`` thins each spec's axes to every third value (for iterating; the acceptance run is
the full one). ``--specs-only`` records or compares the spec cubes alone (a change outside the
engine: the probes and hard cases run code it did not touch). A difference prints the key,
how many elements differ and the largest
difference; the exit status is 1 if anything differs or is missing.
"""
from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

PROBE = {"v_ref": 0.4, "W": 0.4, "omega": 300.0, "t_end": 3.0, "t_transient": 1.0}
CONTACT_PROBE = {"t_end": 0.05, "t_transient": 0.01}
LAWS = ("coulomb", "stribeck", "lugre", "elastoplastic")
DITHERS = ("none", "square-velocity", "sine-velocity", "sine-force")
# the models' probes: Dahl and GMS (own parameters: docs/examples/servo-gms.toml's GMS), on
# each system; the servo with its own outputs
GMS = {"k": [40.0, 100.0, 250.0], "alpha": [0.2, 0.3, 0.5], "C": 20.0}
SERVO = {"kp": 1.0, "ki": 0.5, "kd": 1.0, "x_ref": 1.0}
SERVO_OUTPUTS = ("hunt_amplitude", "hunt_period", "steady_error", "stick_fraction")


def _scenes():
    """(key, Scene keywords, parameter overrides, defaults) of every engine probe."""
    from engine.outputs import SIMULATE

    outputs = tuple(SIMULATE)
    for law in LAWS:
        for dither in DITHERS:
            yield (f"slider/{law}/{dither}/dopri5",
                   dict(friction=law, dither=dither, integrator="dopri5", outputs=outputs),
                   PROBE, None)
    for method in ("rk4", "rodas4"):
        for law in ("lugre", "elastoplastic"):
            yield (f"slider/{law}/square-velocity/{method}",
                   dict(friction=law, integrator=method, outputs=outputs), PROBE, None)
    for flag in ("stribeck", "bristle_damping", "viscous"):
        yield (f"slider/lugre/square-velocity/dopri5/no-{flag}",
               dict(integrator="dopri5", outputs=outputs, **{flag: False}), PROBE, None)
    yield ("slider/lugre/square-velocity/dopri5/slow-force",
           dict(integrator="dopri5", outputs=outputs, slow_force=True),
           {**PROBE, "slow_a": 0.1, "slow_omega": 2.0}, None)
    for law in LAWS:
        for method in ("dopri5", "rodas4"):
            yield (f"contact/{law}/sine-velocity/{method}",
                   dict(system="contact", friction=law, dither="sine-velocity", integrator=method,
                        outputs=("F_mean", "v_mean")),
                   CONTACT_PROBE, "contact")
    yield from _model_scenes(outputs)


def _model_scenes(outputs):
    """The probes of the laws and the system that came with the models issue: their
    parameters packed by engine.registry (``defaults`` names law, system and own values)."""
    for law, own in (("dahl", {}), ("gms", GMS)):
        for dither in DITHERS:
            yield (f"slider/{law}/{dither}/dopri5", dict(friction=law, dither=dither,
                   outputs=outputs), PROBE, (law, "slider", own))
        yield (f"slider/{law}/square-velocity/rodas4", dict(friction=law, integrator="rodas4",
               outputs=outputs), PROBE, (law, "slider", own))
        yield (f"contact/{law}/sine-velocity/dopri5",
               dict(system="contact", friction=law, dither="sine-velocity",
                    outputs=("F_mean", "v_mean")), CONTACT_PROBE, (law, "contact", own))
    for law, own in (("lugre", {}), ("gms", GMS)):
        for dither in ("none", "square-velocity", "sine-velocity"):
            yield (f"servo/{law}/{dither}/dopri5",
                   dict(system="servo", friction=law, dither=dither, outputs=SERVO_OUTPUTS),
                   {**PROBE, "t_end": 30.0, "t_transient": 10.0}, (law, "servo", {**own, **SERVO}))


def _probe(kw, over, defaults):
    """The Scene and parameter vector of one probe."""
    from engine import params as P
    from engine import registry
    from engine.scene import Scene

    if isinstance(defaults, tuple):   # a model's probe: (law, system, own values)
        law, system, own = defaults
        p = registry.pack(law, system, own, **over)
        return Scene.from_params(p, sizes=registry.sizes_of(law, system, own), **kw), p
    return Scene(**kw), P.pack(P.CONTACT_DEFAULTS if defaults == "contact" else None, **over)


def engine_probes() -> dict:
    from engine.api import simulate

    found = {}
    for key, kw, over, defaults in _scenes():
        try:
            sim = simulate(*_probe(kw, over, defaults), record=True, max_records=200_000)
        except ValueError as err:   # a combination the engine refuses: the refusal is recorded
            found[f"probe/{key}/refused"] = np.frombuffer(str(err).encode(), dtype=np.uint8)
            continue
        found[f"probe/{key}/t"] = sim.t
        found[f"probe/{key}/y"] = sim.y
        found[f"probe/{key}/y_end"] = sim.y_end
        found[f"probe/{key}/counts"] = np.array(
            [sim.status, sim.steps, sim.rejected, sim.evals], dtype=np.float64)
        found[f"probe/{key}/outputs"] = np.array(list(sim.outputs.values()))
        if sim.alpha_hist is not None:
            found[f"probe/{key}/alpha_hist"] = sim.alpha_hist
    return found


def hard_cases() -> dict:
    sys.path.insert(0, str(ROOT / "tests" / "hard"))
    from tests.hard import hardcases
    from tests.hard.test_hard_cases import CI

    found = {}
    for case in CI:
        r = hardcases.run(case.params, case.method, case.rtol, case.budget, record=case.record)
        key = f"hard/{case.name}/{case.method}"
        found[f"{key}/q"] = r.q
        found[f"{key}/counts"] = np.array([r.status, r.steps, r.rejected, r.evals, r.z_max])
        # (the outputs the cases compare: DP5's scene computes every output, shared)
        found[f"{key}/outputs"] = np.array([r.outputs[k] for k in hardcases.OUTPUTS])
    return found


def _thin(spec):
    """Every third value of each list axis; a third of the points of each range axis."""
    def thin(axis):
        if isinstance(axis, list):
            return axis[::3]
        if isinstance(axis, dict):
            return {**axis, "num": max(2, axis["num"] // 3)}
        return axis
    data = spec.model_dump()
    data["grid"] = {k: thin(v) for k, v in data["grid"].items()}
    return type(spec).model_validate(data)


def spec_cubes(quick: bool) -> dict:
    import xarray as xr

    import sweeps
    from sweeps.spec import load_spec

    found = {}
    with tempfile.TemporaryDirectory() as store:
        for path in sorted((ROOT / "specs").glob("*.toml")):
            spec = load_spec(path)
            if quick:
                spec = _thin(spec)
            t0 = time.perf_counter()
            res = sweeps.run_sweep(spec, store=store, progress=False)
            with xr.open_dataset(res.cube_path, engine="h5netcdf") as ds:
                for name, var in ds.data_vars.items():
                    if name != "cost_s":
                        found[f"spec/{path.stem}/{name}"] = np.asarray(var.values)
            print(f"  {path.name}: {time.perf_counter() - t0:.1f} s", flush=True)
    return found


def collect(quick: bool, specs_only: bool = False) -> dict:
    if specs_only:
        return spec_cubes(quick)
    t0 = time.perf_counter()
    found = engine_probes()
    print(f"engine probes: {len(found)} arrays, {time.perf_counter() - t0:.1f} s", flush=True)
    t0 = time.perf_counter()
    found |= hard_cases()
    print(f"hard cases: {time.perf_counter() - t0:.1f} s", flush=True)
    found |= spec_cubes(quick)
    return found


def _same(a, b) -> bool:
    if a.shape != b.shape or a.dtype != b.dtype:
        return False
    if a.dtype.kind == "f":
        return a.tobytes() == b.tobytes() or bool(np.array_equal(a, b, equal_nan=True))
    return bool(np.array_equal(a, b))


def compare(before: dict, after: dict) -> int:
    bad = 0
    for key in sorted(before.keys() | after.keys()):
        if key not in after or key not in before:
            print(f"MISSING {'after' if key not in after else 'before'}: {key}")
            bad += 1
            continue
        a, b = before[key], after[key]
        if not _same(a, b):
            bad += 1
            if a.shape == b.shape and a.dtype.kind == b.dtype.kind == "f":
                diff = np.abs(a - b)
                n = int(np.count_nonzero(~((a == b) | (np.isnan(a) & np.isnan(b)))))
                print(f"DIFFERS {key}: {n} of {a.size} elements, max |diff| {np.nanmax(diff):.3g}")
            else:
                print(f"DIFFERS {key}: shape {a.shape} {a.dtype} vs {b.shape} {b.dtype}")
    print(f"{len(before)} arrays recorded, {len(after)} now: "
          + ("all bit-identical" if not bad else f"{bad} differ or are missing"))
    return 1 if bad else 0


def _load(path: Path) -> dict:
    with np.load(path) as npz:
        return {k: npz[k] for k in npz.files}


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("action", choices=("record", "compare", "diff"))
    ap.add_argument("file", type=Path)
    ap.add_argument("other", type=Path, nargs="?", help="diff: the second record")
    ap.add_argument("--quick", action="store_true", help="every third grid value of each spec")
    ap.add_argument("--specs-only", action="store_true", help="the spec cubes alone")
    args = ap.parse_args()
    if args.action == "diff":
        if args.other is None:
            ap.error("diff takes two records")
        return compare(_load(args.file), _load(args.other))
    import engine
    import sweeps

    print(f"code from {Path(engine.__file__).parent.parent} "
          f"(sweeps from {Path(sweeps.__file__).parent.parent})", flush=True)
    found = collect(args.quick, args.specs_only)
    if args.action == "record":
        args.file.parent.mkdir(parents=True, exist_ok=True)
        np.savez_compressed(args.file, **found)
        print(f"recorded {len(found)} arrays in {args.file}")
        return 0
    before = _load(args.file)
    if args.specs_only:
        before = {k: v for k, v in before.items() if k.startswith("spec/")}
    return compare(before, found)


if __name__ == "__main__":
    sys.exit(main())
