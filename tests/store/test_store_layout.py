"""Store folder layout (README 'Store layout', DESIGN.md §5 default store)."""

from pathlib import Path

import pytest

import store
from store import layout


def test_sweep_dir_paths_and_spec(tmp_path):
    sweep = store.SweepDir(tmp_path, "b305ba3e9216")
    assert sweep.root == tmp_path / "b305ba3e9216"
    assert (sweep.cube.name, sweep.journal.name, sweep.spec.name) == (
        "cube.nc",
        "journal",
        "spec.json",
    )
    sweep.write_spec('{"name":"demo"}')
    assert sweep.spec.read_text() == '{"name":"demo"}'
    assert sorted(p.name for p in sweep.root.iterdir()) == ["spec.json"]  # no temporary left
    assert sweep == store.SweepDir(str(tmp_path), "b305ba3e9216")


@pytest.mark.parametrize("bad", ["", "../x", "a/b", ".hidden"])
def test_sweep_dir_refuses_non_folder_names(tmp_path, bad):
    with pytest.raises(ValueError, match="sweep_id must be a plain folder name"):
        store.SweepDir(tmp_path, bad)


def test_the_default_store_is_read_where_every_command_reads_it(monkeypatch, tmp_path):
    from sweeps.lookup import store_root   # the one helper over store.layout's names

    monkeypatch.delenv(layout.ENV_STORE, raising=False)
    assert str(store_root()) == layout.DEFAULT_STORE == "ditherlab-store"
    monkeypatch.setenv(layout.ENV_STORE, str(tmp_path))
    assert store_root() == tmp_path and store_root("elsewhere") == Path("elsewhere")


def test_atomic_write_failure_leaves_nothing(tmp_path):
    def fail(tmp):
        tmp.write_text("partial")
        raise RuntimeError("boom")

    with pytest.raises(RuntimeError, match="boom"):
        store.atomic_write(tmp_path / "f.txt", fail)
    assert list(tmp_path.iterdir()) == []


def test_older_stores_with_cube_h5_still_open(tmp_path):
    """Stores written before 0.2 named the cube ``cube.h5``: it stays the sweep's cube (and is
    adopted by the catalogue) until a ``cube.nc`` exists beside it."""
    sweep = store.SweepDir(tmp_path, "0123456789ab")
    sweep.root.mkdir()
    (sweep.root / "cube.h5").write_bytes(b"")
    assert sweep.cube.name == "cube.h5"
    (sweep.root / "cube.nc").write_bytes(b"")
    assert sweep.cube.name == "cube.nc"
