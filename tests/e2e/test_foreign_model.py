"""A worker with another copy of a model the sweep brings by import path gets no block
(issue 35; sweeps.workers.matching, the source digest in each worker's identity).

The submitter imports ``mylab.laws`` (docs/examples) from its folder; a ``dask worker``
imports an edited copy (one comment added) from another folder. Alone, it computes nothing and
the submit says which module differs, in one line (exit 1); beside a worker with the same
copy, it computes nothing, a warning names it, and the sweep completes.
"""
from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from .test_foreign_worker import scheduler  # noqa: F401  (the fixture)

pytestmark = [pytest.mark.long, pytest.mark.cluster, pytest.mark.subprocess]

ROOT = Path(__file__).resolve().parents[2]
SPEC = {"name": "foreign-model", "friction": "mylab.laws:MaxwellSlip", "dither": "none",
        "outputs": ["v_mean"], "accuracy": "draft", "block_size": 1,
        "time": {"t_end": 2.0, "t_transient": 1.0},
        "params": {"gms": {"k": [100.0], "alpha": [1.0], "C": 20.0}},
        "grid": {"v_ref": [0.1, 0.2, 0.3, 0.4]}}


def _copies(tmp_path):
    mine, theirs = tmp_path / "mine", tmp_path / "theirs"
    for dest in (mine, theirs):
        shutil.copytree(ROOT / "docs" / "examples" / "mylab", dest / "mylab",
                        ignore=shutil.ignore_patterns("__pycache__"))
    laws = theirs / "mylab" / "laws.py"
    laws.write_text(laws.read_text() + "\n# their edit\n")
    return mine, theirs


def _submit(cwd, address, store_dir):
    spec = cwd / "spec.json"
    spec.write_text(json.dumps(SPEC))
    return subprocess.run([str(Path(sys.executable).parent / "ditherlab"), "submit", str(spec),
                           "--store", str(store_dir), "--scheduler", address, "-q"],
                          cwd=cwd, capture_output=True, text=True, timeout=900)


def test_alone_a_worker_with_another_copy_of_the_model_computes_nothing(scheduler,  # noqa: F811
                                                                         tmp_path):
    address, start, _ = scheduler
    mine, theirs = _copies(tmp_path)
    log = tmp_path / "blocks.log"
    start({**os.environ, "PYTHONPATH": str(theirs), "DITHERLAB_BLOCK_LOG": str(log)}, 0)
    out = _submit(mine, address, tmp_path / "store")
    assert out.returncode == 1, out.stderr
    last = out.stderr.strip().splitlines()[-1]
    assert "has another copy of mylab.laws:MaxwellSlip" in last, out.stderr
    assert "nothing was computed" in last and "Traceback" not in out.stderr
    assert not log.exists(), "the worker with the other copy computed a block"


def test_beside_a_matching_worker_it_gets_no_block(scheduler, tmp_path):  # noqa: F811
    address, start, _ = scheduler
    mine, theirs = _copies(tmp_path)
    log = tmp_path / "blocks.log"
    start({**os.environ, "PYTHONPATH": str(theirs), "DITHERLAB_BLOCK_LOG": str(log)}, 0)
    start({**os.environ, "PYTHONPATH": str(mine)}, 1)
    out = _submit(mine, address, tmp_path / "store")
    assert out.returncode == 0, out.stderr
    named = [ln for ln in out.stderr.splitlines() if "another copy of mylab.laws" in ln]
    assert len(named) == 1 and "gets no block" in named[0], out.stderr
    assert not log.exists(), "the worker with the other copy computed a block"
