"""Dither waveforms, each described by a velocity amplitude W and an angular
frequency omega (rad per unit time), DESIGN.md §1:

==================  =====================================  =========================
kind                how it enters                           paper
==================  =====================================  =========================
none                --                                      Fig. 10(a), 11(a)
square-velocity     u = v + W sq(omega t), sq = sign(sin)   Sec. 5.1, 6; Figs 5-6, 9-10
sine-velocity       u = v + W sin(omega t)                  Sec. 7, Figs. 11-17
sine-force          f = W omega sin(omega t), u = v         Sec. 5.2, Figs. 7, 8
==================  =====================================  =========================

The square wave is discontinuous at t_k = k pi / omega; integrators step onto
those instants and never evaluate across them: within half-period k the wave is
the constant ``square_sign(k)``.
"""
from __future__ import annotations

import math

import numpy as np

from .jit import njit

KINDS = ("none", "square-velocity", "sine-velocity", "sine-force")
NONE, SQUARE_VELOCITY, SINE_VELOCITY, SINE_FORCE = range(4)
CODE = {kind: i for i, kind in enumerate(KINDS)}


@njit(cache=True)
def switch_time(k, omega):
    """k-th switching instant t_k = k pi / omega (exact multiple, no accumulation)."""
    return k * (np.pi / omega)


@njit(cache=True, error_model="numpy", entry=True)
def fixed_step(kind, omega, steps_per_period, h_free):
    """The step of a fixed-step method at dither frequency ``omega``: the square wave's
    half-period ``pi / omega`` or a sine's period ``2 pi / omega`` divided into
    ``steps_per_period`` steps (so steps land on the switches and period ends), else
    ``h_free`` (no dither, or no finite positive omega). ``kind`` is a :data:`CODE`. The
    driver sets each point's step with it (engine.integrators.driver), and the spec-time
    checks size a fixed step with it (sweeps.spec.accuracy, sweeps.spec.fixed_step)."""
    if not omega > 0.0 or not math.isfinite(omega):   # no period to divide
        return h_free
    if kind == SQUARE_VELOCITY:
        return (np.pi / omega) / steps_per_period
    if kind != NONE:
        return (2.0 * np.pi / omega) / steps_per_period
    return h_free


@njit(cache=True)
def square_sign(k):
    """sq(omega t) on half-period k, i.e. for t in (t_k, t_{k+1}): +1 for even k."""
    return 1.0 if k % 2 == 0 else -1.0


def switch_times(omega: float, t_end: float, t_start: float = 0.0) -> np.ndarray:
    """All square-wave switching instants in (t_start, t_end), for plots and tests."""
    k0 = int(np.floor(t_start * omega / np.pi)) + 1
    k1 = int(np.ceil(t_end * omega / np.pi))
    t = np.arange(k0, k1) * (np.pi / omega)
    return t[(t > t_start) & (t < t_end)]
