"""What the engine cannot run is refused at spec time (issue 10, sweeps.spec.feasibility):
unknown integrators, options an integrator ignores, explicit fixed steps outside the
method's stability region, points certain to exhaust the step budget."""
import math
import warnings

import pytest

from engine.integrators import stability_region
from sweeps.spec import fixed_step as stability
from sweeps.spec.grid import base_params
from sweeps.spec.accuracy import FIXED_H, FIXED_STEPS, RK4_WHERE, numerics
from sweeps.planning.plan import make_plan
from sweeps.spec import SpecError, SpecWarning, parse_spec

from .spec_mutations import NUMERICS_OF_ANOTHER_INTEGRATOR

# the Sec. 7 scene (specs/fig14.toml) at the point of issue 10: W = 1, omega = 3000
SEC7 = {
    "name": "sec7", "friction": "elastoplastic", "dither": "sine-velocity",
    "method": "simulate", "outputs": ["F_mean", "stick_fraction"],
    "params": {"lam": 0.8, "slow_force": {"amplitude": 1.7, "omega": 0.3}},
    "time": {"t_end": 100.0, "t_transient": 20.0},
    "grid": {"W": [1.0], "omega": [3000.0], "v_ref": [0.1], "v_d": [0.1]},
}


def refused(data) -> list[str]:
    with pytest.raises(SpecError) as info:
        parse_spec(data)
    return info.value.problems


def explicit(acc: dict, base=SEC7, **changes) -> dict:
    return {**base, **changes, "accuracy": acc}


def accepted(data):
    """The numerics ``data`` runs with, parsed with SpecWarning as an error: an accepted
    spec is accepted silently and runs with what it asked for (a check that refused it,
    warned, or changed its step on the way would fail here)."""
    with warnings.catch_warnings():
        warnings.simplefilter("error", SpecWarning)
        return make_plan(parse_spec(data)).numerics


def test_rk4_stability_bounds_come_from_the_tableau():
    assert stability_region.reach("rk4", math.pi) == pytest.approx(2.7853, abs=1e-4)
    assert stability_region.reach("rk4", math.pi / 2) == pytest.approx(2 * math.sqrt(2), abs=1e-6)


def test_unstable_explicit_step_of_issue_10_is_refused():
    """rk4 at one step per dither period on the Sec. 7 scene returned F_mean 0.094 with
    status ok (DP5: 0.158): refused now, with the bound, h*lambda and what to do."""
    (msg,) = refused(explicit({"integrator": "rk4", "steps_per_period": 1}))
    assert msg.startswith("accuracy.steps_per_period: rk4 unstable"), msg
    assert "|h lambda| = 6.28 > 2.828" in msg and "sine dither" in msg, msg
    assert "steps_per_period >= 3" in msg and "'dopri5'" in msg, msg
    (msg,) = refused(explicit({"integrator": "rk4", "steps_per_period": 2}))
    assert "3.14 > 2.828" in msg


def test_explicit_step_under_the_bound_is_allowed():
    n = accepted(explicit({"integrator": "rk4", "steps_per_period": 3}))   # h omega = 2.09
    assert (n.integrator, n.label, n.settings.steps_per_period) == ("rk4", "explicit", 3)


def _no_dither_step(h_lambda: float) -> float:
    """The rk4 step at which the bristle estimate of SEC7 without dither is ``h_lambda``:
    sigma0 (2 v_ref + |A|) / fc = 100 * 1.9 / 1."""
    return h_lambda / 190.0


@pytest.mark.parametrize("h_lambda, ok", [(2.70, True), (2.78, True), (2.80, False),
                                          (5.7, False)])
def test_bristle_relaxation_bound_on_the_real_axis(h_lambda, ok):
    data = explicit({"integrator": "rk4", "step": _no_dither_step(h_lambda)},
                    dither="none", grid={"W": [0.0], "v_ref": [0.1]})
    if ok:
        n = accepted(data)
        assert (n.integrator, n.settings.h) == ("rk4", _no_dither_step(h_lambda))
        return
    (msg,) = refused(data)
    assert msg.startswith("accuracy.step: rk4 unstable"), msg
    assert f"|h lambda| = {h_lambda:.3g} > 2.785" in msg and "bristle relaxation" in msg, msg
    assert "use step <= 0.0146" in msg, msg


def test_default_steps_per_period_named_when_not_given():
    (msg,) = refused(explicit({"integrator": "rk4"},
                              grid={"W": [3.0], "omega": [10.0], "v_ref": [0.1]}))
    assert msg.startswith("accuracy: rk4 unstable") and "at omega = 10" in msg, msg


@pytest.mark.parametrize("name", ["euler", "", "RK4", "dopri"])
def test_unknown_integrator_refused_with_the_allowed_names(name):
    (msg,) = refused(explicit({"integrator": name}))
    assert msg == (f"accuracy.integrator: unknown integrator {name!r}; allowed: dopri5, rk4, "
                   "rodas4, rosenbrock"), msg


@pytest.mark.parametrize("acc, field", [
    *NUMERICS_OF_ANOTHER_INTEGRATOR,
    ({"integrator": "rk4", "step": 1e-3}, "accuracy.step"),                # with dither
])
def test_ignored_options_refused(acc, field):
    (msg,) = refused(explicit(acc))
    assert msg.startswith(field + ":") and "ignore" in msg, msg


def test_steps_per_period_without_dither_refused():
    (msg,) = refused(explicit({"integrator": "rk4", "steps_per_period": 8},
                              grid={"W": [0.0], "v_ref": [0.1]}))
    assert msg.startswith("accuracy.steps_per_period: ignored without dither (W = 0"), msg


def test_explicit_defaults_still_accepted():
    """Options equal to the defaults are not "ignored options": accepted, and used."""
    n = accepted(explicit({"integrator": "rk4", "steps_per_period": 8,
                           "atol_units": "absolute"}))
    assert (n.integrator, n.settings.steps_per_period, n.settings.atol_units) == (
        "rk4", 8, "absolute")
    n = accepted(explicit({"integrator": "dopri5", "rtol": 1e-7, "atol": 1e-10,
                           "atol_units": "natural"}))
    assert (n.integrator, n.settings.rtol, n.settings.atol, n.settings.atol_units) == (
        "dopri5", 1e-7, 1e-10, "natural")
    assert (accepted(explicit({})).integrator, accepted(explicit({})).label) == (
        "dopri5", "explicit")


# a scene per dither where the levels may pick rk4 (rk4_fits: h sigma0 u_max / fc <= 0.5)
RK4_SCENES = {
    "square-velocity": {"friction": "lugre", "dither": "square-velocity", "grid": {
        "W": [0.0, 0.4, 0.6], "omega": [1000.0], "v_ref": [0.4], "v_d": [0.1]}},   # Fig. 10(d)
    "none": {"friction": "lugre", "dither": "none", "grid": {"v_ref": [0.4]}},
    "sine-velocity": {"friction": "lugre", "dither": "sine-velocity", "grid": {
        "W": [0.4], "omega": [1000.0], "v_ref": [0.4]}},
}
RK4_CASES = [(d, lv) for d, levels in RK4_WHERE.items() for lv in levels if d in RK4_SCENES]


@pytest.mark.parametrize("dither, level", RK4_CASES)
def test_level_defaults_unaffected(dither, level):
    """The levels pick rk4 only where rk4_fits (RK4_WHERE); those specs are accepted, and
    the same numerics made explicit are within the stability bound too."""
    spec = RK4_SCENES[dither]
    data = {"name": "lv", "method": "simulate", "outputs": ["v_mean", "F_mean"],
            "accuracy": level, "time": {"t_end": 20.0, "t_transient": 10.0}, **spec}
    s = parse_spec(data)
    assert make_plan(s).numerics.integrator == "rk4"
    step = ({"step": FIXED_H[level]} if dither == "none"
            else {"steps_per_period": FIXED_STEPS[level]})
    n = accepted({**data, "accuracy": {"integrator": "rk4", **step}})
    same = ("h",) if dither == "none" else ("steps_per_period",)
    assert [getattr(n.settings, k) for k in same] == \
        [getattr(make_plan(s).numerics.settings, k) for k in same]


def test_levels_never_checked_for_stability():
    """A level is the calibrated choice (sweeps.spec.accuracy); only explicit numerics are
    held to the bound here."""
    s = parse_spec({**SEC7, "accuracy": "draft"})
    assert stability.stability_faults(s, s.grid_facts, base_params(s), numerics(s, 100.0)) == []


# --- the step budget ----------------------------------------------------------------------

@pytest.mark.parametrize("dither", ["square-velocity", "sine-velocity"])
def test_omega_certain_to_exhaust_the_step_budget_refused(dither):
    data = {**SEC7, "dither": dither, "grid": {**SEC7["grid"], "omega": [1e8]}}
    (msg,) = refused(data)
    assert msg.startswith("grid.omega: at omega = 1e+08 a point has"), msg
    assert "budget of 5e+07 steps" in msg and "lower omega or t_end" in msg, msg


def test_fixed_steps_over_the_budget_refused():
    (msg,) = refused(explicit({"integrator": "rk4", "steps_per_period": 1000},
                              grid={**SEC7["grid"], "omega": [3e5]}))
    assert msg.startswith("accuracy.steps_per_period: rk4 (explicit numerics) takes 1000 steps")
    (msg,) = refused(explicit({"integrator": "rk4", "step": 1e-7}, dither="none",
                              grid={"W": [0.0]}))
    assert msg.startswith("accuracy.step: rk4 (explicit numerics) with step 1e-07 takes")


def test_slow_force_certain_to_exhaust_the_budget_refused():
    data = {**SEC7, "params": {"slow_force": {"amplitude": 1.0, "omega": 1e8}}}
    (msg,) = refused(data)
    assert msg.startswith("params.slow_force.omega:"), msg


def test_omega_that_may_exhaust_the_budget_warns():
    data = {**SEC7, "grid": {**SEC7["grid"], "omega": [1e6]}}   # 1.6e7 periods
    with pytest.warns(SpecWarning, match="may exhaust the budget"):
        parse_spec(data)
    with warnings.catch_warnings():
        warnings.simplefilter("error", SpecWarning)
        parse_spec(SEC7)


def test_no_budget_check_for_the_analysis_paths():
    """1e12 dither periods would exhaust any time integration; harmonic balance solves one
    period, and the averaged theory has no omega at all (omega -> infinity: a grid.omega
    is refused there, docs/MODEL.md §1)."""
    hbm = {"name": "hbm", "method": "hbm", "system": "contact", "friction": "lugre",
           "dither": "sine-velocity", "grid": {"W": [1e-3], "omega": [1e12]}}
    with warnings.catch_warnings():
        warnings.simplefilter("error", SpecWarning)
        plan = make_plan(parse_spec(hbm))
        assert (plan.path, list(plan.coords["omega"])) == ("hbm", [1e12])
        plan = make_plan(parse_spec({"name": "avg", "method": "averaged", "friction": "lugre",
                                     "grid": {"W": [0.5, 1e6]}}))
        assert (plan.path, list(plan.coords["W"])) == ("averaged", [0.5, 1e6])
    # the same omega on the simulate path is refused: the check is there, and skipped here
    (msg,) = refused({**hbm, "method": "simulate", "system": "slider",
                      "time": {"t_end": 100.0, "t_transient": 20.0}})
    assert msg.startswith("grid.omega: at omega = 1e+12 a point has"), msg
