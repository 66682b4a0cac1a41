"""Skipping a guarantee test that this machine cannot run, but never in CI.

The disk-full and read-only-store tests need to mount a tmpfs or a read-only bind mount,
which takes root. A developer's machine may not allow it: the test skips and says why. CI
runs as root (.ci/run, ``CI=true``): there the mount must work, and a skip would hide a
guarantee that nobody checks any more, so it is a failure."""
from __future__ import annotations

import os

import pytest


def in_ci_as_root() -> bool:
    return os.environ.get("CI", "").lower() == "true" and os.geteuid() == 0


def skip_unless_ci(reason: str) -> None:
    """``pytest.skip(reason)``, or ``pytest.fail`` in CI as root (module docstring)."""
    if in_ci_as_root():
        pytest.fail(f"{reason}; CI runs as root, where this guarantee test must run")
    pytest.skip(reason)
