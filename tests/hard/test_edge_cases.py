"""Hard cases at the edges of the friction laws (issue 'what accuracy costs', hard-case suite):
no Stribeck effect (fs == fc), a bristle state starting exactly on the elasto-plastic
breakaway z_ba, a zero of the interface velocity exactly at a square-wave switch, and
sticking that lasts the whole run. Each must finish OK, stay finite and bounded
(|z| <= max g / sigma0 = fs / sigma0), and agree with its own run at 100x tighter
tolerance; the whole-run stick is checked against its exact phase shares."""
import numpy as np
import pytest

from engine import Scene, Settings, pack, simulate
from engine import params as P
from engine.params import PAPER_DEFAULTS
from engine.systems.slider import V, Z

TOL = {"rtol": 1e-8, "atol": 1e-11}
FINE = {"rtol": 1e-10, "atol": 1e-13}
OUT = ("v_mean", "F_mean", "v_slow_p2p", "stick_fraction", "max_stick")


def g(u, fc=1.0, fs=1.5):
    """Eq. 2.4 with the paper's vs and delta = 2."""
    return fc + (fs - fc) * np.exp(-(u / PAPER_DEFAULTS["vs"]) ** 2)


def run_pair(scene, p, budget):
    """The case at TOL and at FINE; both must be OK, bounded, within the step budget."""
    runs = [simulate(scene, p, Settings(**tol, max_steps=budget), record=True)
            for tol in (TOL, FINE)]
    fs_over_sigma0 = max(p[P.FS], p[P.FC]) / p[P.SIGMA0]
    for r in runs:
        assert r.status == 0
        assert np.isfinite(r.y).all() and np.isfinite(list(r.outputs.values())).all()
        assert np.abs(r.y[:, Z]).max() <= fs_over_sigma0 * (1 + 1e-9)
        assert r.steps + r.rejected <= budget
    return runs


def agree(coarse, fine, names, rel=1e-5, abs_=1e-7):
    for name in names:
        a, b = coarse.outputs[name], fine.outputs[name]
        assert abs(a - b) <= abs_ + rel * abs(b), (name, a, b)


def test_no_stribeck_effect_fs_equals_fc():
    """fs == fc: the scene is compiled without the Stribeck term (Scene.from_params) and the
    Fig. 10(d) motion still integrates to a converged, bounded answer."""
    p = pack(fs=1.0, fc=1.0, v_ref=0.4, W=0.4, omega=1000.0, t_end=20.0, t_transient=10.0)
    scene = Scene.from_params(p, friction="lugre", dither="square-velocity", outputs=OUT[:3])
    assert not scene.stribeck
    coarse, fine = run_pair(scene, p, budget=200_000)
    agree(coarse, fine, ("v_mean", "F_mean"))


@pytest.mark.long
def test_bristle_state_starting_exactly_at_breakaway():
    """Elasto-plastic z(0) = z_ba(u(0)) = lam g(u) / sigma0 exactly (Eq. 2.6's corner between
    sticking and pre-sliding), sliding at u = v0 = v_ref = 0.1."""
    lam, sigma0, u0 = 0.8, 100.0, 0.1
    z_ba = lam * g(u0) / sigma0
    p = pack(lam=lam, v_ref=u0, v0=u0, z0=z_ba, e0=sigma0 * z_ba, t_end=5.0)
    scene = Scene(friction="elastoplastic", dither="none", slow_force=False, outputs=OUT)
    coarse, fine = run_pair(scene, p, budget=200_000)
    agree(coarse, fine, ("v_mean", "F_mean"))


def test_interface_velocity_zero_exactly_at_a_switch():
    """LuGre at its steady state for u = v + W = 2 W on the first half-period (v = v_ref = W,
    z = z_ss(2W), e = F_ss(2W): every derivative is 0), so v stays exactly W and the switch at
    t_1 = pi / omega makes u = v - W = 0 exactly there: the |u| kink coincides with the
    square-wave discontinuity."""
    W, sigma0, sigma2 = 0.4, 100.0, PAPER_DEFAULTS["sigma2"]
    z_ss = g(2 * W) / sigma0
    p = pack(v_ref=W, W=W, omega=1000.0, v0=W, z0=z_ss, e0=g(2 * W) + sigma2 * 2 * W,
             t_end=2.0)
    scene = Scene(friction="lugre", dither="square-velocity", slow_force=False, outputs=OUT[:3])
    coarse, fine = run_pair(scene, p, budget=200_000)
    t1 = np.pi / 1000.0
    assert t1 in coarse.t                                   # the switch is a step end
    v_before = coarse.y[coarse.t <= t1][:, V]
    assert np.abs(v_before - W).max() < 1e-12               # v == W up to the switch
    agree(coarse, fine, ("v_mean", "F_mean"))


@pytest.mark.long
def test_sticking_for_the_whole_run():
    """Elasto-plastic from rest, v_ref = 1e-3, no slow force, t_end = 10: the spring force
    e <= v_ref t_end = 0.01 never approaches breakaway (lam fs = 1.2), so |z| stays below
    z_ba and alpha == 0 throughout: stick_fraction = 1, max_stick = t_end - t_transient and
    long_stick_fraction = 1 exactly (Eq. 2.6)."""
    p = pack(v_ref=1e-3, t_end=10.0, t_transient=2.0, lam=0.8)
    scene = Scene(friction="elastoplastic", dither="none", slow_force=False,
                  outputs=OUT + ("slip_fraction", "long_stick_fraction"))
    coarse, fine = run_pair(scene, p, budget=200_000)
    for r in (coarse, fine):
        assert r.outputs["stick_fraction"] == 1.0
        assert r.outputs["long_stick_fraction"] == 1.0
        assert r.outputs["slip_fraction"] == 0.0
        assert r.outputs["max_stick"] == pytest.approx(8.0, rel=1e-12)
    agree(coarse, fine, ("v_mean", "F_mean"))


@pytest.mark.long
def test_interface_velocity_hovering_at_zero_does_not_stall():
    """Regression: elasto-plastic slider under sine dither (Fig. 14 grid point W = 1,
    omega = 2000). At tau = 26.4459 u = v + W sin(omega tau) sits at -6.6e-13; a kink
    landing that fell short by round-off was retaken with zero-length steps until the
    step budget ran out (FAILED). A corner within round-off of t is now crossed instead."""
    p = pack(v_ref=0.1, W=1.0, omega=2000.0, lam=0.8, slow_a=1.7, slow_omega=0.3,
             t_end=30.0)
    scene = Scene(friction="elastoplastic", dither="sine-velocity", outputs=("max_stick",))
    r = simulate(scene, p, Settings(rtol=1e-4, atol=1e-7, max_steps=400_000))
    assert r.status == 0 and r.steps + r.rejected < 400_000
    assert np.isfinite(r.outputs["max_stick"])
