"""The contact of Sec. 3 (SI units) keeps each level's promise on ``F_mean``.

The levels' atol, 1e-3 rtol absolute, was calibrated on the paper's non-dimensional slider
(states ~ 1e-2 to 1). The contact's bristle deflection is ``z ~ fc / sigma0 = 1e-5 m``, so
until 2026-11-30 that atol held it to ``100 rtol`` and the levels missed their promises by
up to 60x: LuGre at ``v_m = 1e-3``, ``v_a = 3e-3 m/s``, omega = 1000 rad/s was 1.1e-2 off
at draft, 3.4e-4 at standard and 5.8e-6 at reference. The contact now asks for atol in
natural units (engine.contract.MechanicalSystem ``natural_atol``).

Reference: tests/engine/reference.py ``contact`` (scipy DOP853 at rtol 1e-12, atol scaled
per state, every ``u = 0`` a restart; the equations re-typed from DESIGN.md), through the
service's own path (``make_plan`` at each level -> ``run_block``). Points: the paper's scale
(1e-3 m/s) and ten times it, at omega 100 and 1000, u reversing (``v_a = 3 v_m``).
"""
import numpy as np
import pytest

from engine import params as P
from engine import status as S
from engine.blocks import run_block
from sweeps.planning.plan import make_plan
from sweeps.spec import parse_spec
from sweeps.spec.accuracy import TARGET_ERROR
from sweeps.spec.models import LEVELS
from tests.engine import reference as R

POINTS = [(1e-3, 1000.0), (1e-3, 100.0), (1e-2, 1000.0), (1e-2, 100.0)]   # (v_m, omega)
PERIODS = 6   # the window: periods 1 to 6


def _spec(v_m: float, omega: float) -> dict:
    T = 2 * np.pi / omega
    return {"name": "contact-levels", "system": "contact", "friction": "lugre",
            "dither": "sine-velocity", "method": "simulate", "outputs": ["F_mean"],
            "time": {"t_end": PERIODS * T, "t_transient": T},
            "grid": {"W": [3 * v_m], "omega": [omega], "v_ref": [v_m]}}


@pytest.fixture(scope="module")
def references():
    out = {}
    for v_m, omega in POINTS:
        plan = make_plan(parse_spec(_spec(v_m, omega)))
        d = P.unpack(plan.params)
        d.update(W=3 * v_m, omega=omega, v_ref=v_m)
        t_end, t_tr = float(plan.params[P.T_END]), float(plan.params[P.T_TRANSIENT])
        out[v_m, omega] = R.contact(d, "lugre", t_end, t_tr)["F_mean"]
    return out


def test_the_levels_run_the_contact_in_natural_units():
    for level in LEVELS:
        assert make_plan(parse_spec(_spec(1e-3, 1000.0)), level).numerics.settings.atol_units \
            == "natural"
    slider = {**_spec(1e-3, 1000.0), "system": "slider", "time": {"t_end": 2.0, "t_transient": 1.0}}
    assert make_plan(parse_spec(slider)).numerics.settings.atol_units == "absolute"


@pytest.mark.parametrize("level", LEVELS)
def test_each_level_keeps_its_promise_on_the_contact(references, level):
    for (v_m, omega), ref in references.items():
        plan = make_plan(parse_spec(_spec(v_m, omega)), level)
        res = run_block(plan.scene, plan.points, plan.params, plan.numerics.settings)
        assert np.all(res.status == S.OK)
        got = float(np.asarray(res.outputs["F_mean"])[0])
        err = abs(got - ref) / max(abs(ref), 1e-3)
        assert err <= TARGET_ERROR[level], (level, v_m, omega, got, ref, f"{err:.1e}")


@pytest.mark.parametrize("omega", [1e5, 1e6])
def test_a_stateless_law_on_the_contact_keeps_the_reference_promise_at_high_omega(omega):
    """Stribeck on the contact has no bristle: the quadratures of F and u are the states
    under error control (Contact.error_size), scaled ``fc`` and ``max(v_m, v_a)`` as if the
    run lasted 1 s. A contact's run lasts milliseconds, so atol outweighed rtol: at the
    reference level F_mean was 1.4e-7 (omega 1e5) and 1.3e-6 (1e6) off (a review found
    it, 2026-11-30). The scales now take ``t_end``. Reference: ``F(t)`` in closed form,
    integrated by quad (tests/engine/reference.py ``contact_static``, the band included)."""
    plan = make_plan(parse_spec({**_spec(1e-3, omega), "friction": "stribeck"}), "reference")
    res = run_block(plan.scene, plan.points, plan.params, plan.numerics.settings)
    assert np.all(res.status == S.OK)
    d = P.unpack(plan.params)
    d.update(W=3e-3, omega=omega, v_ref=1e-3)
    ref = R.contact_static(d, "stribeck", float(plan.params[P.T_END]),
                           float(plan.params[P.T_TRANSIENT]))["F_mean"]
    got = float(np.asarray(res.outputs["F_mean"])[0])
    assert abs(got - ref) / max(abs(ref), 1e-3) <= TARGET_ERROR["reference"], (got, ref)


def test_an_explicit_accuracy_on_the_contact_takes_its_natural_units_unless_told(references):
    """The same trap for explicit numerics: ``{integrator = "dopri5", rtol = ...}`` without
    ``atol_units`` takes the system's own (natural on the contact, absolute elsewhere); one
    that names "absolute" keeps it, and is another sweep. On the slider, not naming it and
    naming "absolute" are the same numbers, so the same sweep."""
    acc = {"integrator": "dopri5", "rtol": 1e-10}
    contact = {**_spec(1e-3, 1000.0), "accuracy": acc}
    told = {**contact, "accuracy": {**acc, "atol_units": "absolute"}}
    plans = [make_plan(parse_spec(s)) for s in (contact, told)]
    assert [p.numerics.settings.atol_units for p in plans] == ["natural", "absolute"]
    assert plans[0].sweep_id != plans[1].sweep_id
    slider = {**contact, "system": "slider", "time": {"t_end": 2.0, "t_transient": 1.0}}
    same = [make_plan(parse_spec(s)) for s in (slider, {**slider, "accuracy": told["accuracy"]})]
    assert [p.numerics.settings.atol_units for p in same] == ["absolute", "absolute"]
    assert same[0].sweep_id == same[1].sweep_id
    res = run_block(plans[0].scene, plans[0].points, plans[0].params,
                    plans[0].numerics.settings)
    ref = references[1e-3, 1000.0]   # (the same point and window)
    got = float(np.asarray(res.outputs["F_mean"])[0])
    assert abs(got - ref) / abs(ref) <= TARGET_ERROR["reference"], (got, ref)
