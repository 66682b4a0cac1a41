"""Trajectory recipes: one slider run through the engine's own API (``engine.api.simulate``),
for the figures that show time histories rather than a sweep (Figs. 6, 8, 10-13, 15-17).

A run is sampled at uniform instants from the integrator's dense output (``record_dt``),
and the interface quantities (``u``, friction ``F``, EP-function ``alpha``) are evaluated at
the samples by the slider's own compiled ``interface`` function, so they are the engine's
numbers, not a re-implementation. Low-pass filtering as in the paper (Secs. 5.1, 7):
an 8th-order Butterworth filter, edge in rad per unit tau, applied forward-backward
(``scipy.signal.sosfiltfilt``: zero phase; the paper's analog filter adds a small delay).
"""
from __future__ import annotations

import functools
import time
from dataclasses import dataclass

import numpy as np

from engine import params as P
from engine.api import simulate
from engine.scene import Scene
from engine.settings import Settings
from engine.systems import slider

#: one output set per friction law, so that every run of a law shares one compiled kernel
EP_OUTPUTS = ("stick_fraction", "presliding_fraction", "near_slip_fraction",
              "long_stick_fraction", "max_stick", "F_mean", "alpha_hist")
LUGRE_OUTPUTS = ("v_mean", "v_slow_p2p", "F_mean")
SETTINGS = Settings(rtol=1e-7, atol=1e-9)     # dopri5, well inside the plotted line widths


@dataclass
class Trajectory:
    """Samples of one run. ``t`` (tau), ``x`` displacement (``v_ref t - e``), ``v`` slider
    velocity, ``u`` interface velocity, ``F`` friction, ``alpha`` EP-function, ``outputs``
    the engine's observables over ``[t_transient, t_end]``, ``alpha_hist`` its 10-bin time
    shares, ``steps`` accepted steps, ``wall`` seconds."""

    t: np.ndarray
    x: np.ndarray
    v: np.ndarray
    u: np.ndarray
    F: np.ndarray
    alpha: np.ndarray
    outputs: dict
    alpha_hist: np.ndarray | None
    steps: int
    status: int
    wall: float


def run(*, friction: str = "elastoplastic", dither: str = "sine-velocity", W: float = 0.0,
        omega: float = 100.0, v_ref: float = 0.1, slow=(1.7, 0.3), vd: float = 0.1,
        lam: float = 0.8, t_end: float = 100.0, t_transient: float = 0.0,
        dt: float | None = None, settings: Settings = SETTINGS, model: tuple = ()) -> Trajectory:
    """One slider trajectory from rest, sampled every ``dt`` (default: 16 samples per
    dither period, or 0.01 tau without dither).

    ``dither = "none"`` is used whenever ``W == 0`` (no dither, whatever the kind).
    ``model``: (name, value) overrides of a deliberately wrong model (Context.run_model;
    ``W_scale`` multiplies W).
    """
    over = dict(model)
    W = W * float(over.pop("W_scale", 1.0))
    if W == 0.0:
        dither = "none"
    if dt is None:
        dt = 2 * np.pi / omega / 16 if dither != "none" else 0.01
    p = P.pack(**{"W": W, "omega": omega if dither != "none" else 0.0, "v_ref": v_ref,
                  "slow_a": slow[0], "slow_omega": slow[1], "vd": vd, "lam": lam,
                  "t_end": t_end, "t_transient": t_transient, **over})
    outputs = EP_OUTPUTS if friction == "elastoplastic" else LUGRE_OUTPUTS
    scene = Scene.from_params(p, friction=friction, dither=dither, integrator="dopri5",
                              outputs=outputs)
    n = int(t_end / dt) + 2
    t0 = time.perf_counter()
    sim = simulate(scene, p, settings, record_dt=dt, max_records=n)
    wall = time.perf_counter() - t0
    u, F, alpha = interface_samples(scene, p, sim.t, sim.y, omega)
    return Trajectory(t=sim.t, x=v_ref * sim.t - sim.y[:, slider.E], v=sim.y[:, slider.V],
                      u=u, F=F, alpha=alpha, outputs=sim.outputs, alpha_hist=sim.alpha_hist,
                      steps=sim.steps, status=sim.status, wall=wall)


def interface_samples(scene, p, t, y, omega):
    """``(u, F, alpha)`` at the recorded states, by the slider's interface function.

    The square wave's sign at ``t`` is that of the half-period containing it (the left
    limit at a switch instant)."""
    if scene.dither == "square-velocity":
        k = np.ceil(t * omega / np.pi - 1e-9) - 1
        sq = np.where(k % 2 == 0, 1.0, -1.0)
    else:
        sq = np.ones_like(t)
    out = np.empty((t.size, 3))
    _loop(scene)(t, np.ascontiguousarray(y), p, sq, out)
    return out[:, 0], out[:, 1], out[:, 2]


@functools.lru_cache(maxsize=None)
def _loop(scene):
    from engine.jit import njit

    interface = slider.make_interface(scene)

    @njit(entry=True)
    def loop(t, y, p, sq, out):
        for i in range(t.size):
            u, F, a = interface(t[i], y[i], p, sq[i])
            out[i, 0], out[i, 1], out[i, 2] = u, F, a
    return loop


def lowpass(x, dt: float, edge: float = 500.0, order: int = 8):
    """Zero-phase Butterworth low-pass of samples ``x`` spaced ``dt`` (tau), ``edge`` in rad
    per unit tau (Secs. 5.1, 5.2: order 8, edge 500). An edge at or above the samples'
    Nyquist frequency returns ``x`` unchanged."""
    from scipy.signal import butter, sosfiltfilt

    fs = 2 * np.pi / dt                    # rad per unit tau
    if edge >= 0.5 * fs:
        return np.asarray(x, dtype=float)
    return sosfiltfilt(butter(order, edge, fs=fs, output="sos"), x)


def stick_runs(t, alpha):
    """Lengths (tau) of the uninterrupted ``alpha == 0`` runs of a sampled trajectory."""
    stuck = np.r_[False, alpha == 0.0, False]
    edges = np.flatnonzero(np.diff(stuck.astype(int)))
    starts, ends = edges[::2], edges[1::2] - 1
    return t[ends] - t[starts]


@functools.lru_cache(maxsize=32)
def cached_run(**kw) -> Trajectory:
    """:func:`run`, remembered per process (Figs. 11 and 12, 16 and 17 share their runs)."""
    return run(**kw)


def sec7(ctx) -> dict:
    """The Sec. 7 parameters, read from the fig14 scene (specs/fig14.toml, one source):
    ``v_ref``, ``vd``, ``lam``, ``slow`` (amplitude, omega) and ``t_end``."""
    spec = ctx.spec("fig14")
    params, grid = spec.get("params", {}), spec["grid"]
    slow = params.get("slow_force", {"amplitude": 0.0, "omega": 0.0})
    return {"v_ref": float(grid["v_ref"][0]), "vd": float(grid["v_d"][0]),
            "lam": float(params.get("lam", 0.8)),
            "slow": (float(slow["amplitude"]), float(slow["omega"])),
            "t_end": float(spec["time"]["t_end"])}
