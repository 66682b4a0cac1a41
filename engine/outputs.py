"""Observable names per analysis path, with CF ``long_name`` and ``units``.

All quantities are non-dimensional for the slider system (force in units of
``k L``, velocity in ``omega_n L``, time in ``tau``) and SI for the contact system.
``units`` are UDUNITS strings (CF): a non-dimensional quantity says ``"1"`` and its
``long_name`` says what it is measured in (e.g. "in units of ... tau").
"""
from __future__ import annotations

SIMULATE = {
    "v_mean": ("mean slider velocity after the transient", "1"),
    "v_slow_p2p": ("peak-to-peak of the dither-period-averaged slider velocity", "1"),
    "F_mean": ("mean friction force after the transient", "1"),
    "stick_fraction": ("fraction of time sticking (alpha == 0)", "1"),
    "presliding_fraction": ("fraction of time pre-sliding (0 < alpha < 1)", "1"),
    "slip_fraction": ("fraction of time sliding (alpha == 1: |z| >= (1 - slip_gap) z_ss)", "1"),
    "long_stick_fraction": ("fraction of time in sticking runs longer than long_stick", "1"),
    "max_stick": ("longest uninterrupted sticking run, in units of the non-dimensional time tau",
                  "1"),
    "near_slip_fraction": ("fraction of time with alpha >= alpha_near", "1"),
    "alpha_hist": ("fraction of time with alpha in each of 10 equal bins of [0, 1]", "1"),
}
# outputs with an extra dimension: name -> (dimension, size)
VECTOR = {"alpha_hist": ("alpha_bin", 10)}
AVERAGED = {
    "F_eff": ("averaged effective friction at slip velocity v_ref", "1"),
    "max_real_eig": ("largest real part of the averaged Jacobian's eigenvalues, per unit of "
                     "the non-dimensional time tau", "1"),
    "stable": ("averaged equilibrium stable (1) or unstable (0)", "1"),
}
HBM = {
    "F_mean": ("mean friction force over one period", "N"),
    "F_min": ("least friction force over one period", "N"),
    "F_max": ("largest friction force over one period", "N"),
    "F_at_vmin": ("friction force at the instant of least velocity", "N"),
    "loop_area": ("closed integral of F dv over one period", "N m/s"),
}
BY_PATH = {"simulate": SIMULATE, "averaged": AVERAGED, "hbm": HBM}


def path_outputs(path: str, system: str = "slider") -> dict:
    """name -> (long_name, units) of every output of ``path`` on ``system``: the simulate
    path adds the system's own observables (engine.contract.MechanicalSystem.outputs,
    e.g. the servo's hunting amplitude)."""
    if path != "simulate":
        return BY_PATH[path]
    from . import registry
    return {**SIMULATE, **(registry.system(system).outputs or {})}


def describe(path: str, name: str, system: str = "slider") -> tuple[str, str]:
    """(long_name, units) of output ``name`` on analysis ``path``."""
    return path_outputs(path, system)[name]
