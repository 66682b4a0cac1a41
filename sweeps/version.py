"""The package version, read from the installed distribution metadata."""
from importlib.metadata import PackageNotFoundError, version

try:
    __version__ = version("ditherlab")
except PackageNotFoundError:  # running from a source tree that was never installed
    __version__ = "0.0.0+unknown"


# the modules that turn a spec into what the engine runs (levels, tolerances, scene, grid):
# a change there changes results as surely as an engine edit
PLANNING = ("spec/accuracy.py", "spec/grid.py", "spec/methods.py", "planning/plan.py",
            "planning/refine.py", "planning/lattice.py", "run/refined.py")


def results_fingerprint() -> str:
    """12 hex digits naming everything that makes a cube's numbers: the engine's sources
    (``engine.provenance.fingerprint``) and the planning modules :data:`PLANNING`. It is in
    every sweep id, cube (``engine_fingerprint``) and catalogue row; a cube made under
    another fingerprint is stale (README "Which engine made this cube")."""
    import hashlib

    from engine import provenance

    return hashlib.sha256((provenance.fingerprint() + _planning_hash()).encode()).hexdigest()[:12]


def _planning_hash() -> str:
    global _PLANNING_HASH
    if _PLANNING_HASH is None:
        import hashlib
        from pathlib import Path

        root, digest = Path(__file__).resolve().parent, hashlib.sha256()
        for name in PLANNING:
            digest.update(name.encode() + (root / name).read_bytes())
        _PLANNING_HASH = digest.hexdigest()
    return _PLANNING_HASH


_PLANNING_HASH: str | None = None
