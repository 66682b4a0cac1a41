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

- ``hunt_amplitude``: half the peak-to-peak of the slow error (with dither: the error's mean
  over each dither period, so that the dither's own ripple, ~W/omega in position, is not
  taken for hunting; without: the error itself, each step's extremes from the quadratic
  through its start, midpoint and end);
- ``hunt_period``: the mean time between upward crossings of the slow error through a band
  ``+-hunt_band`` (a crossing counts once it rose above ``+hunt_band`` after it was below
  ``-hunt_band``); 0 with fewer than two crossings (no hunting);
- ``steady_error``: the RMS of the slow error (Simpson's rule on each step).

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
(S_EMIN, S_EMAX, S_E2, S_ARMED, S_FIRST, S_LAST, S_COUNT, S_E1, S_E1PREV, S_TPREV, S_T2,
 S_SIZE) = range(12)


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
                u += p[P.W] * math.sin(wt)
                hold = p[im] * p[P.W] * p[P.OMEGA] * math.cos(wt)
            elif kind == SINE_FORCE:
                f += p[im] * p[P.W] * p[P.OMEGA] * math.sin(p[P.OMEGA] * t)
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
    """The servo's observables. With dither they read the *slow* error: its average over each
    dither period (the driver stops on the period boundaries), so that the dither's own
    ripple (amplitude ~ W / omega in position) is not taken for hunting; without dither, the
    error itself (each step's extremes from the quadratic through start, midpoint and end)."""
    codes = np.array([tuple(OUTPUTS).index(o) for o in wanted], dtype=np.int64)
    iband = b.ix["hunt_band"]
    dithered = b.scene.dither != "none"

    @b.jit(inline="always", error_model="numpy")
    def crossing(o, e, band, tc):
        """Schmitt trigger on the error: an upward crossing of +band after -band."""
        if e < -band:
            o[S_ARMED] = 1.0
        elif o[S_ARMED] == 1.0 and e > band:
            if o[S_COUNT] == 0.0:
                o[S_FIRST] = tc
            o[S_LAST] = tc
            o[S_COUNT] += 1.0
            o[S_ARMED] = 0.0

    @b.jit(inline="always", error_model="numpy")
    def start(t, y, p, sq, o):
        e = error(t, y, p)
        o[S_EMIN] = np.inf if dithered else e
        o[S_EMAX] = -np.inf if dithered else e
        o[S_E2] = 0.0
        o[S_ARMED] = 1.0 if (e < -p[iband] and not dithered) else 0.0
        o[S_FIRST] = math.nan
        o[S_LAST] = math.nan
        o[S_COUNT] = 0.0
        o[S_E1] = 0.0
        o[S_E1PREV] = 0.0
        o[S_TPREV] = math.nan
        o[S_T2] = 0.0

    @b.jit(inline="always", error_model="numpy")
    def observe(t0, y0, t1, y1, ymid, p, sq, o):
        e0, em, e1 = error(t0, y0, p), error(0.5 * (t0 + t1), ymid, p), error(t1, y1, p)
        h = t1 - t0
        if dithered:   # the period means are taken at the stops
            o[S_E1] += h / 6.0 * (e0 + 4.0 * em + e1)
            return
        o[S_E2] += h / 6.0 * (e0 * e0 + 4.0 * em * em + e1 * e1)
        o[S_T2] += h
        a, bq = 2.0 * (e0 + e1) - 4.0 * em, 4.0 * em - 3.0 * e0 - e1
        lo, hi = min(e0, e1), max(e0, e1)
        if a != 0.0:
            sx = -bq / (2.0 * a)
            if 0.0 < sx < 1.0:
                v = (a * sx + bq) * sx + e0
                lo, hi = min(lo, v), max(hi, v)
        o[S_EMIN] = min(o[S_EMIN], lo)
        o[S_EMAX] = max(o[S_EMAX], hi)
        band = p[iband]
        if lo < -band:
            o[S_ARMED] = 1.0
        if o[S_ARMED] == 1.0 and e1 > band:
            # the upward crossing of +band inside the step, by linear interpolation
            tc = t1 if e1 == e0 else t0 + h * min(max((band - e0) / (e1 - e0), 0.0), 1.0)
            crossing(o, e1, band, tc)

    @b.jit(inline="always", error_model="numpy")
    def stop(t, y, p, is_period, o):
        if not dithered or not is_period:
            return
        if not math.isnan(o[S_TPREV]):
            T = t - o[S_TPREV]
            ebar = (o[S_E1] - o[S_E1PREV]) / T
            o[S_EMIN] = min(o[S_EMIN], ebar)
            o[S_EMAX] = max(o[S_EMAX], ebar)
            o[S_E2] += ebar * ebar * T
            o[S_T2] += T
            crossing(o, ebar, p[iband], t)
        o[S_E1PREV] = o[S_E1]
        o[S_TPREV] = t

    @b.jit(inline="always", error_model="numpy")
    def finish(t, y, p, o, out, span):
        for j in range(codes.size):
            c = codes[j]
            if c == 0:
                out[j] = 0.5 * (o[S_EMAX] - o[S_EMIN]) if o[S_EMAX] >= o[S_EMIN] else 0.0
            elif c == 1:
                out[j] = ((o[S_LAST] - o[S_FIRST]) / (o[S_COUNT] - 1.0)
                          if o[S_COUNT] >= 2.0 else 0.0)
            else:
                out[j] = math.sqrt(max(o[S_E2], 0.0) / o[S_T2]) if o[S_T2] > 0.0 else 0.0

    return SystemOutputs(wanted, S_SIZE, start, observe, finish, stop, dithered)
