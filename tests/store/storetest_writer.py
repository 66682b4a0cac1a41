"""A writer that publishes generation after generation of a big cube until killed.

Run as ``python storetest_writer.py PATH N``: an N x N x 1 x 1 cube with two outputs;
generation g holds ``a = noise + g`` (noise from seed 0, so zlib cannot shrink it much)
and ``b = g``, and the global attribute ``generation = g``. Prints ``start g`` before
and ``done g`` after each publish.
"""

import sys

import numpy as np

import store


def noise(n: int) -> np.ndarray:
    return np.random.default_rng(0).random((n, n, 1, 1))


def main(path: str, n: int) -> None:
    coords = {
        "W": np.arange(n, dtype=float),
        "omega": np.arange(n, dtype=float) + 1.0,
        "v_ref": [0.1],
        "v_d": [0.1],
    }
    ds = store.empty_cube(
        coords, {"a": ("a", "1"), "b": ("b", "1")}, {"sweep_id": "big", "name": "big"}
    )
    base = noise(n)
    for gen in range(10**6):
        ds["a"].values[...] = base + gen
        ds["b"].values[...] = gen
        ds.attrs["generation"] = gen
        print(f"start {gen}", flush=True)
        store.publish(ds, path)
        print(f"done {gen}", flush=True)


if __name__ == "__main__":
    main(sys.argv[1], int(sys.argv[2]))
