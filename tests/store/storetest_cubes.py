"""Small hand-made cubes for the store tests (no engine: the store never computes).

Imported by name (pytest puts this folder on sys.path; tests/ is not a package)."""

import numpy as np

import store

OUTPUTS = {
    "F_mean": ("mean friction force after the transient", "1"),
    "long_stick_fraction": ("fraction of time in sticking runs longer than long_stick", "1"),
}
COORDS = {
    "W": [0.0, 0.5, 1.0],
    "omega": [10.0, 100.0, 1000.0, 1e4],
    "v_ref": [0.1, 0.2],
    "v_d": [0.1],
}
ATTRS = {
    "sweep_id": "0123456789abcdef",
    "name": "unit-cube",
    "spec": '{"name":"unit-cube"}',
    "engine_settings": {"rtol": 1e-6, "atol": 1e-8, "method": "dopri5"},
    "adaptive": True,
}


def make_cube(coords=COORDS, outputs=OUTPUTS, attrs=ATTRS, **kw):
    return store.empty_cube(coords, outputs, attrs, **kw)


def block_record(ds, at, seed=0, **change):
    """A block's deterministic results for the points ``at`` (flat indices; value = flat
    index + 0.25 etc.) as the runner hands them on (``store.BlockRecord``); ``change``
    replaces fields (e.g. ``index=``: the record claims other points)."""
    rng = np.random.default_rng(seed)
    n = len(at)
    outputs = {
        name: np.asarray(at, float) + 0.25 * k for k, name in enumerate(store.output_names(ds))
    }
    status = rng.choice(np.array([0, 0, 0, 2, 3], np.int8), size=n)
    fields = dict(index=at, status=status, cost_s=rng.random(n), steps=np.arange(n) * 7,
                  evals=np.arange(n) * 43, outputs=outputs)
    return store.BlockRecord(**{**fields, **change})


U, S, X = 0.0, 1.0, np.nan  # unstable, stable, not computed (status 2)
# rows: W = 0, 0.2, ..., 1.0; columns: the six V_REF values
STABLE_GRID = np.array(
    [
        [U, S, U, S, U, U],
        [U, S, U, U, U, X],
        [U, S, S, U, U, U],
        [S, S, U, S, U, U],
        [S, S, U, S, U, S],
        [S, S, S, S, U, U],
    ]
)
W = np.linspace(0.0, 1.0, 6)
V_REF = np.array([0.05, 0.1, 0.2, 0.4, 0.8, 1.0])


def averaged_cube(W=W, stable=STABLE_GRID, with_stable=True):
    outputs = {
        "F_eff": ("averaged effective friction", "1"),
        "max_real_eig": ("largest real part, per unit tau", "1"),
    }
    if with_stable:
        outputs["stable"] = ("stable (1) or unstable (0)", "1")
    ds = store.empty_cube(
        {"W": W, "omega": [1000.0], "v_ref": V_REF, "v_d": [0.1, 0.01]},
        outputs,
        {"name": "chart", "sweep_id": "c0ffee"},
    )
    grid = np.broadcast_to(stable[:, None, :, None], ds["status"].shape)
    status = np.where(np.isnan(grid), store.FAILED, store.OK).astype(np.int8)
    ds["status"].values[...] = status
    if with_stable:
        ds["stable"].values[...] = np.where(np.isnan(grid), np.nan, grid)
    ds["max_real_eig"].values[...] = np.where(
        np.isnan(grid), np.nan, np.where(grid == U, 0.3, -0.2)
    )
    ds["F_eff"].values[...] = np.arange(ds["F_eff"].size).reshape(ds["F_eff"].shape)
    return ds.to_dataset()   # as a reader gets it (store.open_cube)
