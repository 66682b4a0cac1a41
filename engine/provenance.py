"""Which engine made a result: a fingerprint of the engine's Python sources.

``fingerprint()`` is 12 hex digits of sha256 over every ``engine/**/*.py`` (relative path
and contents), computed once per process (~3 ms) and then cached, so it names the engine
this process loaded. It goes into every sweep id and every cube's ``engine_fingerprint``
attribute (a cube made by another engine is never served as current, DESIGN.md §4) and
names numba's disk-cache folder (engine.jit). Any edit of an engine source, even a
comment, changes it: a false "stale" costs a recomputation, a missed one a wrong answer.

Only hashlib and pathlib here: hashing files needs no numba.
"""
from __future__ import annotations

import functools
import hashlib
import os
from pathlib import Path

ENGINE_ROOT = Path(__file__).resolve().parent


def source_hash(root: Path | str = ENGINE_ROOT) -> str:
    """12 hex digits of sha256 over the Python sources under ``root`` (paths and contents),
    read now."""
    root = Path(root)
    digest = hashlib.sha256()
    for path in sorted(root.rglob("*.py")):
        digest.update(str(path.relative_to(root).as_posix()).encode())
        digest.update(path.read_bytes())
    return digest.hexdigest()[:12]


@functools.cache
def fingerprint() -> str:
    """The fingerprint of the engine in this process: :func:`source_hash` of
    ``engine/``, computed on the first call and cached."""
    return source_hash(ENGINE_ROOT)


def cache_root() -> Path:
    """The folder of ditherlab's caches: ``$DITHERLAB_CACHE_DIR``, else ``~/.cache/ditherlab``
    (numba's kernels under ``numba-<fingerprint>``, engine.jit; batch jobs are pointed at it,
    sweeps.workers.batch). The one place that decides it."""
    return Path(os.environ.get("DITHERLAB_CACHE_DIR") or Path.home() / ".cache" / "ditherlab")
