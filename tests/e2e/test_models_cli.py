"""Bad user code through the command line (issue 35): `ditherlab plan` and `submit` of a spec
naming a broken law end in one line on stderr, exit 2, and write nothing to the store."""
from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

pytestmark = [pytest.mark.long, pytest.mark.subprocess]

BIN = Path(sys.executable).parent / "ditherlab"
BROKEN = {
    "does_not_import": "import no_such_package_anywhere\n",
    "cannot_compile": '''
from engine.contract import FrictionLaw, LawKernels

class X(FrictionLaw):
    name = "x"

    def build(self, b):
        Z = b.z0

        @b.jit(inline="always")
        def rates(u, y, dy, hold, p):
            dy[Z] = u + "a"
            return u

        @b.jit(inline="always")
        def force(u, y, hold, p):
            return y[Z], 1.0

        @b.jit(inline="always")
        def init(p, y):
            y[Z] = 0.0

        return LawKernels(rates, force, 0, None, init, init)
''',
    # sys.exit() in a hook ended `ditherlab` silently with its code (0: "done") until
    # 2026-11-30 (engine.user_code.USER_FAULTS)
    "exits_at_import": "import sys\nsys.exit(0)\n",
    "exits_in_a_hook": '''
import sys
from engine.friction.dahl import Dahl

class X(Dahl):
    name = "x"

    def check(self, values):
        sys.exit(0)
''',
}


@pytest.mark.parametrize("command", ["plan", "submit"])
@pytest.mark.parametrize("module", sorted(BROKEN))
def test_bad_user_code_is_one_line_exit_2_and_nothing_written(tmp_path, module, command):
    (tmp_path / f"{module}.py").write_text(BROKEN[module])
    spec = tmp_path / "spec.json"
    spec.write_text(json.dumps({"friction": f"{module}:X", "dither": "none",
                                "outputs": ["v_mean"], "time": {"t_end": 2.0,
                                                                "t_transient": 1.0}}))
    store = tmp_path / "store"
    out = subprocess.run([str(BIN), command, str(spec), "--store", str(store)], cwd=tmp_path,
                         capture_output=True, text=True, timeout=600)
    assert out.returncode == 2, out.stderr
    lines = [ln for ln in out.stderr.splitlines() if ln.strip()]
    assert "Traceback" not in out.stderr
    assert module in out.stderr, out.stderr
    what = {"does_not_import": "cannot import", "cannot_compile": "numba cannot compile",
            "exits_at_import": "cannot import 'exits_at_import': SystemExit: 0",
            "exits_in_a_hook": "x.check failed: SystemExit: 0"}[module]
    assert any(what in ln for ln in lines), out.stderr
    if module == "cannot_compile":
        assert f"{module}.py line" in out.stderr, out.stderr
    assert len(lines) <= 2, out.stderr        # "invalid sweep spec:" and its one fault
    assert not store.exists() or not any(store.rglob("*.nc")), "something was written"


@pytest.mark.parametrize("friction, dither, capped", [
    ("gms", "sine-velocity", True),        # modes: a reversal stepped over changes them
    ("stribeck", "sine-force", True),      # switches that mark jumps
    ("dahl", "sine-velocity", True),       # a corner probed for grazing (switch_jumps)
    ("lugre", "sine-velocity", False),     # neither: no cap compiled in
    ("gms", "square-velocity", False),     # the square wave's switches are stops already
])
def test_plan_says_where_steps_are_capped_to_a_quarter_dither_period(tmp_path, friction,
                                                                     dither, capped):
    spec = tmp_path / "spec.json"
    spec.write_text(json.dumps({"friction": friction, "dither": dither,
                                "outputs": ["v_mean"], "grid": {"W": [0.2]}}))
    out = subprocess.run([str(BIN), "plan", str(spec), "--store", str(tmp_path / "store")],
                         cwd=tmp_path, capture_output=True, text=True, timeout=600)
    assert out.returncode == 0, out.stderr
    numerics = next(ln for ln in out.stdout.splitlines() if ln.startswith("numerics"))
    assert ("steps of at most 0.25 dither period" in numerics) == capped, numerics
