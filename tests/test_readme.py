"""The documentation runs as written and hangs together (README.md and docs/*.md).

- A code block marked ``<!-- runnable -->`` on the line before its fence runs: ``bash`` and
  ``python`` in a fresh folder that links the checkout's ``specs/`` (and ``.venv/``), with the
  store in it through $DITHERLAB_STORE; ``toml`` is loaded as a sweep spec. Blocks marked
  ``<!-- runnable slow -->`` run with ``-m slow``.
- Every relative link resolves to a file, and a ``#fragment`` to a heading of it; every page
  under docs/ is reachable from the README. Pages that other branches are writing
  (:data:`COMING`) may be linked before they exist.
- Every source file a page names (``tests/...py::test_x``, ``scripts/x.py``, ``sweeps/...py``)
  exists, and so does every test named after it.
"""
from __future__ import annotations

import os
import re
import subprocess
import sys
import tomllib
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
PAGES = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]
COMING = {"docs/BATCH.md"}   # written on other branches; linked already

FENCE = re.compile(r"^( *)<!-- runnable( slow)? -->\n\1```(bash|python|toml)\n(.*?)^\1```",
                   re.DOTALL | re.MULTILINE)
LINK = re.compile(r"\]\(([^)\s]+)\)")
SOURCE = re.compile(r"(?<![\w/.])((?:tests|scripts|engine|sweeps|store)/[\w/]+\.py)|::(\w+)")


def runnable_blocks() -> list:
    params = []
    for page in PAGES:
        for k, m in enumerate(FENCE.finditer(page.read_text())):
            indent, slow, lang, body = m.groups()
            code = "".join(line[len(indent):] for line in body.splitlines(keepends=True))
            # every block runs ditherlab (seconds each): long, or a slow study
            marks = [pytest.mark.slow] if slow else [pytest.mark.long]
            params.append(pytest.param(lang, code, id=f"{page.relative_to(ROOT)}-{k}-{lang}",
                                       marks=marks))
    return params


def rel(page: Path) -> str:
    return page.relative_to(ROOT).as_posix()


@pytest.mark.parametrize("lang, code", runnable_blocks())
def test_runnable_block(lang, code, tmp_path):
    if lang == "toml":
        import sweeps

        sweeps.load_spec(tomllib.loads(code))   # raises on a key or value the spec refuses
        return
    work = tmp_path / "work"
    work.mkdir()
    for name in ("specs", ".venv"):
        if (ROOT / name).exists():
            (work / name).symlink_to(ROOT / name)
    store = tmp_path / "store"
    env = {**os.environ, "DITHERLAB_STORE": str(store), "MPLBACKEND": "Agg",
           "PATH": f"{Path(sys.executable).parent}{os.pathsep}{os.environ['PATH']}"}
    cmd = ["bash", "-euo", "pipefail", "-c", code] if lang == "bash" \
        else [sys.executable, "-c", code]
    out = subprocess.run(cmd, cwd=work, env=env, capture_output=True, text=True, timeout=900)
    assert out.returncode == 0, f"{out.stdout[-2000:]}\n{out.stderr[-3000:]}"
    # the store is the one $DITHERLAB_STORE names, never ./ditherlab-store of the folder
    assert not (work / "ditherlab-store").exists()
    if re.search(r"run_sweep\(|ditherlab submit specs/", code):
        assert (store / "catalogue.sqlite").exists()


def test_readme_runs_its_python_block_and_tour():
    """The README's own examples are among the runnable blocks (the markers are not lost)."""
    blocks = [m.group(3, 4) for m in FENCE.finditer((ROOT / "README.md").read_text())]
    assert any(lang == "python" and "sweeps.run_sweep" in code and "sweeps.open_sweep" in code
               for lang, code in blocks)
    assert any(lang == "bash" and "ditherlab submit" in code for lang, code in blocks)


def anchors(page: Path) -> set[str]:
    """GitHub's heading ids: lower case, punctuation dropped, spaces to hyphens."""
    text = re.sub(r"^```.*?^```", "", page.read_text(), flags=re.DOTALL | re.MULTILINE)
    heads = re.findall(r"^#+ (.+)$", text, re.MULTILINE)
    return {re.sub(r"[^\w\- ]", "", h.strip().lower()).replace(" ", "-") for h in heads}


def links(page: Path) -> list[tuple[str, str]]:
    """(target path relative to ROOT, fragment) of every relative link of ``page``."""
    out = []
    for target in LINK.findall(page.read_text()):
        if re.match(r"[a-z]+:", target):
            continue                     # https:, mailto:
        path, _, frag = target.partition("#")
        dest = (page.parent / path).resolve() if path else page
        out.append((dest.relative_to(ROOT).as_posix(), frag))
    return out


def test_relative_links_resolve():
    bad = []
    for page in PAGES:
        for dest, frag in links(page):
            if dest in COMING and not (ROOT / dest).exists():
                continue
            if not (ROOT / dest).exists():
                bad.append(f"{rel(page)}: {dest} does not exist")
            elif frag and dest.endswith(".md") and frag not in anchors(ROOT / dest):
                bad.append(f"{rel(page)}: {dest} has no heading #{frag}")
    assert not bad, "\n".join(bad)


def test_every_docs_page_is_reachable_from_the_readme():
    seen, todo = set(), ["README.md"]
    while todo:
        page = todo.pop()
        if page in seen or not (ROOT / page).exists():
            continue
        seen.add(page)
        todo += [dest for dest, _ in links(ROOT / page) if dest.endswith(".md")]
    assert {rel(p) for p in PAGES} <= seen, sorted({rel(p) for p in PAGES} - seen)
    assert COMING <= {dest for dest, _ in links(ROOT / "README.md")}


def test_named_files_and_tests_exist():
    """``tests/a.py::test_x`` and a following bare ``::test_y`` (same file) are defined; a
    module named by its path (``engine/jit.py``) is where the page says."""
    bad = []
    for page in PAGES:
        current = None
        for m in re.finditer(SOURCE, page.read_text()):
            if m.group(1):
                current = m.group(1)
                if not (ROOT / current).exists():
                    bad.append(f"{rel(page)}: {current} does not exist")
            elif current and (ROOT / current).exists() and not re.search(
                    rf"^\s*def {m.group(2)}\(", (ROOT / current).read_text(), re.MULTILINE):
                bad.append(f"{rel(page)}: {current} has no {m.group(2)}")
    assert not bad, "\n".join(bad)
