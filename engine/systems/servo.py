"""A position servo with PID control and friction (issue 35), through the model contract.

State ``y = (x, v, xi)``: position, velocity, the integral of the tracking error
``e = x_r(t) - x`` with ``x_r(t) = x_ref + v_ref t`` (``v_ref = 0``: positioning). With the
actuator force ``f = kp e - kd v + ki xi``:

    dx/dt  = v
    m dv/dt = f - F(u, z) + f_dither
    dxi/dt = x_r(t) - x

Dither as on the slider: ``square-velocity`` / ``sine-velocity`` add ``W sq(omega t)`` /
``W sin(omega t)`` to the interface velocity ``u = v + ...``; ``sine-force`` adds
``f_dither = m W omega sin(omega t)`` to the actuator force (a velocity amplitude ``W`` of
the free mass, as the slider's ``W omega sin``). The stick-holding force of the static laws
is ``f + f_dither`` (+ ``m W omega cos(omega t)`` with sine-velocity dither).

Friction with integral action hunts: the mass sticks short of the target, the integral
builds the force until it breaks away, overshoots and sticks on the other side -- a limit
cycle. Dither can quench it. Outputs of its own (over ``[t_transient, t_end]``):

- ``hunt_amplitude``: half the peak-to-peak of the error ``e`` (each step's extremes from the
  quadratic through its start, midpoint and end);
- ``hunt_period``: the mean time between upward crossings of ``e`` through a band
  ``+-hunt_band`` (a crossing counts once ``e`` rose above ``+hunt_band`` after it was below
  ``-hunt_band``, so that the dither's ripple about a settled error is not counted); 0 with
  fewer than two crossings (no hunting);
- ``steady_error``: the RMS of ``e`` (Simpson's rule on each step).

Spec: ``system = "servo"``, ``[params] servo = { m, kp, ki, kd, x_ref, hunt_band }``.
"""
from __future__ import annotations

import math

import numpy as np

from .. import params as P
from ..contract import MechanicalSystem, Param, SystemKernels, SystemOutputs
from ..dither import CODE, SINE_FORCE, SINE_VELOCITY, SQUARE_VELOCITY

X, V, XI = 0, 1, 2
OUTPUTS = {
    "hunt_amplitude": ("half the peak-to-peak of the servo's tracking error after the transient",
                       "1"),
    "hunt_period": ("mean period of the servo's hunting (upward crossings of the error band), "
                    "in units of the time of the spec", "1"),
    "steady_error": ("RMS of the servo's tracking error after the transient", "1"),
}
# accumulator slots of the servo's outputs
S_EMIN, S_EMAX, S_E2, S_ARMED, S_FIRST, S_LAST, S_COUNT, S_SIZE = range(8)


class Servo(MechanicalSystem):
    name = "servo"
    group = "servo"
    state_names = ("x", "v", "xi")
    outputs = OUTPUTS
    defaults = P.PAPER_DEFAULTS
    params = {
        "m": Param(1.0, "1", "moving mass", lo=0.0, lo_open=True),
        "kp": Param(1.0, "1", "proportional gain (force per position)", lo=0.0),
        "ki": Param(0.5, "1", "integral gain (force per position-time)", lo=0.0),
        "kd": Param(1.0, "1", "derivative gain (force per velocity)", lo=0.0),
        "x_ref": Param(1.0, "1", "target position (the reference ramps at v_ref)"),
        "hunt_band": Param(1e-3, "1", "error band of a hunting crossing (hunt_period)",
                           lo=0.0, lo_open=True),
    }

    def build(self, b):
        kind = CODE[b.scene.dither]
        ix = b.ix
        im, ikp, iki, ikd, ixr = ix["m"], ix["kp"], ix["ki"], ix["kd"], ix["x_ref"]

        @b.jit(inline="always", error_model="numpy")
        def error(t, y, p):
            return p[ixr] + p[P.V_REF] * t - y[X]

        @b.jit(inline="always", error_model="numpy")
        def drive(t, y, p, sq):
            f = p[ikp] * error(t, y, p) - p[ikd] * y[V] + p[iki] * y[XI]
            u = y[V]
            hold = 0.0
            if kind == SQUARE_VELOCITY:
                u += p[P.W] * sq
            elif kind == SINE_VELOCITY:
                wt = p[P.OMEGA] * t
                u += p[P.W] * np.sin(wt)
                hold = p[im] * p[P.W] * p[P.OMEGA] * np.cos(wt)
            elif kind == SINE_FORCE:
                f += p[im] * p[P.W] * p[P.OMEGA] * np.sin(p[P.OMEGA] * t)
            return u, f, f + hold

        @b.jit(inline="always", error_model="numpy")
        def dynamics(t, y, p, sq, u, f, F, dy):
            dy[X] = y[V]
            dy[V] = (f - F) / p[im]
            dy[XI] = error(t, y, p)

        @b.jit(inline="always", error_model="numpy")
        def position(t, y, p):
            return y[X]

        @b.jit(inline="always", error_model="numpy")
        def velocity(t, y, p, sq):
            return y[V]

        @b.jit(inline="always", error_model="numpy")
        def init(p, y):
            y[X], y[V] = p[P.E0], p[P.V0]

        @b.jit(inline="always", error_model="numpy")
        def scales(p, out):
            """``x ~ max(|x_ref|, fc / kp)``, ``v ~ max(|v_ref|, W)``, ``xi ~ x t``-ish:
            the position scale (1 when all vanish)."""
            xs = max(abs(p[ixr]), abs(p[P.FC]) / p[ikp] if p[ikp] > 0.0 else 0.0)
            vs = max(abs(p[P.V_REF]), abs(p[P.W]))
            out[X] = xs if xs > 0.0 else 1.0
            out[V] = vs if vs > 0.0 else 1.0
            out[XI] = out[X]

        wanted = tuple(o for o in b.scene.outputs if o in OUTPUTS)
        outputs = _outputs(b, wanted, error) if wanted else None
        return SystemKernels(drive, dynamics, position, velocity, init, scales, outputs)


def _outputs(b, wanted, error):
    codes = np.array([tuple(OUTPUTS).index(o) for o in wanted], dtype=np.int64)
    iband = b.ix["hunt_band"]

    @b.jit(inline="always", error_model="numpy")
    def start(t, y, p, sq, o):
        e = error(t, y, p)
        o[S_EMIN] = e
        o[S_EMAX] = e
        o[S_E2] = 0.0
        o[S_ARMED] = 1.0 if e < -p[iband] else 0.0
        o[S_FIRST] = math.nan
        o[S_LAST] = math.nan
        o[S_COUNT] = 0.0

    @b.jit(inline="always", error_model="numpy")
    def observe(t0, y0, t1, y1, ymid, p, sq, o):
        e0, em, e1 = error(t0, y0, p), error(0.5 * (t0 + t1), ymid, p), error(t1, y1, p)
        h = t1 - t0
        o[S_E2] += h / 6.0 * (e0 * e0 + 4.0 * em * em + e1 * e1)
        a, bq = 2.0 * (e0 + e1) - 4.0 * em, 4.0 * em - 3.0 * e0 - e1
        lo, hi = min(e0, e1), max(e0, e1)
        if a != 0.0:
            s = -bq / (2.0 * a)
            if 0.0 < s < 1.0:
                v = (a * s + bq) * s + e0
                lo, hi = min(lo, v), max(hi, v)
        o[S_EMIN] = min(o[S_EMIN], lo)
        o[S_EMAX] = max(o[S_EMAX], hi)
        band = p[iband]
        if lo < -band:
            o[S_ARMED] = 1.0
        if o[S_ARMED] == 1.0 and e1 > band:
            # the upward crossing of +band inside the step, by linear interpolation
            tc = t1 if e1 == e0 else t0 + h * min(max((band - e0) / (e1 - e0), 0.0), 1.0)
            if o[S_COUNT] == 0.0:
                o[S_FIRST] = tc
            o[S_LAST] = tc
            o[S_COUNT] += 1.0
            o[S_ARMED] = 0.0

    @b.jit(inline="always", error_model="numpy")
    def finish(t, y, p, o, out, span):
        for j in range(codes.size):
            c = codes[j]
            if c == 0:
                out[j] = 0.5 * (o[S_EMAX] - o[S_EMIN])
            elif c == 1:
                out[j] = ((o[S_LAST] - o[S_FIRST]) / (o[S_COUNT] - 1.0)
                          if o[S_COUNT] >= 2.0 else 0.0)
            else:
                out[j] = math.sqrt(max(o[S_E2], 0.0) / span)

    return SystemOutputs(wanted, S_SIZE, start, observe, finish)
