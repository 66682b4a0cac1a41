"""A closed standard output (``ditherlab scenes | head -1``) ends the command quietly; any
other broken pipe is a fault like the rest: one line on stderr, never silence."""
import importlib
import subprocess
import sys

import pytest

from ..helpers import BIN

pytestmark = pytest.mark.subprocess   # what it starts (tests/conftest.py)


@pytest.mark.long
def test_a_reader_that_stops_early_gets_no_error_line():
    """`scenes` writes more than head reads: the broken pipe is near certain (it was the
    CI failure of stop 25, "ditherlab: Broken pipe"); exit 0 under pipefail either way."""
    for _ in range(3):
        proc = subprocess.run(f"set -o pipefail; '{BIN}' scenes | head -1", shell=True,
                              executable="/bin/bash", capture_output=True, text=True,
                              timeout=120)
        assert proc.stdout.startswith("scene ") and proc.stdout.count("\n") == 1
        assert proc.stderr == "" and proc.returncode == 0


def test_a_broken_pipe_elsewhere_is_one_line(capsys, monkeypatch):
    cli = importlib.import_module("sweeps.cli.main")

    def broken(args):
        raise BrokenPipeError(32, "Broken pipe (a dask comm)")

    parser = cli.build_parser

    def patched():
        ap = parser()
        for sub in ap._subparsers._group_actions[0].choices.values():
            sub.set_defaults(func=broken)
        return ap

    monkeypatch.setattr(cli, "build_parser", patched)
    assert cli.main(["status"]) == 1
    assert capsys.readouterr().err == "ditherlab: Broken pipe (a dask comm)\n"


def test_a_broken_pipe_elsewhere_is_one_line_with_stdout_an_open_pipe():
    """The same with a real, still-read standard output pipe: the kernel is asked whether
    *our* reader has gone, and it has not (guards the poll against a false 'closed')."""
    code = ("import importlib, sys\n"
            "m = importlib.import_module('sweeps.cli.main')\n"
            "def broken(args): raise BrokenPipeError(32, 'Broken pipe (a dask comm)')\n"
            "p = m.build_parser\n"
            "def patched():\n"
            "    ap = p()\n"
            "    for sub in ap._subparsers._group_actions[0].choices.values():\n"
            "        sub.set_defaults(func=broken)\n"
            "    return ap\n"
            "m.build_parser = patched\n"
            "sys.exit(m.main(['status']))\n")
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          timeout=120)
    assert proc.returncode == 1
    assert proc.stderr == "ditherlab: Broken pipe (a dask comm)\n"
