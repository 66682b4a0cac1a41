"""A guarantee test that cannot run skips on a developer's machine but fails in CI as root
(tests/guarantee.py)."""
import os

import pytest

from .guarantee import skip_unless_ci


@pytest.mark.parametrize("ci, euid, outcome", [
    ("true", 0, pytest.fail.Exception),      # CI runs as root: the mount must work
    ("true", 1000, pytest.skip.Exception),
    ("", 0, pytest.skip.Exception),
])
def test_a_skip_is_a_failure_only_in_ci_as_root(monkeypatch, ci, euid, outcome):
    monkeypatch.setenv("CI", ci)
    monkeypatch.setattr(os, "geteuid", lambda: euid)
    with pytest.raises(outcome, match="cannot mount here: not root"):
        skip_unless_ci("cannot mount here: not root")
