"""The elasto-plastic phase shares converge with the tolerance and meet every level's
promise (issue 9; DESIGN.md §1 "Elasto-plastic phases").

Expected values: ``tests/hard/phase_references.json``, written by
``scripts/reference_phases.py`` -- an independent computation (its own numpy right-hand
side, scipy DOP853 at rtol 1e-12 (1e-11 with dither) restarted at every kink of the law,
step capped below the bristle relaxation time, thresholds located by brentq on the dense
output; its own tolerance check: shares agree to 1e-10 (undithered) and 8e-9 (dither)
between rtol 1e-10/1e-12 and 1e-9/1e-11); DESIGN.md §1 gives the undithered shares as
stick 0.527, pre-sliding 0.123, slip 0.350.
"""
import json
import math
from pathlib import Path

import numpy as np
import pytest

from engine import params as P
from engine.blocks import run_block
from engine.phase_book import share_above
from sweeps.spec.accuracy import promise
from sweeps.planning.plan import make_plan
from sweeps.spec import parse_spec

REFS = json.loads((Path(__file__).parents[1] / "hard" / "phase_references.json").read_text())
SHARES = ("stick_fraction", "presliding_fraction", "slip_fraction")
OUTPUTS = [*SHARES, "near_slip_fraction", "alpha_hist"]   # (also tests/e2e/test_accuracy_gate.py's)


def _spec(W=0.0, omega=1000.0, t_transient=0.0, accuracy="standard"):
    return parse_spec({
        "name": "sec7-phases", "friction": "elastoplastic", "dither": "sine-velocity",
        "method": "simulate", "outputs": OUTPUTS, "accuracy": accuracy,
        "params": {"lam": 0.8, "slow_force": {"amplitude": 1.7, "omega": 0.3}},
        "time": {"t_end": 100.0, "t_transient": t_transient},
        "grid": {"W": [W], "omega": [omega], "v_ref": [0.1], "v_d": [0.1]}})


def _run(spec, level):
    plan = make_plan(spec, level)
    res = run_block(plan.scene, plan.block_points(0), plan.params, plan.numerics.settings)
    assert res.status[0] == 0
    return {k: v[0] for k, v in res.outputs.items()}, plan


KEYS = {"stick_fraction": "stick", "presliding_fraction": "presliding",
        "slip_fraction": "slip", "near_slip_fraction": "near_slip", "alpha_hist": "alpha_hist"}


def _ref(case):
    """The independent reference shares of ``case``, by output name."""
    return {out: np.asarray(REFS[case]["shares"][key]) for out, key in KEYS.items()}


@pytest.mark.long
def test_share_above_is_exact_for_quadratics():
    assert share_above(0.0, 0.5, 1.0, 0.25) == pytest.approx(0.75, abs=1e-15)
    assert share_above(1.0, 1.0, 1.0, 0.5) == 1.0 and share_above(0.0, 0.0, 0.0, 0.5) == 0.0
    rng = np.random.default_rng(7)
    s = np.linspace(0.0, 1.0, 2_000_001)
    for _ in range(200):
        r0, rm, r1, thr = rng.normal(size=4)
        q = r0 + s * (4 * rm - 3 * r0 - r1) + s * s * (2 * (r0 + r1) - 4 * rm)
        assert share_above(r0, rm, r1, thr) == pytest.approx(np.mean(q >= thr), abs=2e-6)


@pytest.mark.long
@pytest.mark.parametrize("level", ["draft", "standard", "reference"])
def test_undithered_shares_meet_every_level(level):
    """The measured defect: slip 0.081 / 0.096 / 0.350 at draft / standard / reference."""
    ref = _ref("undithered")
    out, plan = _run(_spec(), level)
    assert plan.scene.dither == "none"
    # DESIGN.md §1's reference shares, to 0.01 (the issue's acceptance)
    for name, design in zip(SHARES, (0.527, 0.123, 0.350)):
        assert abs(out[name] - design) < 0.01, (level, name, out[name])
    # the independent computation, within the level's promise for each output
    for name in SHARES + ("near_slip_fraction",):
        assert abs(out[name] - ref[name]) <= promise(level, name), (level, name, out[name])
    assert np.max(np.abs(out["alpha_hist"] - ref["alpha_hist"])) <= promise(level, "alpha_hist")
    assert math.isclose(sum(out[n] for n in SHARES), 1.0, abs_tol=1e-12)
    assert math.isclose(out["alpha_hist"].sum(), 1.0, abs_tol=1e-12)


@pytest.mark.long   # 17-30 s of first compilations (2 cores): quick set <= 3 min, issue 38
def test_near_slip_is_well_conditioned_at_loose_tolerance():
    """near_slip (alpha >= 0.9) converges where slip (alpha == 1) cannot: DP5 at rtol 1e-5."""
    from engine.settings import Settings

    plan = make_plan(_spec(), "standard")
    loose = run_block(plan.scene, plan.block_points(0), plan.params,
                      Settings(rtol=1e-5, atol=1e-8))
    ref = _ref("undithered")
    assert abs(loose.outputs["near_slip_fraction"][0] - ref["near_slip_fraction"]) < 1e-4
    assert abs(loose.outputs["slip_fraction"][0] - ref["slip_fraction"]) > 1e-2  # why slip needs PHASE_LEVELS


@pytest.mark.long
def test_sine_dither_shares_meet_standard():
    """Sec. 7 with sine-velocity dither W = 1, omega = 300 (window [20, 100])."""
    case = REFS["sine_W1_w300"]
    ref = _ref("sine_W1_w300")
    out, _ = _run(_spec(W=case["params"]["W"], omega=case["params"]["omega"],
                        t_transient=case["t_transient"]), "standard")
    for name in SHARES + ("near_slip_fraction",):
        assert abs(out[name] - ref[name]) <= promise("standard", name), (name, out[name])
    assert np.max(np.abs(out["alpha_hist"] - ref["alpha_hist"])) <= promise("standard",
                                                                           "alpha_hist")


@pytest.mark.long   # 17-30 s of first compilations (2 cores): quick set <= 3 min, issue 38
def test_zero_dither_row_does_not_depend_on_omega():
    """specs/fig14.toml's W = 0 row had slip_fraction 0.100-0.106 across omega, where omega
    means nothing; now the row agrees to the standard promise."""
    spec = _spec(t_transient=20.0)
    plan = make_plan(spec, "standard")
    scene = plan.scene.with_(dither="sine-velocity")      # as in a grid with W > 0 elsewhere
    pts = np.array([[0.0, om, 0.1, 0.1] for om in (10.0, 46.4, 215.4, 1000.0)])
    p = plan.params.copy()
    res = run_block(scene, pts, p, plan.numerics.settings)
    assert np.all(res.status == 0)
    for name in SHARES:
        spread = np.ptp(res.outputs[name])
        assert spread <= promise("standard", name), (name, res.outputs[name])
    assert p[P.SLIP_GAP] == 1e-9
