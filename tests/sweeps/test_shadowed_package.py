"""A folder named ``store`` beside a user's script (a natural name for a sweep store) used
to hide ditherlab's ``store`` package under the README's editable install (setuptools'
finder comes after the script's folder on the path), and the run died in an
AttributeError deep inside (found running ``python -m sweeps.cli submit ... --store
store`` twice in one folder). Now ``import sweeps`` says what hides what, in one line;
where the real package comes first on the path (a plain ``pip install .``) it just works."""
import subprocess
import sys


def test_a_store_folder_beside_the_script_is_named_or_harmless(tmp_path):
    (tmp_path / "store").mkdir()
    script = tmp_path / "user_script.py"
    script.write_text("import sweeps, store\nprint('found', store.SweepDir.__name__)\n")
    out = subprocess.run([sys.executable, str(script)], cwd=tmp_path, capture_output=True,
                         text=True, timeout=120)
    if out.returncode == 0:
        assert "found SweepDir" in out.stdout
    else:
        last = out.stderr.strip().splitlines()[-1]
        assert last.startswith("ImportError: the folder") and "hides ditherlab's 'store'" \
            in last, out.stderr[-2000:]
