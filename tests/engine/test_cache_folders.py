"""The kernel cache keeps a folder per engine fingerprint and removes the ones unused for
``$DITHERLAB_CACHE_KEEP_DAYS`` (engine.cache_folders): the cache root no longer grows by a
folder with every engine edit."""
import os
import subprocess
import sys
from pathlib import Path

import pytest

from engine import cache_folders as cf
from engine.provenance import fingerprint

ROOT = Path(__file__).resolve().parents[2]
NOW = 1_800_000_000.0
DAY = cf.DAY_S


def folder(root: Path, name: str, used_days_ago: float | None, stamped=True) -> Path:
    """A cache folder with one kernel file, last used ``used_days_ago`` before NOW."""
    path = root / name
    (path / "kernels").mkdir(parents=True)
    (path / "kernels" / "k.nbc").write_bytes(b"machine code")
    if used_days_ago is not None:
        when = NOW - used_days_ago * DAY
        if stamped:
            (path / cf.STAMP).touch()
            os.utime(path / cf.STAMP, (when, when))
        os.utime(path, (when, when))
    return path


def test_folders_unused_for_a_month_go_the_rest_stay(tmp_path, monkeypatch):
    monkeypatch.delenv("DITHERLAB_CACHE_KEEP_DAYS", raising=False)
    current = folder(tmp_path, "numba-cccccccccccc", None)
    old = folder(tmp_path, "numba-aaaaaaaaaaaa", 31)
    recent = folder(tmp_path, "numba-bbbbbbbbbbbb", 29)
    unstamped_old = folder(tmp_path, "numba-dddddddddddd", 45, stamped=False)
    other = folder(tmp_path, "not-a-kernel-folder", 400)
    theirs = folder(tmp_path, "numba-notes", 400)   # a user's folder in a root they chose
    removed = cf.use(current, now=NOW)
    assert removed == [old, unstamped_old]
    assert not old.exists() and not unstamped_old.exists()
    assert recent.exists() and other.exists() and theirs.exists() and current.exists()
    assert (current / cf.STAMP).stat().st_mtime == NOW


def test_the_stamp_is_written_once_a_day_and_only_then_does_it_prune(tmp_path):
    current = folder(tmp_path, "numba-cccccccccccc", 0.5)
    old = folder(tmp_path, "numba-aaaaaaaaaaaa", 90)
    assert cf.use(current, now=NOW) == []   # stamped 12 hours ago: nothing to do
    assert old.exists() and (current / cf.STAMP).stat().st_mtime == NOW - 0.5 * DAY
    assert cf.use(current, now=NOW + DAY) == [old]


@pytest.mark.parametrize("value, kept", [("0", True), ("-1", True), ("100", True),
                                         ("7", False), ("seven", False)])
def test_keep_days_is_read_from_the_environment(tmp_path, monkeypatch, value, kept):
    monkeypatch.setenv("DITHERLAB_CACHE_KEEP_DAYS", value)   # "seven": the default, 30
    current = folder(tmp_path, "numba-cccccccccccc", None)
    old = folder(tmp_path, "numba-aaaaaaaaaaaa", 60)
    cf.use(current, now=NOW)
    assert old.exists() == kept


def test_a_folder_that_cannot_be_stamped_changes_nothing(tmp_path):
    old = folder(tmp_path, "numba-aaaaaaaaaaaa", 60)
    (tmp_path / "blocker").write_text("a file where the cache folder should be")
    assert cf.use(tmp_path / "blocker" / "numba-cccccccccccc", now=NOW) == []
    assert old.exists()


@pytest.mark.subprocess
def test_importing_the_engine_prunes_its_cache_root(tmp_path):
    old = folder(tmp_path, "numba-aaaaaaaaaaaa", 60)
    os.utime(old / cf.STAMP, (0, 0))
    os.utime(old, (0, 0))   # used in 1970
    recent = tmp_path / "numba-bbbbbbbbbbbb"
    recent.mkdir()
    env = {**os.environ, "DITHERLAB_CACHE_DIR": str(tmp_path)}
    env.pop("DITHERLAB_CACHE_KEEP_DAYS", None)
    subprocess.run([sys.executable, "-c", "import engine.jit"], cwd=ROOT, env=env, check=True,
                   timeout=120)
    assert not old.exists() and recent.exists()
    assert (tmp_path / f"numba-{fingerprint()}" / cf.STAMP).exists()
