"""The README's "From Python" block runs as written (from the checkout's root, with the
store in a temporary folder through $DITHERLAB_STORE)."""
import os
import re
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent


def test_readme_python_example_runs(tmp_path):
    text = (ROOT / "README.md").read_text()
    block = re.search(r"### From Python\n.*?```python\n(.*?)```", text, re.DOTALL).group(1)
    env = {**os.environ, "DITHERLAB_STORE": str(tmp_path / "store"), "MPLBACKEND": "Agg"}
    out = subprocess.run([sys.executable, "-c", block], cwd=ROOT, env=env, capture_output=True,
                         text=True, timeout=900)
    assert out.returncode == 0, out.stderr[-3000:]
    assert (tmp_path / "store" / "catalogue.sqlite").exists()
    assert not (ROOT / "ditherlab-store").exists() or "ditherlab-store" in os.listdir(ROOT)
