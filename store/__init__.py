"""ditherlab's store: result cubes, the crash-safe journal, the catalogue, queries, maps.

Knows numpy, xarray, h5netcdf/h5py, sqlite3 and matplotlib (maps only); never
imports numba, dask, ``engine`` or ``sweeps`` (ARCHITECTURE.md).

How the sweep runner uses it (the submitting process is the only writer)::

    import store

    sweep = store.SweepDir(store_root, sweep_id)        # <store>/<id>/{cube.h5, journal/, spec.json}
    sweep.write_spec(spec_json)
    cat = store.Catalogue(store_root)
    cat.register(sweep_id, name, spec_json, n_points, n_blocks, sweep.root)

    empty = store.empty_cube(coords, variables, attrs)  # outputs NaN, status 1
    journal = store.Journal(sweep.journal)
    cube = store.rebuild(empty, journal)                # what earlier runs finished
    store.publish(cube, sweep.cube)                     # a valid cube from the start
    todo = [b for b in blocks if b.id not in journal.done()]      # resume
    for block, result in finished(todo):                # as dask futures complete
        payload = store.block_payload(block.flat_index, result.outputs, result.status,
                                      result.cost_s, result.steps, result.evals)
        journal.write(block.id, payload)                # durable from here on
        store.fill_block(cube, payload)                 # O(block), no re-read
        if every_few_seconds_or_last:
            store.publish(cube, sweep.cube)             # atomic replace
            counts = store.status_counts(cube)
            cat.update(sweep_id, state="running", done_points=..., failed_points=...)

``rebuild`` re-reads every journal file (~1 ms a block): call it once when a run
starts, not after every block. The journal, not the cube, is the durable record:
a run killed at any instant resumes from ``journal.done()``.

and how a user reads it::

    ds = store.open_cube(sweep.cube)                    # in memory, file closed
    store.zone_map(ds)                                  # Fig. 14 zones over (W, omega)
    store.stability_chart(ds, sel={"v_d": 0.1})         # Fig. 9 labels over (v_ref, W)
    store.stability_map(ds, "fig09.png", sel={"v_d": 0.1})

Public API
----------
cube
    ``AXES``; ``empty_cube(coords, variables, attrs=None, axis_units=None,
    axis_long_names=None) -> Dataset``; ``fill(ds, flat_index, values, status, cost_s,
    steps, evals)``; ``publish(ds, path) -> Path``; ``open_cube(path) -> Dataset``;
    ``grid_points(ds, flat_index=None) -> (n, 4)``; ``pending_index(ds)``;
    ``status_counts(ds)``; ``output_names(ds)``; status codes ``OK, NOT_COMPUTED,
    FAILED, NON_FINITE``.
journal
    ``Journal(folder)`` with ``.write(block_id, payload)``, ``.done() -> set[int]``,
    ``.read() -> Iterator[(block_id, payload)]``; ``block_payload(...)``;
    ``fill_block(ds, payload)``; ``rebuild(ds_empty, journal) -> Dataset``.
catalogue
    ``Catalogue(store_root)`` with ``register``, ``update``, ``get``, ``find``,
    ``list``, ``scan``; ``STATES``.
query
    ``zone_map``, ``stability_chart``, ``effective_friction_curve``, ``table``,
    ``select``; labels ``STABLE, PU, SU, NO_DATA``.
maps
    ``stability_map``, ``stick_slip_map``, ``friction_curves`` (PNG files).
layout / attrs
    ``SweepDir(store_root, sweep_id)``, ``default_store()``, ``atomic_write``;
    ``canonical_json``, ``decode_attr``.
"""

from .attrs import canonical_json
from .attrs import decode as decode_attr
from .catalogue import STATES, Catalogue
from .cube import (
    AXES,
    FAILED,
    NON_FINITE,
    NOT_COMPUTED,
    OK,
    STATUS_MEANINGS,
    empty_cube,
    fill,
    grid_points,
    open_cube,
    output_names,
    pending_index,
    publish,
    status_counts,
)
from .journal import Journal, block_payload, fill_block, rebuild
from .layout import SweepDir, atomic_write, default_store
from .maps import friction_curves, stability_map, stick_slip_map
from .query import (
    NO_DATA,
    PU,
    STABLE,
    SU,
    effective_friction_curve,
    select,
    stability_chart,
    table,
    zone_map,
)

__all__ = [
    "AXES",
    "FAILED",
    "NON_FINITE",
    "NOT_COMPUTED",
    "NO_DATA",
    "OK",
    "PU",
    "STABLE",
    "STATES",
    "STATUS_MEANINGS",
    "SU",
    "Catalogue",
    "Journal",
    "SweepDir",
    "atomic_write",
    "block_payload",
    "canonical_json",
    "decode_attr",
    "default_store",
    "effective_friction_curve",
    "empty_cube",
    "fill",
    "fill_block",
    "friction_curves",
    "grid_points",
    "open_cube",
    "output_names",
    "pending_index",
    "publish",
    "rebuild",
    "select",
    "stability_chart",
    "stability_map",
    "status_counts",
    "stick_slip_map",
    "table",
    "zone_map",
]
