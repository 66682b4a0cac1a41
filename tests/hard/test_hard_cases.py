"""Hard cases: each finishes with status OK, finite and bounded results that agree with its
refined run (rtol / 100) and with the independent scipy reference, within a step budget.

Cases, references and error units: tests/hard/hardcases.py and scripts/reference_engine.py.
The CI subset runs in well under a minute after compilation; the long ones (t_end = 1e4,
omega = 1e5 over 100 tau, the stiff scenes over 100 tau, every case with the stiff
method) are marked ``slow`` (``pytest -m slow tests/hard``).
"""
from __future__ import annotations

import numpy as np
import pytest

from engine import status as S

from .hardcases import REFINE, Case, error_units, run

CI = [
    # sigma0 = 1e4, 1e6: bristle time scale g / (sigma0 |u|) down to 1e-6; the stiff method
    Case("sigma0_1e4", "rodas4", 1e-6, budget=110_000, tol=1e-6),
    Case("sigma0_1e6", "rodas4", 1e-6, budget=170_000, tol=1e-6),
    # sigma1(u) drops by e^-1 within |u| = 1e-3 of the kink at u = 0
    Case("vd_1e-3", "dopri5", 1e-8, budget=100_000, tol=1e-4),
    # W = v_ref: the interface velocity u = v - W hovers around 0 on every other half-period
    Case("W_eq_vref_0.1", "dopri5", 1e-8, budget=70_000, tol=1e-6),
    # 2 pi / omega = 6.3e-5: 63662 switches in 2 tau
    Case("omega_1e5", "dopri5", 1e-8, budget=150_000, tol=1e-6),
    # creep: v_ref = 1e-6 without dither (u ~ 1e-8 at the kink), and with the fig10 dither
    Case("vref_1e-6", "dopri5", 1e-8, budget=70_000, tol=1e-6),
    Case("vref_1e-6_dither", "dopri5", 1e-8, budget=300_000, tol=1e-5),
]
SLOW = [
    # from t ~ 100 on, u = v - W grazes 0 every other half-period (v -> v_ref = W): ~2.5
    # steps + 1.5 retakes per half-period, 1.3e7 in all (measured)
    Case("t_end_1e4", "dopri5", 1e-8, budget=25_000_000, tol=1e-6,
         overrides={"t_end": 1e4}, record=False),
    Case("omega_1e5_100tau", "dopri5", 1e-8, budget=8_000_000, tol=1e-6,
         overrides={"omega": 1e5}, record=False),
    Case("sigma0_1e4_100tau", "rodas4", 1e-6, budget=2_000_000, tol=1e-5,
         overrides={"sigma0": 1e4}, record=False),
    Case("sigma0_1e6_100tau", "rodas4", 1e-6, budget=3_000_000, tol=1e-5,
         overrides={"sigma0": 1e6}, record=False),
] + [Case(c.name, "rodas4", c.rtol, budget=4 * c.budget, tol=c.tol) for c in CI
     if c.method != "rodas4"]


def _ids(cases):
    return [f"{c.name}-{c.method}" for c in cases]


def check(case: Case):
    c = case.params
    r = run(c, case.method, case.rtol, case.budget, case.record)
    assert r.status == S.OK, (f"{case.name}: status {S.MEANINGS[r.status]} within "
                              f"{case.budget} steps ({r.steps} accepted, {r.rejected} rejected)")
    assert np.all(np.isfinite(r.q)), f"{case.name}: non-finite q {r.q}"
    assert r.steps + r.rejected <= case.budget
    # LuGre keeps |z| <= g(u) / sigma0 <= fs / sigma0 from rest (DESIGN.md §1), up to rtol
    # (over all recorded steps; at t_end only for record=False)
    assert r.z_max <= c["fs"] / c["sigma0"] * (1 + 10 * case.rtol), r.z_max
    fine = run(c, case.method, case.rtol / REFINE, REFINE ** 0.25 * 4 * case.budget,
               case.record)
    assert fine.status == S.OK, f"{case.name} refined: status {S.MEANINGS[fine.status]}"
    err = error_units(r.q, fine.q, c)
    assert err <= case.tol, f"{case.name}: {err:.2e} from its refined run (tol {case.tol:g})"
    ref = case.reference
    if ref is not None:
        # the reference's own error (self_error) is part of the allowance
        err_ref = error_units(fine.q, np.array(ref["q"]), c)
        allowed = case.tol + 2 * ref["self_error"]
        assert err_ref <= allowed, (f"{case.name}: {err_ref:.2e} from the {ref['method']} "
                                    f"reference (allowed {allowed:.2e})")
    return r, fine


@pytest.mark.parametrize("case", CI, ids=_ids(CI))
def test_hard_case(case):
    check(case)


@pytest.mark.slow
@pytest.mark.parametrize("case", SLOW, ids=_ids(SLOW))
def test_hard_case_slow(case):
    check(case)
