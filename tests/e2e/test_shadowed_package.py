"""A folder named ``store`` beside a user's script (a natural name for a sweep store) used
to hide ditherlab's ``store`` package under the README's editable install (setuptools'
finder comes after the script's folder on the path), and the run died in an
AttributeError deep inside (found running ``python -m sweeps.cli submit ... --store
store`` twice in one folder). Now ``import sweeps`` says what hides what, in one line;
where the real package comes first on the path (a plain ``pip install .``) it just works.

Both cases are made, not found: the plain one by putting the checkout first on the path,
the editable one from the install this suite runs under (``scripts/test``: ``pip install
-e``), which its metadata states (PEP 610 ``direct_url.json``)."""
import json
import os
import subprocess
import sys
import sysconfig
from importlib import metadata
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
SCRIPT = "import sweeps, store\nprint('found', store.SweepDir.__name__)\n"


def _editable_install() -> bool:
    """Whether the environment's site-packages holds ditherlab as an editable install (not
    the checkout's own ``ditherlab.egg-info``, which the current folder would find)."""
    site = sysconfig.get_paths()["purelib"]
    for dist in metadata.distributions(name="ditherlab", path=[site]):
        text = dist.read_text("direct_url.json")
        return bool(text and json.loads(text).get("dir_info", {}).get("editable"))
    return False


def _run_beside_a_store_folder(tmp_path, pythonpath: str | None):
    (tmp_path / "store").mkdir()
    script = tmp_path / "user_script.py"
    script.write_text(SCRIPT)
    env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
    if pythonpath is not None:
        env["PYTHONPATH"] = pythonpath
    return subprocess.run([sys.executable, str(script)], cwd=tmp_path, capture_output=True,
                          text=True, timeout=120, env=env)


def test_a_store_folder_beside_the_script_is_named_under_an_editable_install(tmp_path):
    if not _editable_install():   # the suite's own install (scripts/test) is editable
        pytest.fail("ditherlab is not installed editable here; run the suite with "
                    "scripts/test (pip install -e)")
    out = _run_beside_a_store_folder(tmp_path, pythonpath=None)
    assert out.returncode == 1, (out.stdout, out.stderr[-2000:])
    last = out.stderr.strip().splitlines()[-1]
    assert last == (f"ImportError: {_LINE.format(where=tmp_path / 'store')}"), \
        out.stderr[-2000:]


_LINE = ("the folder {where} hides ditherlab's 'store' package (Python finds it first: the "
         "script's folder, the current one under -m, or $PYTHONPATH): rename that folder or "
         "run from another folder")


def test_the_command_says_it_in_one_line_with_a_store_folder_on_pythonpath(tmp_path):
    """A store named ``store`` in a folder on $PYTHONPATH (found when a test put a user's
    law module beside its store): the ``ditherlab`` command printed the ImportError's
    traceback; now one line, exit 2."""
    (tmp_path / "store").mkdir()
    bin_ = Path(sys.executable).parent / "ditherlab"
    out = subprocess.run([str(bin_), "status"], cwd=tmp_path, capture_output=True, text=True,
                         timeout=120, env={**os.environ, "PYTHONPATH": str(tmp_path)})
    assert out.returncode == 2, (out.stdout, out.stderr[-2000:])
    assert out.stderr == f"ditherlab: {_LINE.format(where=tmp_path / 'store')}\n"


def test_a_store_folder_beside_the_script_is_harmless_when_the_package_comes_first(tmp_path):
    out = _run_beside_a_store_folder(tmp_path, pythonpath=str(ROOT))
    assert (out.returncode, out.stdout) == (0, "found SweepDir\n"), out.stderr[-2000:]
