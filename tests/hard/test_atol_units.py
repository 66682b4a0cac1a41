"""Per-component absolute tolerances (``Settings(atol_units="natural")``).

At sigma0 = 1e6 the bristle deflection is z ~ fc / sigma0 = 1e-6 while the spring force is
e ~ 1: one absolute ``atol`` small enough for ``e`` leaves ``z`` uncontrolled. The natural
units scale it per component (``z`` by ``fc / sigma0``) and restore tolerance-proportional
accuracy. Reference: scipy Radau, rtol 1e-11, restarted at every switch
(tests/hard/references.json, scripts/reference_engine.py); errors in anchor units.

Measured (RODAS, sigma0 = 1e6, rtol 1e-4 / 1e-6 / 1e-8, atol = 1e-2 rtol): absolute
2.5e-3 / 6.6e-5 / 4.9e-6, natural 2.6e-6 / 1.9e-8 / 3.5e-10.
"""
from __future__ import annotations

import numpy as np
import pytest

from engine import params as P
from engine.api import simulate
from engine.kernels import make_config
from engine.scene import Scene
from tests.engine.common import scene as common_scene
from engine.settings import Settings
from engine.systems import make_system

from .hardcases import REFS, error_units, run


@pytest.mark.long
@pytest.mark.parametrize("rtol", [1e-4, 1e-6])
def test_natural_units_control_the_stiff_bristle(rtol):
    c, q_ref = REFS["sigma0_1e6"]["params"], np.array(REFS["sigma0_1e6"]["q"])
    absolute = error_units(run(c, "rodas4", rtol, 2_000_000, atol_units="absolute").q, q_ref, c)
    natural = error_units(run(c, "rodas4", rtol, 2_000_000, atol_units="natural").q, q_ref, c)
    assert natural <= 0.1 * rtol, natural
    assert absolute > 100 * natural, (absolute, natural)


def test_natural_scales_of_the_slider():
    """e ~ fc, v ~ max(|v_ref|, W), z ~ fc / sigma0 (engine.systems.slider.make_scales)."""
    system = make_system(Scene())
    out = np.zeros(3)
    system.scales(P.pack(fc=2.0, sigma0=1e6, v_ref=1e-6, W=0.0), out)
    np.testing.assert_allclose(out, [2.0, 1e-6, 2e-6])
    system.scales(P.pack(v_ref=0.1, W=0.4), out)
    assert out[1] == 0.4


@pytest.mark.long
def test_absolute_units_keep_one_atol_and_bad_units_are_refused():
    cfg = make_config(Settings(atol=3e-9))
    assert (cfg[0]["atol_i"][:3] == 3e-9).all()
    with pytest.raises(ValueError, match="atol_units"):
        Settings(atol_units="relative")
    sim = simulate(common_scene(), P.pack(t_end=1.0, v_ref=0.4, W=0.4, omega=1e3),  # (the
                   Settings(atol_units="natural"))   # engine tests' scene: compiled once for all)
    assert sim.status == 0
