"""Agreement with an independent integration: scipy DOP853 (rtol 1e-12, atol 1e-14)
restarted at every square-wave switch and at every kink, on the equations re-typed from
DESIGN.md §1 (tests/engine/reference.py), for every friction law and every dither kind.

The static laws are compared in the sliding regime (u stays away from 0, so the Eq. 2.2
branch alone applies), and, without dither, through stick-slip against an exact-sticking
hybrid automaton: the engine's Karnopp band (width stick_band = 1e-6) must agree to
O(band) -- the first stick lasts exactly fs / v_ref (the spring force e = v_ref t reaches
the break-away level fs).
"""
import numpy as np
import pytest

from engine import params as P
from engine.api import simulate
from engine.settings import Settings
from tests.engine import reference as R
from tests.engine.common import ALL, scene
from tests.engine.gpu_cases import SHARED as GPU_SHARED

T_END = 2.0
SLOW = {"slow_a": 1.7, "slow_omega": 0.3}   # Sec. 7 slow force
CASES = [
    # law, dither, parameters, initial (e, v, z)
    ("lugre", "none", {"v_ref": 0.4}, (0, 0, 0)),
    ("lugre", "square-velocity", {"v_ref": 0.4, "W": 0.3, "omega": 100.0}, (0, 0, 0)),
    ("lugre", "sine-velocity", {"v_ref": 0.4, "W": 0.3, "omega": 100.0}, (0, 0, 0)),
    ("lugre", "sine-force", {"v_ref": 0.4, "W": 0.3, "omega": 100.0}, (0, 0, 0)),
    ("elastoplastic", "none", dict(v_ref=0.1, **SLOW), (0, 0, 0)),
    ("elastoplastic", "square-velocity", dict(v_ref=0.1, W=0.5, omega=100.0, **SLOW), (0, 0, 0)),
    ("elastoplastic", "sine-velocity", dict(v_ref=0.1, W=1.5, omega=100.0, **SLOW), (0, 0, 0)),
    ("elastoplastic", "sine-force", dict(v_ref=0.1, W=0.5, omega=100.0, **SLOW), (0, 0, 0)),
    ("stribeck", "square-velocity", {"v_ref": 0.5, "W": 0.2, "omega": 100.0}, (1.2, 0.5, 0)),
    ("stribeck", "sine-force", {"v_ref": 0.5, "W": 0.2, "omega": 100.0}, (1.2, 0.5, 0)),
    ("coulomb", "sine-velocity", {"v_ref": 0.5, "W": 0.2, "omega": 100.0}, (1.0, 0.5, 0)),
    ("coulomb", "none", {"v_ref": 0.5}, (1.0, 0.5, 0)),
]


# The scenes tests/engine/test_gpu.py (and the batch tests) compile too keep every output:
# one kernel for both. The others compile only what is compared here: compiling an
# elasto-plastic scene took 17-19 s with every output, 10-13 s with F_mean alone (its
# phase bookkeeping; measured in fresh caches), and this module is mostly compiling.
# (Taking every output for the four scenes test_engine_observables.py and
# test_engine_paper_figures.py simulate too was measured and dropped: in two CI runs this
# module took 53-59 s more, those two 46 s less; the three 287-292 s, without 281-287 s.)
SHARED = {(c.get("friction", "lugre"), c.get("dither", "square-velocity"))
          for c in GPU_SHARED.values() if c.get("integrator", "dopri5") == "dopri5"}

STATIC = ("stribeck", "coulomb")


def _outputs(law, dither):
    if (law, dither) in SHARED:
        return ALL
    # the static laws' scenes without dither serve both tests below
    return ("F_mean", "stick_fraction", "max_stick") if law in STATIC else ("F_mean",)


@pytest.mark.long
@pytest.mark.parametrize("law,dither,kw,y0", CASES, ids=[f"{c[0]}-{c[1]}" for c in CASES])
def test_matches_dop853(law, dither, kw, y0):
    p = P.pack(t_end=T_END, e0=y0[0], v0=y0[1], z0=y0[2], **kw)
    ref = R.slider(P.unpack(p), law, dither, y0, T_END)
    sc = scene(law, dither, slow="slow_a" in kw, outputs=_outputs(law, dither))
    r = simulate(sc, p, Settings(rtol=1e-10, atol=1e-12), record=True)
    assert r.status == 0
    if law in STATIC:                        # sliding regime: |u| stays clear of the band
        u_min = np.abs(r.y[:, 1]).min() - kw.get("W", 0.0)
        assert u_min > 0.05
    err = np.abs(r.y_end[:3] - ref[:3]) * [1.0, 1.0, p[P.SIGMA0]]   # z in units of fc/sigma0
    assert err.max() < 1e-8, err
    assert abs(r.outputs["F_mean"] - ref[3] / T_END) < 1e-8


@pytest.mark.long
@pytest.mark.parametrize("law", ["stribeck", "coulomb"])
def test_static_law_stick_slip_matches_exact_sticking(law):
    t_end, band = 40.0, 1e-6
    p = P.pack(t_end=t_end, v_ref=0.1, stick_band=band, long_stick=1.0)
    (e, v), sticks = R.static_stick_slip(P.unpack(p), law, t_end)
    r = simulate(scene(law, "none", outputs=_outputs(law, "none")), p,
                 Settings(rtol=1e-10, atol=1e-12))
    assert r.status == 0
    # O(band): the engine sticks at |v| = band, not 0, so e drifts by band * stick time
    assert abs(r.y_end[0] - e) < 10 * band * t_end and abs(r.y_end[1] - v) < 2 * band
    stick_time = sum(min(b, t_end) - a for a, b in sticks)
    assert abs(r.outputs["stick_fraction"] - stick_time / t_end) < 1e-6
    fs = p[P.FS] if law == "stribeck" else p[P.FC]
    assert sticks[0] == (0.0, pytest.approx(fs / 0.1, rel=1e-12))
    assert r.outputs["max_stick"] == pytest.approx(max(b - a for a, b in sticks), abs=1e-6)
