"""The three rooms keep their one-way doors (STYLE.md 'The house', docs/ARCHITECTURE.md):
engine imports no dask/xarray/matplotlib/store/sweeps; store imports no numba/engine/
sweeps/dask. Each package is imported in a fresh interpreter with the others blocked."""
import subprocess
import sys

import pytest

# A None entry in sys.modules makes `import x` raise ImportError while letting
# `importlib.util.find_spec(x)` answer None: xarray probes for dask that way at import
# ("is it available?") without importing it, which is allowed.
BLOCKER = """
import sys
for name in {blocked!r}:
    sys.modules[name] = None
import {package}
import pkgutil, importlib
for mod in pkgutil.walk_packages({package}.__path__, '{package}.'):
    importlib.import_module(mod.name)
"""

RULES = {
    "engine": ["dask", "distributed", "xarray", "h5py", "h5netcdf", "matplotlib", "store",
               "sweeps"],
    "store": ["numba", "engine", "sweeps", "dask", "distributed"],
}


@pytest.mark.parametrize("package", sorted(RULES))
def test_package_imports_with_others_blocked(package):
    code = BLOCKER.format(blocked=RULES[package], package=package)
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr[-2000:]


# --- no import circle inside a package ----------------------------------------------------
# Counted: imports at module level (those run when a module is imported). An import inside
# a function is the sanctioned way to defer a heavy or optional dependency, and runs only
# when called; it is not an edge here.

import ast
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent


def _module_name(path: Path) -> str:
    parts = path.relative_to(ROOT).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def _imports(path: Path, package: str) -> set[str]:
    """Modules of ``package`` that ``path`` imports at module level."""
    me = _module_name(path)
    base = me if path.name == "__init__.py" else me.rpartition(".")[0]
    out = set()
    for node in ast.parse(path.read_text()).body:
        if isinstance(node, ast.Import):
            out |= {a.name for a in node.names}
        elif isinstance(node, ast.ImportFrom):
            mod = node.module or ""
            if node.level:
                anchor = base.split(".")[:len(base.split(".")) - node.level + 1]
                mod = ".".join(anchor + ([mod] if mod else []))
            out |= {mod} | {f"{mod}.{a.name}" for a in node.names}
    return {m for m in out if m == package or m.startswith(package + ".")}


def _cycle(graph: dict[str, set[str]]) -> list[str] | None:
    state, stack = {}, []

    def visit(node):
        state[node] = 1
        stack.append(node)
        for nxt in sorted(graph.get(node, ())):
            if state.get(nxt) == 1:
                return stack[stack.index(nxt):] + [nxt]
            if nxt not in state and (found := visit(nxt)):
                return found
        state[node] = 2
        stack.pop()
        return None

    for node in sorted(graph):
        if node not in state and (found := visit(node)):
            return found
    return None


@pytest.mark.parametrize("package", ["engine", "store", "sweeps"])
def test_no_import_circle_inside_a_package(package):
    files = sorted((ROOT / package).rglob("*.py"))
    modules = {_module_name(f) for f in files}
    graph = {}
    for f in files:
        me = _module_name(f)
        # importing a package's __init__ from inside it is not a circle of modules
        graph[me] = {m for m in _imports(f, package) if m in modules and m != me
                     and not (me.startswith(m + ".") and (ROOT / Path(*m.split("."))
                                                          / "__init__.py").exists())}
    assert _cycle(graph) is None, " -> ".join(_cycle(graph))


def test_the_circle_finder_finds_circles():
    assert _cycle({"a": {"b"}, "b": {"c"}, "c": {"a"}}) == ["a", "b", "c", "a"]
    assert _cycle({"a": {"b"}, "b": set()}) is None


# --- small modules (STYLE.md 'Small': modules under ~300 lines) ---------------------------

MAX_MODULE_LINES = 300
# over the limit, and being edited on another branch: split there, then drop it from here
EDITED_ELSEWHERE: set[str] = set()


def test_no_module_is_over_300_lines():
    allowed = EDITED_ELSEWHERE
    long = {}
    for package in ("engine", "store", "sweeps"):
        for f in sorted((ROOT / package).rglob("*.py")):
            n = len(f.read_text().splitlines())
            if n > MAX_MODULE_LINES:
                long[f.relative_to(ROOT).as_posix()] = n
    unexpected = {name: n for name, n in long.items() if name not in allowed}
    assert not unexpected, (f"modules over {MAX_MODULE_LINES} lines (split them along a "
                            f"seam, STYLE.md 'Small'): {unexpected}")
    fixed = sorted(allowed - set(long))
    assert not fixed, f"now at most {MAX_MODULE_LINES} lines: drop {fixed} from the allow-list"


# --- the rooms of sweeps/ run one way ------------------------------------------------------
# sweeps/ is a chain of units (a sub-package, or a module at its root), lowest first. The
# rule: a module may import (at module level AND inside a function: a deferred import is
# still a dependency) only modules of its own unit or of units earlier in SWEEPS_CHAIN.
# ``sweeps/__init__.py`` is the public face above the chain: it re-exports (lazily) from
# any unit, and nothing in the chain imports it. docs/ARCHITECTURE.md draws the chain.

SWEEPS_CHAIN = (
    "errors",      # exceptions and exit codes
    "version",     # __version__, results_fingerprint (reads files, imports no sweeps module)
    "spec",        # models, messages, grid, methods, accuracy levels, checks, load_spec
    "planning",    # Plan, make_plan, blocks, refinement lattice
    "workers",     # the dask worker's task, the cluster
    "estimates",   # the error estimate (and running it), the wall-time estimate
    "run",         # submit: lease, sink, journal, dispatch, refined levels, outcome
    "service",     # the queue: enqueue, serve, cancel
    "lookup",      # a sweep by id / prefix / name, stale notes
    "overview",    # the sweeps of a store as plain data (status --format json, the web view)
    "api",         # run_sweep, open_sweep
    "gallery",     # the paper's figures as scenes
    "exports",     # query's text and map's drawing, for the command line and the web view
    "web",         # the read-only web view (ditherlab web, serve --web)
    "cli",         # the ditherlab command line
)


def _unit(module: str) -> str | None:
    """The chain unit of a ``sweeps`` module (None for the package itself)."""
    parts = module.split(".")
    return parts[1] if len(parts) > 1 else None


def _all_imports(path: Path, package: str) -> set[tuple[int, str]]:
    """(line, module) of every import of ``package`` anywhere in ``path``, functions too
    (``from package import name``: the module ``package.name``)."""
    me = _module_name(path)
    base = me if path.name == "__init__.py" else me.rpartition(".")[0]
    out = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Import):
            out |= {(node.lineno, a.name) for a in node.names}
        elif isinstance(node, ast.ImportFrom):
            mod = node.module or ""
            if node.level:
                anchor = base.split(".")[:len(base.split(".")) - node.level + 1]
                mod = ".".join(anchor + ([mod] if mod else []))
            out |= {(node.lineno, f"{mod}.{a.name}") for a in node.names} if mod == package \
                else {(node.lineno, mod)}
    return {(n, m) for n, m in out if m == package or m.startswith(package + ".")}


def _backward_imports(files) -> list[str]:
    rank = {unit: i for i, unit in enumerate(SWEEPS_CHAIN)}
    found = []
    for f in files:
        me = _module_name(f)
        if me == "sweeps":
            continue
        mine = rank[_unit(me)]
        for line, target in sorted(_all_imports(f, "sweeps")):
            unit = _unit(target)
            if unit not in rank:   # `import sweeps`, or a name of its face
                found.append(f"{me}:{line} imports {target} (the package's face)")
            elif rank[unit] > mine:
                found.append(f"{me}:{line} imports {target} ({unit} is above {_unit(me)})")
    return found


def test_sweeps_units_are_all_in_the_chain():
    units = {_unit(_module_name(f)) for f in (ROOT / "sweeps").rglob("*.py")} - {None}
    assert units == set(SWEEPS_CHAIN), (f"add to or drop from SWEEPS_CHAIN: "
                                        f"{sorted(units ^ set(SWEEPS_CHAIN))}")


def test_sweeps_units_import_only_down_the_chain():
    found = _backward_imports(sorted((ROOT / "sweeps").rglob("*.py")))
    assert not found, "imports up the chain (SWEEPS_CHAIN):\n" + "\n".join(found)


def test_the_chain_check_sees_deferred_and_relative_imports(tmp_path, monkeypatch):
    pkg = tmp_path / "sweeps" / "spec"
    pkg.mkdir(parents=True)
    (pkg / "load.py").write_text("def f():\n    from ..run.submit import submit\n")
    monkeypatch.setattr(sys.modules[__name__], "ROOT", tmp_path)
    (pkg / "grid.py").write_text("from .models import Spec\nfrom .. import errors\n")
    (pkg / "checks.py").write_text("import sweeps\n")
    assert _backward_imports([pkg / "load.py", pkg / "grid.py", pkg / "checks.py"]) == [
        "sweeps.spec.load:2 imports sweeps.run.submit (run is above spec)",
        "sweeps.spec.checks:1 imports sweeps (the package's face)"]
