"""A script that calls run_sweep at its top level, without ``if __name__ == "__main__":``,
is imported again by every dask worker it starts (multiprocessing 'spawn'). It used to hang
for ever (each worker attached to the sweep, waiting on the submitter's lease); now the
workers refuse in one line and the submitter's cluster start fails at once."""
import os
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

pytestmark = [pytest.mark.cluster, pytest.mark.subprocess]   # what it starts (tests/conftest.py)

ROOT = Path(__file__).resolve().parents[2]
# dithered: priced at a few seconds of work (sweeps.planning.plan.work_s), so it starts a
# local cluster (a sweep priced below a cluster's start runs on threads of the script's own
# process, and an unguarded script then just works); it computes in well under a second
SPEC = ('{"name": "guard", "friction": "lugre", "dither": "square-velocity", '
        '"outputs": ["F_mean"], "accuracy": "draft", '
        '"time": {"t_end": 200.0, "t_transient": 100.0}, '
        '"grid": {"W": [0.2], "omega": [1000.0], "v_ref": [0.2, 0.4]}}')


def _run(tmp_path, body: str) -> subprocess.CompletedProcess:
    script = tmp_path / "user_script.py"
    script.write_text(textwrap.dedent(f"""\
        import json
        import sweeps
        spec = json.loads('{SPEC}')
        """) + textwrap.dedent(body))
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    return subprocess.run([sys.executable, str(script)], cwd=tmp_path, env=env,
                          capture_output=True, text=True, timeout=300)


def test_unguarded_script_is_refused_in_one_line(tmp_path):
    out = _run(tmp_path, """\
        res = sweeps.run_sweep(spec, "store", progress=False)
        print("STATE", res.state)
        """)
    assert out.returncode != 0 and "STATE" not in out.stdout
    assert "calls run_sweep at its top level: put the call under" in out.stderr
    assert out.stderr.strip().splitlines()[-1].startswith("sweeps.workers.cluster.ClusterStartError")


@pytest.mark.long
def test_guarded_script_runs(tmp_path):
    out = _run(tmp_path, """\
        if __name__ == "__main__":
            res = sweeps.run_sweep(spec, "store", progress=False)
            print("STATE", res.state)
        """)
    assert out.returncode == 0, out.stderr[-2000:]
    assert "STATE done" in out.stdout
