"""ditherlab's store: result cubes, the crash-safe journal, the catalogue, queries, maps.

Knows numpy, xarray, h5netcdf/h5py, sqlite3 and matplotlib (maps only); never
imports numba, dask, ``engine`` or ``sweeps`` (ARCHITECTURE.md).

How the sweep runner uses it (the submitting process is the only writer)::

    import store

    sweep = store.SweepDir(store_root, sweep_id)        # <store>/<id>/{cube.nc, journal/, spec.json}
    sweep.write_spec(spec_json)
    cat = store.Catalogue(store_root)
    cat.register(sweep_id, name, spec_json, n_points, n_blocks, sweep.root)

    empty = store.empty_cube(coords, variables, attrs)  # outputs NaN, status 1
    journal = store.Journal(sweep.journal)
    cube = store.rebuild(empty, journal)                # what earlier runs finished
    store.publish(cube, sweep.cube)                     # a valid cube from the start
    todo = [b for b in blocks if b.id not in journal.done()]      # resume
    for block_id, record in finished(todo):             # store.BlockRecord, as dask
        journal.write(block_id, record)                 # futures complete; durable now
        store.fill(cube, record)                        # O(block), no re-read
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
cube / points / cube_io
    ``AXES``; ``empty_cube(coords, variables, attrs=None, axis_units=None,
    axis_long_names=None) -> Cube`` (``store.cubedata``: numpy arrays, dims, attributes;
    ``.to_dataset()`` for xarray); ``output_names(ds)``; ``fill(ds, record)``;
    ``status_counts(ds)``; ``publish(ds, path) -> Path``;
    ``open_cube(path) -> xarray.Dataset``; ``read_cube(path) -> Cube``; status codes
    ``OK, NOT_COMPUTED, FAILED, NON_FINITE`` and provenance codes ``COMPUTED, INFERRED,
    UNDECIDED`` (store.flags).
record / journal
    ``BlockRecord(index, status, cost_s, steps, evals, outputs)``: one block's results from
    the worker to the journal to the cube; ``Journal(folder)`` with ``.write(block_id,
    record)``, ``.done() -> set[int]``, ``.read() -> Iterator[(block_id, record)]``;
    ``rebuild(ds_empty, journal) -> Cube``.
catalogue
    ``Catalogue(store_root)`` with ``register``, ``update``, ``get``, ``find``,
    ``list``, ``scan``; ``STATES``.
query
    ``zone_map``, ``stability_chart``, ``effective_friction_curve``, ``table``,
    ``select``; labels ``STABLE, PU, SU, NO_DATA``.
maps
    ``stability_map``, ``stick_slip_map``, ``hunting_map``, ``friction_curves`` (PNG files).
layout / atomic / errors / attrs
    ``SweepDir(store_root, sweep_id)``, ``ENV_STORE``/``DEFAULT_STORE`` (the default
    store, sweeps.lookup.store_root); ``atomic_write``;
    ``store.errors.StoreError`` and its kinds; ``canonical_json``, ``decode_attr``.
"""

import lazy_loader as _lazy

# Re-exports load their module on first use: `ditherlab status` needs the catalogue, not
# xarray or matplotlib (a command's start-up time is its imports).
__getattr__, __dir__, __all__ = _lazy.attach(
    __name__,
    submodules=["atomic", "attrs", "catalogue", "catalogue_db", "cube", "cube_io", "cubedata",
                "errors",
                "flags", "header", "journal", "layout", "lease", "maps", "points", "query",
                "record"],
    submod_attrs={
        "attrs": ["canonical_json", "decode_attr"],
        "catalogue": ["STATES", "Catalogue"],
        "cube": ["AXES", "empty_cube", "output_names"],
        "cube_io": ["open_cube", "publish", "read_cube"],
        "cubedata": ["Cube", "as_dataset"],
        "header": ["read_header"],
        "journal": ["Journal", "rebuild"],
        "record": ["BlockRecord"],
        "atomic": ["atomic_write"],
        "layout": ["SweepDir"],
        "points": ["fill", "status_counts"],
        "axes": ["FIGURE_FORMATS", "figure_format"],
        "maps": ["friction_curves", "stability_map", "stick_slip_map"],
        "hunting": ["hunting_map"],
        "query": ["NO_DATA", "PU", "STABLE", "SU", "effective_friction_curve", "select",
                  "stability_chart", "table", "zone_map"],
        "flags": ["COMPUTED", "FAILED", "INFERRED", "NON_FINITE", "NOT_COMPUTED", "OK",
                  "PROVENANCE_MEANINGS", "STATUS_MEANINGS", "UNDECIDED"],
    },
)
