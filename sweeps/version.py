"""The package version, and the results fingerprint: which code made a cube's numbers.

Policy (README "Which engine made this cube", docs/ARCHITECTURE.md): a cube's numbers are
made by the code that turns a spec into a plan, computes its blocks and writes them into the
cube. That code is found, not listed: :func:`computing_path` follows every import
(module-level and deferred, ``from . import x``, and the submodules a lazy package
``__init__`` attaches with ``lazy_loader``) from the entry modules :data:`ENTRY_MODULES`
through ditherlab's own packages, and :func:`results_fingerprint` hashes the sources of
every module it reaches, together with the whole engine (``engine.provenance``, which also
names numba's cache). An edit of any module on that path -- even a comment -- makes new
sweep ids, and old cubes are stale; a module off it (the command line, the read side, the
gallery) can change freely. Over-inclusion costs a recomputation, a miss a wrong answer
served as current: ``tests/sweeps/test_fingerprint.py`` runs sweeps and fails if they load
a module of ours that the path does not hold, and holds the reviewed list of the path's
modules (``COMPUTING_PATH``: a module joining or leaving it shows in a diff).

Code that cannot change a number stays off the path by structure, not by a list here: the
runner is handed its progress display (sweeps.run.quiet; the bars are sweeps.run.phases),
its callers record the time history (sweeps.estimates.time_history.record_run), and the
tests' gates are found by name in tests/hooks (sweeps.workers.task.HOOKS_MODULE). None of
them is imported by a module on the path, and nothing they return is computed with.

Only the standard library here: ``ditherlab --help`` must not pay for numerics.
"""
from __future__ import annotations

import ast
import functools
import hashlib
import re
from importlib.metadata import PackageNotFoundError, version
from pathlib import Path

try:
    __version__ = version("ditherlab")
except PackageNotFoundError:  # running from a source tree that was never installed
    __version__ = "0.0.0+unknown"

# where computing starts: planning a spec, a worker's block, the runner that journals
# blocks and publishes the cube, and the refinement that chooses a refined map's points
ENTRY_MODULES = ("sweeps.planning.plan", "sweeps.workers.task", "sweeps.run.submit",
                 "sweeps.run.refined")
PACKAGES = ("engine", "sweeps", "store")        # ours: the only imports followed
ROOT = Path(__file__).resolve().parent.parent   # the folder holding the three packages


def results_fingerprint() -> str:
    """12 hex digits naming everything that makes a cube's numbers (module docstring). It
    is in every sweep id, cube (``engine_fingerprint``) and catalogue row; a cube made under
    another fingerprint is stale. The path's sources are read once per process."""
    from engine import provenance

    return _combine(provenance.fingerprint(), _installed_path_digest())


def fingerprint_of(root: Path, engine_hash: str) -> str:
    """The results fingerprint of the source tree under ``root`` whose engine hashes to
    ``engine_hash``, read now (the tests edit copies of the tree)."""
    return _combine(engine_hash, _path_digest(root))


def _combine(engine_hash: str, path_digest: str) -> str:
    return hashlib.sha256((engine_hash + path_digest).encode()).hexdigest()[:12]


@functools.cache
def _installed_path_digest() -> str:
    return _path_digest(ROOT)


def _path_digest(root: Path) -> str:
    digest = hashlib.sha256()
    for name, path in sorted(computing_path(root).items()):
        if name.split(".")[0] != "engine":        # all of engine/ is in the engine's hash
            digest.update(name.encode() + b"\0" + path.read_bytes())
    return digest.hexdigest()


def computing_path(root: Path = ROOT) -> dict[str, Path]:
    """Module name -> source file of every module of ours that the entry modules import,
    directly or not, at module level or inside a function (the import closure)."""
    found: dict[str, Path] = {}
    todo = list(ENTRY_MODULES)
    while todo:
        name = todo.pop()
        if name in found or (path := _source(root, name)) is None:
            continue
        found[name] = path
        parents = [name.rsplit(".", i)[0] for i in range(1, name.count(".") + 1)]
        todo += parents + sorted(_imports(root, name, path))   # importing a.b runs a/__init__
    return found


@functools.cache
def _source(root: Path, name: str) -> Path | None:
    base = root.joinpath(*name.split("."))
    for path in (base.with_suffix(".py"), base / "__init__.py"):
        if path.is_file():
            return path
    return None   # not a module (an attribute, a third-party name)


# Import statements are read with regular expressions, not ast (parsing ~90 modules costs a
# second; every `ditherlab status` needs the fingerprint), after dropping triple-quoted
# strings and comments (docstrings show `import store` examples). What is left over can
# only add a module, never lose one; the tests cross-check the path against the modules
# real runs load.
_PROSE = re.compile(r'""".*?"""|\'\'\'.*?\'\'\'|#[^\n]*', re.S)
_FROM = re.compile(r"^[ \t]*from[ \t]+(\.*)([\w.]*)[ \t]+import[ \t]+(\([^)]*\)|[^\n#;]*)", re.M)
_IMPORT = re.compile(r"^[ \t]*import[ \t]+([^\n#;]*)", re.M)
_NAME = re.compile(r"[A-Za-z_][\w.]*")


def _imports(root: Path, name: str, path: Path) -> set[str]:
    """The modules of :data:`PACKAGES` that the source of module ``name`` may import:
    ``import x.y``; ``from x import y`` (y a submodule, or an attribute a lazy package
    ``x`` loads a submodule for); ``import x`` followed by ``x.attr`` (the same)."""
    text = _PROSE.sub("", path.read_text())
    package = name if path.name == "__init__.py" else name.rpartition(".")[0]
    out: set[str] = set()
    for dots, mod, names in _FROM.findall(text):
        if dots:
            anchor = package.split(".")[: package.count(".") + 2 - len(dots)]
            mod = ".".join(anchor + ([mod] if mod else []))
        if mod.split(".")[0] in PACKAGES:
            out |= {mod} | {_resolve(root, mod, n) for n in _NAME.findall(names)
                            if n != "as"}
    for clause in _IMPORT.findall(text):
        for part in clause.split(","):
            mod, _, alias = part.strip().partition(" as ")
            if mod.split(".")[0] not in PACKAGES:
                continue
            out.add(mod)
            local = alias.strip() or mod          # `import store` then `store.publish(...)`
            attrs = re.findall(rf"\b{re.escape(local)}\.(\w+)", text)
            out |= {_resolve(root, mod, a) for a in attrs}
    return out


def _resolve(root: Path, package: str, attr: str) -> str:
    """The module that ``package.attr`` lives in: a submodule, or the one a lazy
    ``__init__`` attaches ``attr`` from, or the package itself."""
    return _lazy_table(root, package).get(attr, f"{package}.{attr}")


@functools.cache
def _lazy_table(root: Path, package: str) -> dict[str, str]:
    """attr -> module for a package whose ``__init__`` calls ``lazy_loader.attach(__name__,
    submodules=[...], submod_attrs={...})`` (read with ast: these files are small)."""
    init = root.joinpath(*package.split("."), "__init__.py")
    if not init.is_file() or "attach(" not in (text := init.read_text()):
        return {}
    table: dict[str, str] = {}
    for node in ast.walk(ast.parse(text)):
        if isinstance(node, ast.Call) and getattr(node.func, "attr", "") == "attach":
            for kw in node.keywords:
                value = ast.literal_eval(kw.value)
                if kw.arg == "submodules":
                    table |= {sub: f"{package}.{sub}" for sub in value}
                elif kw.arg == "submod_attrs":
                    table |= {a: f"{package}.{sub}" for sub, attrs in value.items()
                              for a in attrs}
    return table
