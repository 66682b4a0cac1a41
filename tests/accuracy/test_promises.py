"""Every shipped spec and gallery scene (small size) keeps every level's promise: the
service's own error estimate (a sample re-run 100x more accurately, sweeps.estimate) records no
warning at draft, standard or reference (scripts/promise_check.py; issue 30: the demo's
first output was a warning that F_mean changed more than draft promises). Long: about
seven sweeps of up to 49 points at each of three levels."""
import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "scripts"))
import promise_check  # noqa: E402


# long (CI runs it, `-m long`): about 400 s of CPU on two workers (docs/ACCURACY.md 5.2);
# on the shared 2-core machine at load 8-11 it took 15 min, past the suite's 900 s guard
@pytest.mark.long
@pytest.mark.timeout(2400)
def test_no_shipped_spec_warns_at_any_level(tmp_path):
    rows = promise_check.check(promise_check.shipped_specs(), store=tmp_path / "store",
                               log=lambda m: None)
    assert {name for name, _, _ in rows} >= {"demo-stick-slip", "fig10-small", "fig14-small"}
    warned = [(name, level, est["warnings"] + est.get("grid_warnings", []))
              for name, level, est in rows if est and (est["warnings"] or est.get("grid_warnings"))]
    assert not warned
    compared = {(name, level) for name, level, est in rows if est and "grid_change" in est}
    assert {("demo-stick-slip", "draft"), ("fig14-small", "standard")} <= compared


def test_draft_promise_for_the_elasto_plastic_mean_friction():
    """Measured on specs/demo-stick-slip.toml: draft's F_mean 3.4e-2 off standard at most
    (docs/ACCURACY.md 5.2); every other law and level keeps the target error."""
    from sweeps.spec.accuracy import TARGET_ERROR, promise

    assert promise("draft", "F_mean", "elastoplastic") == 5e-2
    for level in ("standard", "reference"):
        assert promise(level, "F_mean", "elastoplastic") == TARGET_ERROR[level]
    assert promise("draft", "F_mean", "lugre") == TARGET_ERROR["draft"]


def test_draft_promise_for_the_elasto_plastic_near_slip_share():
    """Measured over the whole demo grid (scripts/promise_check.py, docs/ACCURACY.md 5.3):
    draft 1.06e-2 off standard at one of 49 points; promised 2e-2, the other levels and
    laws keep the target error."""
    from sweeps.spec.accuracy import TARGET_ERROR, promise

    assert promise("draft", "near_slip_fraction", "elastoplastic") == 2e-2
    assert promise("standard", "near_slip_fraction", "elastoplastic") == TARGET_ERROR["standard"]
    assert promise("draft", "near_slip_fraction", "lugre") == TARGET_ERROR["draft"]


def test_the_elasto_plastic_reference_level_runs_at_rtol_1e_12():
    """Measured on the error samples of specs/demo-stick-slip.toml and the small fig14
    scenes (docs/ACCURACY.md 5.2): at DP5 rtol 1e-10 the alpha-booked shares were up to
    9.6e-7 off, over reference's 1e-7; at 1e-12 4.5e-8. LuGre's reference is unchanged."""
    from sweeps.spec import parse_spec
    from sweeps.spec.accuracy import numerics

    spec = promise_check.shipped_specs()["demo-stick-slip"]
    ep = parse_spec({**spec, "accuracy": "reference"})
    assert numerics(ep, 1e5).settings.rtol == 1e-12
    assert numerics(ep, 1e5, "standard").settings.rtol == 1e-8
    lugre = parse_spec({**promise_check.shipped_specs()["fig10-small"], "accuracy": "reference"})
    assert numerics(lugre, 1e5).settings.rtol == 1e-10
