"""Parameter vector shared by every engine kernel.

Numba kernels take the physical parameters as one flat ``float64`` array ``p``
indexed by the named constants below (a struct would not cross the njit/Python
boundary as cheaply). :func:`pack` builds it from keywords, with the paper's
Sec. 5.1 set as defaults; the per-point grid values (``W``, ``omega``,
``v_ref``, ``vd``) are written into a copy of it by the batch kernel.

All quantities are non-dimensional (time ``tau``) for the ``slider`` system and
dimensional SI for the ``contact`` system (Sec. 3, Fig. 1), see DESIGN.md §1.
"""
from __future__ import annotations

import numpy as np

# --- friction law (Eqs. 2.3-2.7) -------------------------------------------------
SIGMA0 = 0        # bristle stiffness sigma0
SIGMA1 = 1        # bristle damping scale sigma1_hat (Eq. 2.5)
SIGMA2 = 2        # viscous coefficient sigma2
VS = 3            # Stribeck velocity vs
VD = 4            # bristle-damping velocity vd (Eq. 2.5)
FC = 5            # Coulomb level fc
FS = 6            # static level fs
DELTA = 7         # Stribeck exponent delta (Eq. 2.4)
DELTA_D = 8       # bristle-damping exponent (Eq. 2.5)
LAM = 9           # elasto-plastic breakaway ratio lambda = z_ba / z_ss
# --- excitation ---------------------------------------------------------------
SLOW_A = 10       # slow force amplitude A_s   (f_slow = A_s sin(Omega_s tau))
SLOW_OMEGA = 11   # slow force angular frequency Omega_s
W = 12            # dither velocity amplitude W (contact: v_a)
OMEGA = 13        # dither angular frequency omega, rad per unit time
V_REF = 14        # drive velocity v_ref (contact: v_m)
# --- run window and observable thresholds ------------------------------------
T_END = 15        # end of integration
T_TRANSIENT = 16  # observables accumulate for t >= T_TRANSIENT
LONG_STICK = 17   # a sticking run longer than this is 'long' (DESIGN.md §1)
STICK_BAND = 18   # |u| below this counts as stuck for laws without alpha (Karnopp band)
# --- initial state -----------------------------------------------------------
E0 = 19
V0 = 20
Z0 = 21
# --- elasto-plastic phase thresholds (engine.observables) ----------------------
SLIP_GAP = 22     # sliding: |z| >= (1 - slip_gap) z_ss  (alpha == 1 up to round-off)
ALPHA_NEAR = 23   # near_slip_fraction: share of time with alpha >= alpha_near
N_PARAMS = 24

NAMES = (
    "sigma0", "sigma1", "sigma2", "vs", "vd", "fc", "fs", "delta", "delta_d", "lam",
    "slow_a", "slow_omega", "W", "omega", "v_ref", "t_end", "t_transient",
    "long_stick", "stick_band", "e0", "v0", "z0", "slip_gap", "alpha_near",
)
INDEX = {name: i for i, name in enumerate(NAMES)}
#: The columns of a block's ``points`` (engine.blocks.run_block): the parameters the four
#: axes of a sweep set, in the cube's axis order (the cube and the spec spell vd ``v_d``).
POINT_AXES = ("W", "omega", "v_ref", "vd")

#: The paper's Sec. 5.1 parameter set (non-dimensional), vd = 0.1, no excitation.
PAPER_DEFAULTS = {
    "sigma0": 100.0, "sigma1": 10.0, "sigma2": 0.004, "vs": 0.1, "vd": 0.1,
    "fc": 1.0, "fs": 1.5, "delta": 2.0, "delta_d": 2.0, "lam": 0.8,
    "slow_a": 0.0, "slow_omega": 0.0, "W": 0.0, "omega": 0.0, "v_ref": 0.0,
    "t_end": 100.0, "t_transient": 0.0,
    # Long-duration stick (the paper never defines it): an uninterrupted alpha == 0
    # run longer than 0.5 tau, i.e. > 30 dither periods at omega = 400, while the
    # slow force period 2 pi / 0.3 = 21 tau; see README "Choices".
    "long_stick": 0.5,
    "stick_band": 1e-6,
    "e0": 0.0, "v0": 0.0, "z0": 0.0,
    # Sliding (alpha == 1) is |z| >= z_ss, but a sliding bristle relaxes onto z_ss
    # exponentially, so alpha == 1 holds there only to round-off and a share of exact
    # alpha == 1 is ill-posed (engine.observables). Sliding is |z| within slip_gap
    # (relative) of z_ss; 1e-9 is where alpha rounds to 1.0 in double precision for
    # lam = 0.8 (1 - alpha ~ 31 gap^2 < 2^-53), the reading of DESIGN.md's reference shares.
    "slip_gap": 1e-9,
    # near_slip_fraction: alpha >= 0.9 (crossed transversally: well conditioned)
    "alpha_near": 0.9,
}

#: Sec. 3 / Fig. 1 contact model, SI units (delta = 1 there).
CONTACT_DEFAULTS = {
    **PAPER_DEFAULTS,
    "sigma0": 1e5, "sigma1": 1e3, "sigma2": 0.0, "vs": 1e-3, "vd": 1e-3,
    "fc": 1.0, "fs": 1.5, "delta": 1.0, "delta_d": 2.0,
    "W": 1e-3, "v_ref": 1e-3,
}


def pack(defaults: dict | None = None, **values: float) -> np.ndarray:
    """Return the parameter vector ``p`` (shape ``(N_PARAMS,)``, float64).

    Parameters
    ----------
    defaults
        Base values by name; :data:`PAPER_DEFAULTS` when omitted.
    **values
        Overrides by name (see :data:`NAMES`).
    """
    base = dict(PAPER_DEFAULTS if defaults is None else defaults)
    for name, value in values.items():
        if name not in INDEX:
            raise KeyError(f"unknown parameter {name!r}; known: {', '.join(NAMES)}")
        base[name] = value
    p = np.empty(N_PARAMS)
    for name, i in INDEX.items():
        p[i] = float(base[name])
    return p


def unpack(p: np.ndarray) -> dict[str, float]:
    """Inverse of :func:`pack`: a name -> value dict."""
    return {name: float(p[i]) for name, i in INDEX.items()}
