"""analysis_block: the batch layer's entry point for the 'averaged' and 'hbm' paths
(docs/ARCHITECTURE.md), its outputs (engine/outputs.py), status codes and messages."""
import numpy as np
import pytest

from engine import params as P
from engine import status as ST
from engine.analysis import analysis_block, contact_hbm, effective_friction, jacobian, max_real_eig
from engine.analysis.block import HBM_RTOL
from engine.scene import Scene

PAPER = P.pack()
PC = P.pack(P.CONTACT_DEFAULTS)
AVG = Scene(path="averaged", dither="square-velocity", outputs=("F_eff", "max_real_eig", "stable"))


def test_averaged_block_matches_direct_calls_and_ignores_omega():
    """Columns W, omega, v_ref, vd; omega plays no role (omega -> infinity limit)."""
    pts = np.array([[0.5, 1e3, 0.2, 0.1], [0.5, 10.0, 0.2, 0.1], [0.1, 1e3, 0.25, 0.01]])
    out, status = analysis_block(AVG, pts, PAPER)
    assert set(out) == {"F_eff", "max_real_eig", "stable"} and status.dtype == np.int8
    assert np.all(status == ST.OK)
    J, F = jacobian(pts[:, 2], pts[:, 0], PAPER, vd=pts[:, 3])
    lam = max_real_eig(J)
    assert np.array_equal(out["F_eff"], F) and np.array_equal(out["max_real_eig"], lam)
    assert out["F_eff"][0] == out["F_eff"][1]
    assert np.array_equal(out["stable"], (lam < 0).astype(float))


def test_averaged_sine_and_static_paths():
    pts = np.array([[0.5, 1e3, 0.2, 0.1]])
    out, _ = analysis_block(AVG.with_(dither="sine-velocity", outputs=("F_eff",)), pts, PAPER)
    assert out["F_eff"][0] == effective_friction(0.2, 0.5, PAPER, dither="sine-velocity")
    out, _ = analysis_block(AVG.with_(friction="stribeck"), pts, PAPER)
    F, dF = effective_friction(0.2, 0.5, PAPER, model="static", slope=True)
    assert out["F_eff"][0] == F and out["stable"][0] == float(dF > 0)


def test_non_finite_point_gets_its_status():
    """v_ref = W = 0: the slow manifold v / A is 0/0."""
    out, status = analysis_block(AVG, np.array([[0.0, 1.0, 0.0, 0.1], [0.3, 1.0, 0.1, 0.1]]), PAPER)
    assert status.tolist() == [ST.NON_FINITE, ST.OK] and np.isnan(out["F_eff"][0])


def test_hbm_block_matches_contact_hbm():
    scene = Scene(system="contact", path="hbm", dither="sine-velocity")
    pts = np.array([[1e-3, 100.0, 1e-3, 1e-3], [1e-3, 0.0, 1e-3, 1e-3]])
    out, status = analysis_block(scene, pts, PC)
    assert set(out) == {"F_mean", "F_min", "F_max", "F_at_vmin", "loop_area"}
    assert status.tolist() == [ST.OK, ST.FAILED]
    ref = contact_hbm(1e-3, 1e-3, 100.0, PC, rtol=HBM_RTOL).loop(100.0, 1e-3)
    assert all(out[k][0] == ref[k] for k in ref) and np.isnan(out["F_mean"][1])


@pytest.mark.parametrize("scene, match", [
    (Scene(integrator="dopri5"), "scene.path: analysis_block needs"),
    (Scene(path="averaged", outputs=("v_mean",)), "scene.outputs: \\['v_mean'\\] are not outputs"),
    (Scene(path="averaged", friction="elastoplastic"), "scene.friction: .* elasto-plastic law has no averaged"),
    (Scene(path="averaged", system="contact"), "scene.system: .*use path='hbm'"),
    (Scene(path="hbm"), "scene.system: .*use path='averaged'"),
    (Scene(system="contact", path="hbm", dither="square-velocity"), "scene.dither: the 'hbm' path needs"),
])
def test_scene_errors_name_the_field(scene, match):
    with pytest.raises(ValueError, match=match):
        analysis_block(scene, np.zeros((1, 4)), PAPER)


def test_points_shape_error():
    with pytest.raises(ValueError, match=r"points: expected shape \(n, 4\)"):
        analysis_block(AVG, np.zeros((3, 3)), PAPER)
