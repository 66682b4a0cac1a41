"""A fixed step's stability is judged by the law's own relaxation rate
(engine.contract.FrictionLaw.relaxation_factor; sweeps.spec.fixed_step).

Dahl's bristle relaxes ``a 2**(a - 1)`` times faster than LuGre's right after a reversal
of a saturated ``z`` (``dahl_alpha = a``): until 2026-11-30 the draft level still chose RK4
by LuGre's rate under a square wave, and at ``dahl_alpha = 10`` a point went non-finite
(W 0.3, omega 500, v_ref 0.1, sigma0 100; the explicit ``rk4`` check did not look at Dahl
at all)."""
from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from engine import Settings, simulate
from engine import params as P
from sweeps.planning.plan import make_plan
from sweeps.spec import SpecError, parse_spec
from sweeps.spec.accuracy import TARGET_ERROR

DAHL_SQUARE = {
    "name": "dahl-square", "friction": "dahl", "dither": "square-velocity",
    "outputs": ["v_mean", "F_mean"], "accuracy": "draft",
    "params": {"sigma0": 100.0},
    "grid": {"W": [0.3], "omega": [500.0, 1000.0], "v_ref": [0.1]},
}


def dahl(alpha: float, **changes) -> dict:
    return {**DAHL_SQUARE, **changes, "params": {**DAHL_SQUARE["params"], "dahl_alpha": alpha}}


def test_draft_keeps_rk4_where_dahl_relaxes_as_lugre_and_not_where_it_is_stiffer():
    assert make_plan(parse_spec(dahl(1.0))).numerics.integrator == "rk4"    # factor 1
    assert make_plan(parse_spec({**dahl(1.0), "friction": "lugre",
                                 "params": {"sigma0": 100.0}})).numerics.integrator == "rk4"
    for alpha in (2.0, 10.0):                                                # 4, 5120
        assert make_plan(parse_spec(dahl(alpha))).numerics.integrator == "dopri5", alpha


def _point(plan, i: int):
    """The plan's scene and the parameter vector of its grid point ``i``."""
    p = plan.params.copy()
    p[P.W], p[P.OMEGA], p[P.V_REF] = plan.points_at(np.array([i]))[0, :3]
    return plan.scene, p


def test_the_stiff_dahl_draft_point_is_finite_and_within_its_promise():
    """The point that went non-finite: the draft plan now runs it with status ok, within
    draft's promise of a tight DP5 run (rtol 1e-11)."""
    plan = make_plan(parse_spec(dahl(10.0)))
    for i in range(2):
        scene, p = _point(plan, i)
        got = simulate(scene, p, plan.numerics.settings)
        tight = simulate(replace(scene, integrator="dopri5"), p,
                         Settings(rtol=1e-11, atol=1e-14))
        assert got.status == tight.status == 0
        for out in ("v_mean", "F_mean"):
            a, b = got.outputs[out], tight.outputs[out]
            assert abs(a - b) / max(abs(b), 1e-3) <= TARGET_ERROR["draft"], (out, a, b)


def test_rk4_on_the_stiff_dahl_point_is_what_went_wrong():
    """The same point with the RK4 the old plan chose: not finite (status 3), so the test
    above checks the plan's choice, not a point RK4 could have run."""
    plan = make_plan(parse_spec(dahl(10.0)))
    scene, p = _point(plan, 0)
    rk4 = simulate(replace(scene, integrator="rk4"), p,
                   Settings(steps_per_period=1))
    assert rk4.status == 3 or not all(math.isfinite(v) for v in rk4.outputs.values())


def test_explicit_rk4_is_refused_where_dahl_is_stiffer():
    ok = dahl(1.0, accuracy={"integrator": "rk4", "steps_per_period": 1})
    assert make_plan(parse_spec(ok)).numerics.integrator == "rk4"
    with pytest.raises(SpecError) as info:
        parse_spec(dahl(10.0, accuracy={"integrator": "rk4", "steps_per_period": 1}))
    (msg,) = info.value.problems
    assert msg.startswith("accuracy.steps_per_period: rk4 unstable"), msg
    assert "bristle relaxation" in msg and "'dopri5'" in msg, msg


BROUGHT = '''
from engine.friction.dahl import Dahl


class Mine(Dahl):
    name = "mine"

    def relaxation_factor(self, values):
        {body}
'''


@pytest.mark.parametrize("module, body, says", [
    ("raises", "raise RuntimeError('no idea')",
     "relaxation_factor failed: RuntimeError: no idea (at raises.py line 9)"),
    ("exits", "raise SystemExit(0)", "relaxation_factor failed: SystemExit: 0"),
    ("words", "return 'fast'", "relaxation_factor must return a positive number, got 'fast'"),
    ("negative", "return -1.0", "relaxation_factor must return a positive number, got -1.0"),
    ("nan", "return float('nan')", "must return a positive number, got nan"),
    ("inf", "return float('inf')", "must return a positive number, got inf"),
    ("boolean", "return True", "must return a positive number, got True"),
    ("huge", "return 10 ** 400", "must return a positive number, got 1000000"),
    ("huger", "return 10 ** 5000", "must return a positive number, got <a int>"),
])
def test_a_brought_laws_bad_relaxation_factor_is_one_line(tmp_path, monkeypatch, module, body,
                                                          says):
    (tmp_path / f"{module}.py").write_text(BROUGHT.format(body=body))
    monkeypatch.syspath_prepend(str(tmp_path))
    with pytest.raises((SpecError, ValueError)) as info:
        make_plan(parse_spec({**dahl(1.0), "friction": f"{module}:Mine"}))
    text = str(info.value)
    assert says in text and "\n" not in text.strip(), text


@pytest.mark.parametrize("module, factor, integrator", [
    ("says_one", "1.0", "rk4"), ("says_stiff", "100.0", "dopri5")])
def test_a_brought_laws_factor_decides_as_dahls_does(tmp_path, monkeypatch, module, factor,
                                                     integrator):
    """A brought law's own factor is what the plan reads: the same Dahl equations at
    dahl_alpha = 10 declared as relaxing like LuGre keep RK4 at draft, declared 100x
    stiffer take DP5."""
    (tmp_path / f"{module}.py").write_text(BROUGHT.format(body=f"return {factor}"))
    monkeypatch.syspath_prepend(str(tmp_path))
    spec = {**dahl(10.0), "friction": f"{module}:Mine"}
    assert make_plan(parse_spec(spec)).numerics.integrator == integrator


def test_explicit_rk4_is_refused_for_a_brought_law_past_its_factor(tmp_path, monkeypatch):
    """A brought law that inherits Dahl's factor is held to it like Dahl (until the review of
    2026-11-30 only the built-in names were checked: the same spec ran 1 of 2 points
    non-finite)."""
    (tmp_path / "heir.py").write_text(BROUGHT.replace(
        "\n    def relaxation_factor(self, values):\n        {body}\n", ""))
    monkeypatch.syspath_prepend(str(tmp_path))
    with pytest.raises(SpecError) as info:
        parse_spec({**dahl(10.0, accuracy={"integrator": "rk4", "steps_per_period": 1}),
                    "friction": "heir:Mine"})
    (msg,) = info.value.problems
    assert msg.startswith("accuracy.steps_per_period: rk4 unstable"), msg


def test_a_law_without_a_declared_factor_is_not_held_to_a_bristle(tmp_path, monkeypatch):
    """GMS's states do not relax at sigma0: with the contract's default it is not given a
    bristle's rate in the explicit check (an explicit rk4 at sigma0 = 1e5 is accepted)."""
    spec = {**DAHL_SQUARE, "friction": "gms", "params": {"sigma0": 1e5},
            "accuracy": {"integrator": "rk4", "steps_per_period": 4}}
    assert make_plan(parse_spec(spec)).numerics.integrator == "rk4"
