"""Entry point of the analysis paths for the batch layer (engine.blocks.run_block).

``analysis_block(scene, points, p)`` evaluates a block of grid points without time
integration:

* ``scene.path == "averaged"`` (slider, Secs. 5-6): ``F_eff`` = effective friction at
  slip velocity ``v_ref`` (Eq. 5.9 for LuGre; Eq. 5.14 for the static ``stribeck`` /
  ``coulomb`` laws), ``max_real_eig`` of the averaged Jacobian (Eqs. 6.4-6.7; for a
  static law the (e, v) system ``J = [[0, -1], [1, -F']]``; for a law that declares its
  steady-state curve -- Dahl, GMS, a user's -- its phase average, engine.analysis.steady),
  ``stable`` = 1.0 when
  ``max_real_eig < 0`` else 0.0. **omega is ignored**: averaging is the
  ``omega -> infinity`` limit. Dither ``none`` sets W = 0; ``sine-force`` uses the sine
  rule with velocity amplitude W (engine.analysis.quadrature).
* ``scene.path == "hbm"`` (contact, Sec. 3): harmonic balance with ``v_m = v_ref``,
  ``v_a = W`` (dither ``sine-velocity``; ``none`` sets v_a = 0), outputs
  ``F_mean, F_min, F_max, F_at_vmin, loop_area`` (engine.analysis.hbm).

Scene-level mistakes (wrong system/friction/dither for the path, unknown output) raise
ValueError naming the field; a bad point never raises: its status says what happened
(engine.status: OK, FAILED = HBM not converged or omega <= 0, NON_FINITE).
"""
from __future__ import annotations

import numpy as np

from .. import outputs as OUT
from .. import params as P
from .. import status as ST
from .effective import effective_friction
from .hbm import contact_hbm
from .quadrature import N_QUAD
from .stability import linearisation, static_max_real_eig

#: Columns of ``points`` (engine.params.POINT_AXES) and the parameters they override.
POINT_AXES = P.POINT_AXES
_AVERAGED_LAWS = ("lugre", "stribeck", "coulomb")
#: Default relative tolerance of the harmonic balance on the friction samples.
HBM_RTOL = 1e-6


def _requested(scene) -> tuple[str, ...]:
    known = OUT.BY_PATH[scene.path]
    names = tuple(scene.outputs) or tuple(known)
    bad = [n for n in names if n not in known]
    if bad:
        raise ValueError(f"scene.outputs: {bad} are not outputs of the {scene.path!r} path; "
                         f"choose from {tuple(known)}")
    return names


def _check(scene, field, value, allowed, hint):
    if value not in allowed:
        raise ValueError(f"scene.{field}: the {scene.path!r} path needs one of {allowed}, "
                         f"got {value!r}; {hint}")


def _effective_p(scene, p) -> np.ndarray:
    """Copy of p with the effects the scene switches off set to zero."""
    q = np.array(p, dtype=np.float64, copy=True)
    if not scene.stribeck or scene.friction == "coulomb":
        q[P.FS] = q[P.FC]
    if not scene.bristle_damping:
        q[P.SIGMA1] = 0.0
    if not scene.viscous:
        q[P.SIGMA2] = 0.0
    return q


def _averaged(scene, W, v_ref, vd, p, n_quad, side):
    _check(scene, "system", scene.system, ("slider",), "use path='hbm' for 'contact'")
    if scene.dither == "none":
        W = np.zeros_like(W)
    if scene.friction not in _AVERAGED_LAWS + ("elastoplastic",):
        # a law with a declared steady-state curve (Dahl, GMS, a user's): engine.analysis.steady
        from .steady import steady_effective

        F, dF = steady_effective(scene, v_ref, W, p, n_quad)
        lam = static_max_real_eig(dF)
        stable = np.where(np.isnan(lam), np.nan, (lam < 0).astype(float))
        return {"F_eff": F, "max_real_eig": lam, "stable": stable}, \
            np.full(W.size, ST.OK, np.int8)
    _check(scene, "friction", scene.friction, _AVERAGED_LAWS,
           "the elasto-plastic law has no averaged model: use a time integrator")
    if scene.friction == "lugre":
        _J, F, lam = linearisation(v_ref, W, p, dither=scene.dither, vd=vd, n_quad=n_quad,
                                   side=side)
    else:
        F, dF = effective_friction(v_ref, W, p, dither=scene.dither, model="static", vd=vd,
                                   n_quad=n_quad, side=side, slope=True)
        lam = static_max_real_eig(dF)
    stable = np.where(np.isnan(lam), np.nan, (lam < 0).astype(float))
    return {"F_eff": F, "max_real_eig": lam, "stable": stable}, np.full(W.size, ST.OK, np.int8)


def _hbm(scene, W, omega, v_ref, vd, p, rtol):
    _check(scene, "system", scene.system, ("contact",), "use path='averaged' for 'slider'")
    _check(scene, "friction", scene.friction, ("lugre",), "harmonic balance is for LuGre")
    _check(scene, "dither", scene.dither, ("sine-velocity", "none"),
           "the contact model's velocity is v_m + v_a cos(omega t)")
    names = tuple(OUT.HBM)
    out = {k: np.full(W.size, np.nan) for k in names}
    status = np.full(W.size, ST.FAILED, np.int8)
    q = p.copy()
    for i in range(W.size):
        v_a = 0.0 if scene.dither == "none" else W[i]
        if not omega[i] > 0:
            continue
        q[P.VD] = vd[i]
        r = contact_hbm(v_ref[i], v_a, omega[i], q, rtol=rtol)
        status[i] = r.status
        if r.status == ST.OK:        # an unconverged loop is not reported
            for k, val in r.loop(omega[i], v_a).items():
                out[k][i] = val
    return out, status


def analysis_block(scene, points, p, *, n_quad=N_QUAD, side=1.0, hbm_rtol=HBM_RTOL):
    """Evaluate a block of grid points on an analysis path (module docstring).

    Parameters
    ----------
    scene : engine.scene.Scene
        ``scene.path`` is ``"averaged"`` or ``"hbm"``; ``scene.outputs`` the requested
        names (all of the path's outputs if empty).
    points : (n, 4) float64 array
        Columns W, omega, v_ref, vd, overriding ``p[W], p[OMEGA], p[V_REF], p[VD]``.
    p : (N_PARAMS,) float64 array
        Parameter vector (engine.params).
    n_quad, side
        Sine quadrature points per piece and the one-sided Jacobian at the square-wave
        kink ``W = v_ref`` (see engine.analysis.stability).
    hbm_rtol : float
        Relative convergence tolerance of the harmonic balance on F (engine.analysis.hbm);
        with velocity reversal (W > v_ref) convergence is algebraic and H_max = 1024
        reaches about 1e-6.

    Returns
    -------
    outputs : dict name -> (n,) float64, exactly the requested names
    status : (n,) int8 engine.status codes
    """
    if scene.path not in ("averaged", "hbm"):
        raise ValueError(f"scene.path: analysis_block needs 'averaged' or 'hbm', "
                         f"got {scene.path!r}; time integration is engine.blocks.run_block")
    names = _requested(scene)
    pts = np.asarray(points, dtype=np.float64)
    if pts.ndim != 2 or pts.shape[1] != 4:
        raise ValueError(f"points: expected shape (n, 4) with columns {POINT_AXES}, got {pts.shape}")
    W, omega, v_ref, vd = (np.ascontiguousarray(pts[:, j]) for j in range(4))
    q = _effective_p(scene, p)
    if scene.path == "averaged":
        res, status = _averaged(scene, W, v_ref, vd, q, n_quad, side)
    else:
        res, status = _hbm(scene, W, omega, v_ref, vd, q, hbm_rtol)
    out = {k: np.asarray(res[k], dtype=np.float64) for k in names}
    bad = ~np.all([np.isfinite(out[k]) for k in names], axis=0) & (status == ST.OK)
    status[bad] = ST.NON_FINITE
    return out, status
