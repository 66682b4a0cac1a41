"""Independent high-accuracy elasto-plastic phase shares of the Sec. 7 slider (test references).

Run: ``.venv/bin/python scripts/reference_phases.py [CASE ... | all] [--list] [--radau]
[--rtols COARSE FINE] [--no-write]`` writes ``tests/hard/phase_references.json`` (merging with the
cases already there). Default cases: ``undithered`` (window [0, 100]) and ``sine_W1_w300``
(sine-velocity W = 1, omega = 300, window [20, 100]): ~8 min of CPU together on one core
(18 min wall on the shared, loaded 2-core machine of the stored run; the JSON's ``seconds``
are wall times); ``sine_W0.5_w1000`` (W = 0.5, omega = 1000) only on request (~15 min of CPU
at rtol 1e-8 / 1e-10, estimated from a 2-tau run, so not stored).

Model (written from DESIGN.md §1, independent of ``engine/`` and ``sweeps/``: its own scalar
right-hand side and scipy's integrators). Non-dimensional slider from rest, ``e = v = z = 0``::

    de = v_ref - v,   dv = e - F + 1.7 sin(0.3 tau) + f_dither,   u = v + W sin(omega tau)
    dz = u - alpha(z, u) sigma0 |u| z / g(u),   F = sigma0 z + sigma1(u) dz + sigma2 u
    g(u) = fc + (fs - fc) exp(-(u/vs)^2),  sigma1(u) = sigma1_hat exp(-(u/vd)^2)
    z_ss = g(u)/sigma0, z_ba = lam z_ss; alpha = 0 if sgn u != sgn z or |z| <= z_ba,
    1 if |z| >= z_ss, else 0.5 sin(pi (|z| - (z_ss + z_ba)/2) / (z_ss - z_ba)) + 0.5

(Sec. 5.1 parameters, lam = 0.8, vd = 0.1, v_ref = 0.1; f_dither = 0 for the sine-velocity dither).

Method. The trajectory is split into segments of constant *mode*: ``stick`` (alpha == 0, so
``dz = u``: smooth, and u = 0 is no kink there), ``transition(s)`` (the sine branch of alpha with
``|u| = s u``, ``|z| = s z``, s = sgn z = sgn u) and ``slip(s)`` (alpha = 1). Inside a mode the
right-hand side is the analytic (C-infinity) extension of that branch, so no integration step
ever crosses a kink: every kink (u = 0 with sgn u = sgn z, |z| = z_ba, |z| = z_ss) is a terminal,
directional event of ``scipy.integrate.solve_ivp`` (located by scipy's brentq on the dense
output, to ~4 eps), and the integration restarts from the event state in the new mode:

    stick       -> transition/slip  when min(|z| - z_ba, sgn(z) u) rises through 0
    transition  -> slip             when s z - z_ss rises through 0
    transition  -> stick            when s z - z_ba falls through 0, or s u falls through 0
    slip        -> transition       when s z - (1 - H) z_ss falls through 0 (H = 1e-13)
    slip        -> stick            when s u falls through 0

The hysteresis H only stops round-off chatter where z relaxes onto a constant z_ss (|u| >> vs):
below z_ss by a relative 1e-13 the true alpha is 1 - 6e-25, i.e. exactly 1.0 in double, so the
slip right-hand side used there is the true one bit for bit.

Integrator: ``DOP853`` (``--radau`` adds ``Radau``, finite-difference Jacobian, for comparison)
with ``dense_output=True``, two tolerances per case, ``rtol`` = (1e-10, 1e-12) for the undithered
case and (1e-9, 1e-11) for the omega = 300 dither (an omega = 300 period needs ~50-90 DOP853 steps
and scipy costs ~0.5 ms a step: 1e-12 there would take ~10 min), ``atol = 1e-3 * rtol * [fc, fc,
fc/sigma0]`` for (e, v, z), i.e. 1e-15, 1e-15, 1e-17 at rtol = 1e-12, and
``max_step = fc / (sigma0 (2 + W))``, i.e. h sigma0 |u| / g(u) <= 1 for |u| < 2 + W. That cap
matters: in slip at |u| ~ 1 the bristle relaxes onto z_ss at a rate sigma0 |u| / g ~ 100, and
with the steps rtol alone allows (h rate ~ 6) the DOP853 *dense output* between the (accurate)
step ends misses z_ss by up to 4e-8 relative, which moved the gap = 1e-9 slip share by up to
0.045 and made it differ by 1e-2 between rtol = 1e-10 and 1e-12. The stored shares are those
of the finer run; ``tol_diff`` is |coarse - fine| per share and, where the steps are set by
max_step (the undithered case), ``step_check`` reruns the fine rtol with max_step halved;
``self_error`` is the larger of the two per share, an estimate of the reference's own error.

Shares over the window [t_transient, t_end], as exact interval lengths, not sample counts:
stick = total length of stick segments (alpha == 0 exactly); slip = the time with
``|z| >= (1 - gap) z_ss`` and sgn z = sgn u, gap = 1e-9 (a sliding bristle relaxes onto z_ss
exponentially, so alpha == 1 holds only to round-off; below gap = 1.16e-9 the double alpha
rounds to 1.0, so this is the "alpha == 1" share of the exact trajectory); presliding = the
rest. near_slip = share with alpha >= 0.9; alpha_hist = shares in the 10 bins [0, .1), ...,
[.9, 1] (alpha == 0 in the first, alpha == 1 in the last). On every transition segment each
threshold (s z - (1 - gap) z_ss for each gap, alpha - c for c = 0.1 .. 0.9) is sampled at 50
points per integration step of the dense output; every sign change is refined by
``scipy.optimize.brentq`` on the dense output (xtol 1e-15) and the lengths are summed between the
roots. Sanity: the same shares counted on a uniform 1e-4 grid with the unsplit alpha formula
(``sampled``: alpha == 0, alpha == 1.0 in double, the gap rule) and the slip share for
gap in 1e-10 .. 1e-7 (``slip_by_gap``).
"""
from __future__ import annotations

import argparse
import datetime
import json
import math
import pathlib
import time

import numpy as np
import scipy
from scipy.integrate import solve_ivp
from scipy.optimize import brentq

ROOT = pathlib.Path(__file__).resolve().parents[1]
OUT = ROOT / "tests" / "hard" / "phase_references.json"

#: Sec. 7 slider (DESIGN.md §1, Sec. 5.1 parameter set).
BASE = {"sigma0": 100.0, "sigma1_hat": 10.0, "sigma2": 0.004, "vs": 0.1, "fc": 1.0, "fs": 1.5,
        "lam": 0.8, "vd": 0.1, "v_ref": 0.1, "slow_amplitude": 1.7, "slow_omega": 0.3,
        "dither": "none", "W": 0.0, "omega": 0.0}

#: name -> parameter overrides, window (t_transient, t_end), (coarse, fine) rtol, whether to add a
#: run at the fine rtol with max_step halved (only where max_step, not rtol, sets the steps), and
#: whether the case is run by default (the omega = 1000 case costs ~15 min: on request only).
CASES = {
    "undithered": {"overrides": {}, "window": (0.0, 100.0), "rtols": (1e-10, 1e-12),
                   "step_check": True, "default": True},
    "sine_W1_w300": {"overrides": {"dither": "sine-velocity", "W": 1.0, "omega": 300.0},
                     "window": (20.0, 100.0), "rtols": (1e-9, 1e-11),
                     "step_check": False, "default": True},
    "sine_W0.5_w1000": {"overrides": {"dither": "sine-velocity", "W": 0.5, "omega": 1000.0},
                        "window": (20.0, 100.0), "rtols": (1e-8, 1e-10),
                        "step_check": False, "default": False},
}

GAP = 1e-9
GAPS = (1e-10, 1e-9, 1e-8, 1e-7)
HYST = 1e-13            # slip -> transition hysteresis (see docstring)
STEP_RATE = 1.0         # max_step = STEP_RATE * fc / (sigma0 * U), U = 2 + W (see docstring)
ATOL_FACTORS = (1e-3, 1e-3, 1e-3)   # atol = rtol * ATOL_FACTORS * (fc, fc, fc / sigma0)
SAMPLES_PER_STEP = 50
SAMPLE_DT = 1e-4
LEVELS = tuple(round(0.1 * k, 1) for k in range(1, 10))   # alpha bin edges
STICK, TRANS, SLIP = 0, 1, 2
MODE_NAMES = {STICK: "stick", TRANS: "transition", SLIP: "slip"}


# ----------------------------------------------------------------------------- model
class Slider:
    """Right-hand side, events and alpha of the elasto-plastic slider, per mode."""

    def __init__(self, p: dict):
        self.p = p
        self.s0, self.s1h, self.s2 = p["sigma0"], p["sigma1_hat"], p["sigma2"]
        self.vs, self.vd, self.fc, self.dfs = p["vs"], p["vd"], p["fc"], p["fs"] - p["fc"]
        self.lam, self.vref = p["lam"], p["v_ref"]
        self.As, self.Os = p["slow_amplitude"], p["slow_omega"]
        self.W = p["W"] if p["dither"] == "sine-velocity" else 0.0
        self.om = p["omega"]
        if p["dither"] not in ("none", "sine-velocity"):
            raise ValueError(f"dither {p['dither']!r} not supported here")
        self.rhs = self._make_rhs()

    # scalar pieces (math, for speed in the integrator's inner loop)
    def u(self, t, v):
        return v + self.W * math.sin(self.om * t)

    def g(self, u):
        r = u / self.vs
        return self.fc + self.dfs * math.exp(-r * r)

    def _make_rhs(self):
        """The scalar right-hand side as a closure over local constants (speed)."""
        s0, s1h, s2, fc, dfs, lam = self.s0, self.s1h, self.s2, self.fc, self.dfs, self.lam
        ivs, ivd, vref, As, Os, W, om = 1.0 / self.vs, 1.0 / self.vd, self.vref, self.As, \
            self.Os, self.W, self.om
        sin, exp, pi = math.sin, math.exp, math.pi

        def rhs(t, y, mode, s):
            e, v, z = y
            u = v + W * sin(om * t)
            r = u * ivs
            g = fc + dfs * exp(-r * r)
            if mode == STICK:
                dz = u
            elif mode == SLIP:
                dz = u - s0 * s * u * z / g
            else:
                zss = g / s0
                zba = lam * zss
                alpha = 0.5 * sin(pi * (s * z - 0.5 * (zss + zba)) / (zss - zba)) + 0.5
                dz = u - alpha * s0 * s * u * z / g
            r = u * ivd
            F = s0 * z + s1h * exp(-r * r) * dz + s2 * u
            return [vref - v, e - F + As * sin(Os * t), dz]
        return rhs

    def events(self, mode, s):
        """Terminal directional events of a mode, and the mode each one leads to."""
        s0, lam = self.s0, self.lam

        def ev(fun, direction):
            fun.terminal, fun.direction = True, direction
            return fun

        if mode == STICK:
            def leave_stick(t, y, *_):
                u = self.u(t, y[1])
                z = y[2]
                return min(abs(z) - lam * self.g(u) / s0, math.copysign(1.0, z) * u if z else 0.0)
            return [ev(leave_stick, 1.0)], [None]          # None: decide from the state
        if mode == TRANS:
            def to_slip(t, y, *_):
                return s * y[2] - self.g(self.u(t, y[1])) / s0

            def to_stick_z(t, y, *_):
                return s * y[2] - lam * self.g(self.u(t, y[1])) / s0

            def to_stick_u(t, y, *_):
                return s * self.u(t, y[1])
            return ([ev(to_slip, 1.0), ev(to_stick_z, -1.0), ev(to_stick_u, -1.0)],
                    [(SLIP, s), (STICK, 0.0), (STICK, 0.0)])

        def to_trans(t, y, *_):
            return s * y[2] - (1.0 - HYST) * self.g(self.u(t, y[1])) / s0

        def to_stick_u2(t, y, *_):
            return s * self.u(t, y[1])
        return [ev(to_trans, -1.0), ev(to_stick_u2, -1.0)], [(TRANS, s), (STICK, 0.0)]

    def mode_after_stick(self, t, y):
        z = y[2]
        s = 1.0 if z > 0 else -1.0
        zss = self.g(self.u(t, y[1])) / self.s0
        return (TRANS, s) if s * z < zss else (SLIP, s)

    # vectorised pieces (numpy, for the measurements)
    def u_vec(self, t, v):
        return v + self.W * np.sin(self.om * t)

    def zss_vec(self, u):
        return (self.fc + self.dfs * np.exp(-(u / self.vs) ** 2)) / self.s0

    def alpha_trans_vec(self, t, y, s):
        """alpha on the sine branch (mode transition with sign s)."""
        zss = self.zss_vec(self.u_vec(t, y[1]))
        zba = self.lam * zss
        return 0.5 * np.sin(np.pi * (s * y[2] - 0.5 * (zss + zba)) / (zss - zba)) + 0.5

    def alpha_vec(self, t, y):
        """alpha from the unsplit definition (for the sampled sanity check)."""
        u = self.u_vec(t, y[1])
        z = y[2]
        zss = self.zss_vec(u)
        zba = self.lam * zss
        az = np.abs(z)
        with np.errstate(invalid="ignore", divide="ignore"):
            a = 0.5 * np.sin(np.pi * (az - 0.5 * (zss + zba)) / (zss - zba)) + 0.5
        a = np.where(az >= zss, 1.0, a)
        a = np.where((np.sign(u) != np.sign(z)) | (az <= zba), 0.0, a)
        return a, u, zss


# ----------------------------------------------------------------------------- measuring
def measure_nonneg(f_vec, f_scalar, ts):
    """Length of {t in [ts[0], ts[-1]] : f(t) >= 0}, roots of f refined by brentq."""
    fv = f_vec(ts)
    b = fv >= 0
    total = float(np.sum(np.diff(ts)[b[:-1] & b[1:]]))
    for k in np.flatnonzero(b[:-1] != b[1:]):
        r = brentq(f_scalar, ts[k], ts[k + 1], xtol=1e-15, rtol=4 * np.finfo(float).eps)
        total += (r - ts[k]) if b[k] else (ts[k + 1] - r)
    return total


def step_samples(step_ts, a, b, n=SAMPLES_PER_STEP):
    """n sub-intervals per integration step, clipped to [a, b]."""
    inner = step_ts[(step_ts > a) & (step_ts < b)]
    edges = np.concatenate(([a], inner, [b]))
    frac = np.arange(n) / n
    ts = (edges[:-1, None] + np.diff(edges)[:, None] * frac[None, :]).ravel()
    return np.append(ts, b)


class Accumulator:
    def __init__(self, model: Slider, window):
        self.m = model
        self.ta, self.tb = window
        self.stick = self.trans = self.slipmode = 0.0
        self.above = np.zeros(len(LEVELS))          # transition time with alpha >= level
        self.gap_len = {g: 0.0 for g in GAPS + (GAP,)}  # transition time with s z >= (1-gap) z_ss
        n = int(round((self.tb - self.ta) / SAMPLE_DT))
        self.n_samples = n
        self.cnt = {"alpha0": 0, "alpha1": 0, "gap": 0}

    def add(self, t0, t1, mode, s, sol):
        a, b = max(t0, self.ta), min(t1, self.tb)
        if b > a:
            L = b - a
            if mode == STICK:
                self.stick += L
            elif mode == SLIP:
                self.slipmode += L
            else:
                self.trans += L
                self._transition(a, b, s, sol)
        self._sample(t0, t1, sol)

    def _transition(self, a, b, s, sol):
        m = self.m
        ts = step_samples(sol.ts, a, b)
        ys = sol(ts)
        alpha_s = m.alpha_trans_vec(ts, ys, s)
        zss_s = m.zss_vec(m.u_vec(ts, ys[1]))
        sz = s * ys[2]

        def alpha_at(t):
            return float(m.alpha_trans_vec(t, sol(t), s))

        for i, c in enumerate(LEVELS):
            self.above[i] += measure_nonneg(lambda _t, c=c: alpha_s - c,
                                            lambda t, c=c: alpha_at(t) - c, ts)
        for gap in self.gap_len:
            def q_scalar(t, gap=gap):
                y = sol(t)
                return float(s * y[2] - (1.0 - gap) * m.zss_vec(m.u_vec(t, y[1])))
            self.gap_len[gap] += measure_nonneg(
                lambda _t, gap=gap: sz - (1.0 - gap) * zss_s, q_scalar, ts)

    def _sample(self, t0, t1, sol):
        """Uniform grid t_k = ta + k dt, k < n, counted with the unsplit alpha."""
        k0 = max(0, math.ceil((t0 - self.ta) / SAMPLE_DT - 1e-9))
        k1 = min(self.n_samples, math.ceil((t1 - self.ta) / SAMPLE_DT - 1e-9))
        if k1 <= k0:
            return
        ts = self.ta + SAMPLE_DT * np.arange(k0, k1)
        ts = ts[(ts >= t0) & (ts < t1)]
        if ts.size == 0:
            return
        ys = sol(ts)
        a, u, zss = self.m.alpha_vec(ts, ys)
        self.cnt["alpha0"] += int(np.sum(a == 0.0))
        self.cnt["alpha1"] += int(np.sum(a == 1.0))
        self.cnt["gap"] += int(np.sum((np.abs(ys[2]) >= (1.0 - GAP) * zss)
                                      & (np.sign(u) == np.sign(ys[2]))))

    def shares(self):
        T = self.tb - self.ta
        total = self.stick + self.trans + self.slipmode
        if abs(total - T) > 1e-9 * T:
            raise RuntimeError(f"segments cover {total}, window is {T}")
        slip = {g: (self.slipmode + self.gap_len[g]) / T for g in self.gap_len}
        above = self.above + self.slipmode                      # alpha >= LEVELS[i], all modes
        edges_up = np.concatenate(([T], above, [0.0]))          # time with alpha >= 0, .1, ..., 1+
        hist = (edges_up[:-1] - edges_up[1:]) / T
        return {
            "stick": self.stick / T,
            "presliding": 1.0 - self.stick / T - slip[GAP],
            "slip": slip[GAP],
            "near_slip": above[-1] / T,
            "alpha_hist": hist.tolist(),
            "slip_mode": self.slipmode / T,
            "slip_by_gap": {f"{g:g}": slip[g] for g in GAPS},
        }

    def sampled(self):
        n = self.n_samples
        return {"n": n, "dt": SAMPLE_DT, "stick": self.cnt["alpha0"] / n,
                "slip_alpha_eq_1": self.cnt["alpha1"] / n, "slip_gap": self.cnt["gap"] / n,
                "presliding_gap": 1.0 - (self.cnt["alpha0"] + self.cnt["gap"]) / n}


# ----------------------------------------------------------------------------- integration
def max_step_of(p: dict, step_rate: float = STEP_RATE) -> float:
    return step_rate * p["fc"] / (p["sigma0"] * (2.0 + p["W"]))


def run(p: dict, window, method: str, rtol: float, step_rate: float = STEP_RATE):
    """Integrate from rest to t_end mode by mode; return (shares, sampled, stats)."""
    m = Slider(p)
    acc = Accumulator(m, window)
    atol = rtol * np.array(ATOL_FACTORS) * np.array([p["fc"], p["fc"], p["fc"] / p["sigma0"]])
    max_step = max_step_of(p, step_rate)
    t, t_end, y = 0.0, window[1], np.zeros(3)
    mode, s = STICK, 0.0
    h = None                # first step of a restart: the last step before the event
    n_seg = n_steps = n_tiny = 0
    hrate = umax = 0.0
    tic = time.perf_counter()
    while t < t_end:
        events, nxt = m.events(mode, s)
        res = solve_ivp(m.rhs, (t, t_end), y, method=method, rtol=rtol, atol=atol,
                        dense_output=True, events=events, args=(mode, s), max_step=max_step,
                        first_step=None if h is None else min(h, t_end - t))
        if res.status < 0:
            raise RuntimeError(f"{method} failed at t={t}: {res.message}")
        n_seg += 1
        n_steps += len(res.sol.ts) - 1
        ts_ = res.sol.ts
        u_ = np.abs(m.u_vec(ts_, res.sol(ts_)[1]))
        umax = max(umax, float(u_.max()))
        if len(ts_) > 1:   # fastest bristle relaxation rate sigma0 |u| / g(u) times the step
            hrate = max(hrate, float(np.max(np.diff(ts_) * p["sigma0"] * np.maximum(u_[:-1], u_[1:])
                                            / p["fc"])))
        if res.status == 1:
            i = next(k for k, te in enumerate(res.t_events) if len(te))
            t1, y1 = float(res.t_events[i][0]), np.array(res.y_events[i][0])
            new = nxt[i] if nxt[i] is not None else m.mode_after_stick(t1, y1)
        else:
            t1, y1, new = t_end, res.y[:, -1], (mode, s)
        acc.add(t, t1, mode, s, res.sol)
        if len(ts_) > 1:
            h = float(ts_[-1] - ts_[-2])
        n_tiny = n_tiny + 1 if t1 - t < 1e-12 else 0
        if n_tiny > 50:
            raise RuntimeError(f"event chatter at t={t}: mode {MODE_NAMES[mode]}")
        t, y = t1, y1
        mode, s = new
    stats = {"segments": n_seg, "steps": n_steps, "seconds": round(time.perf_counter() - tic, 1),
             "max_step": max_step, "max_abs_u": umax, "max_h_rate": hrate}
    return acc.shares(), acc.sampled(), stats


SHARE_KEYS = ("stick", "presliding", "slip", "near_slip")


def diff(a: dict, b: dict) -> dict:
    d = {k: abs(a[k] - b[k]) for k in SHARE_KEYS + ("slip_mode",)}
    d["alpha_hist"] = np.abs(np.subtract(a["alpha_hist"], b["alpha_hist"])).tolist()
    d["slip_by_gap"] = {g: abs(a["slip_by_gap"][g] - b["slip_by_gap"][g]) for g in a["slip_by_gap"]}
    return d


def fmt_row(label, sh):
    return (f"  {label:26s} " + " ".join(f"{sh[k]:.9f}" for k in SHARE_KEYS)
            + "  " + " ".join(f"{x:.4f}" for x in sh["alpha_hist"]))


def fmt_diff(label, d):
    return (f"  {label:26s} " + " ".join(f"{d[k]:11.2e}" for k in SHARE_KEYS)
            + f"  max hist {max(d['alpha_hist']):.1e}")


def reference(name: str, methods, rtols=None) -> dict:
    case = CASES[name]
    window = case["window"]
    rtols = tuple(rtols or case["rtols"])
    p = {**BASE, **case["overrides"]}
    tic = time.perf_counter()
    print(f"\n== {name}: dither={p['dither']} W={p['W']} omega={p['omega']} window={window}")
    print(f"  {'':26s} {'stick':11s} {'presliding':11s} {'slip':11s} {'near_slip':11s}  alpha_hist")

    def one(label, method, rtol, step_rate=STEP_RATE):
        sh, sa, st = run(p, window, method, rtol, step_rate)
        print(fmt_row(label, sh) + f"   [{st['segments']} segments, {st['steps']} steps, "
              f"{st['seconds']} s]", flush=True)
        return sh, sa, st

    main_m = methods[0]
    coarse = one(f"{main_m} rtol={rtols[0]:g}", main_m, rtols[0])
    fine = one(f"{main_m} rtol={rtols[1]:g}", main_m, rtols[1])
    d = diff(coarse[0], fine[0])
    print(fmt_diff("|diff| of the two rtols", d))
    self_err = {k: d[k] for k in SHARE_KEYS}
    self_err["alpha_hist"] = list(d["alpha_hist"])
    rec = {}
    if case["step_check"]:
        half = one(f"{main_m} rtol={rtols[1]:g} h/2", main_m, rtols[1], STEP_RATE / 2)
        d_half = diff(half[0], fine[0])
        print(fmt_diff("|diff| max_step halved", d_half))
        rec["step_check"] = {"shares": half[0], "stats": half[2], "diff": d_half}
        for k in SHARE_KEYS:
            self_err[k] = max(self_err[k], d_half[k])
        self_err["alpha_hist"] = np.maximum(self_err["alpha_hist"], d_half["alpha_hist"]).tolist()
    others = {}
    for other in methods[1:]:
        runs = [one(f"{other} rtol={r:g}", other, r) for r in rtols]
        d2 = diff(runs[1][0], fine[0])
        print(fmt_diff(f"|{other} - {main_m}| at rtol={rtols[1]:g}", d2))
        others[other] = {"shares": runs[1][0], "shares_coarse": runs[0][0], "stats": runs[1][2],
                         "stats_coarse": runs[0][2], "diff_vs_main": d2}
    sa = fine[1]
    print(f"  sampled dt={SAMPLE_DT:g}: stick {sa['stick']:.6f}, slip(alpha==1.0) "
          f"{sa['slip_alpha_eq_1']:.6f}, slip(gap) {sa['slip_gap']:.6f}, "
          f"presliding(gap) {sa['presliding_gap']:.6f}")
    print("  slip by gap: " + ", ".join(f"{g}: {v:.9f}" for g, v in fine[0]["slip_by_gap"].items())
          + f"; slip mode (|z| >= (1-{HYST:g}) z_ss): {fine[0]['slip_mode']:.9f}")
    seconds = round(time.perf_counter() - tic, 1)
    print(f"  total {seconds} s")
    return {
        "params": p, "window": list(window), "t_transient": window[0], "t_end": window[1],
        "method": main_m, "rtol": rtols[1], "rtol_coarse": rtols[0],
        "atol": f"rtol * {list(ATOL_FACTORS)} * [fc, fc, fc / sigma0] for (e, v, z)",
        "max_step": f"{STEP_RATE:g} * fc / (sigma0 * (2 + W)) = {max_step_of(p):.6g}",
        "gap": GAP, "alpha_near": 0.9, "alpha_bins": [round(0.1 * k, 1) for k in range(11)],
        "shares": fine[0], "shares_coarse": coarse[0], "tol_diff": d, "self_error": self_err,
        **rec, "sampled": sa, "stats": fine[2], "stats_coarse": coarse[2],
        "other_methods": others,
        "events": "terminal, directional: u = 0 (sgn u = sgn z), |z| = z_ba, |z| = z_ss "
                  f"(slip exit at (1 - {HYST:g}) z_ss); restart in the new mode",
        "measure": f"brentq on the dense output, {SAMPLES_PER_STEP} samples per step",
        "seconds": seconds, "date": datetime.date.today().isoformat(),
        "scipy": scipy.__version__, "numpy": np.__version__,
        "script": "scripts/reference_phases.py",
    }


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("cases", nargs="*", help=f"any of {list(CASES)} (default: "
                    f"{[n for n, c in CASES.items() if c['default']]}); 'all' for every case")
    ap.add_argument("--list", action="store_true", help="list the cases and exit")
    ap.add_argument("--radau", action="store_true", help="also run Radau and compare")
    ap.add_argument("--rtols", nargs=2, type=float, metavar=("COARSE", "FINE"),
                    help="override the case's pair of rtols")
    ap.add_argument("--no-write", action="store_true", help="print only, do not write the JSON")
    args = ap.parse_args(argv)
    if args.list:
        for name, c in CASES.items():
            print(f"{name:16s} window={c['window']} rtols={c['rtols']} default={c['default']} "
                  f"{c['overrides']}")
        return
    if args.cases == ["all"]:
        args.cases = list(CASES)
    unknown = set(args.cases) - set(CASES)
    if unknown:
        ap.error(f"unknown case(s) {sorted(unknown)}; known: {list(CASES)}")
    methods = ["DOP853"] + (["Radau"] if args.radau else [])
    store = json.loads(OUT.read_text()) if OUT.exists() else {}
    for name in args.cases or [n for n, c in CASES.items() if c["default"]]:
        store[name] = reference(name, methods, args.rtols)
        if not args.no_write:
            OUT.parent.mkdir(parents=True, exist_ok=True)
            OUT.write_text(json.dumps(store, indent=1, sort_keys=True) + "\n")


if __name__ == "__main__":
    main()
