"""Independent high-accuracy references for the engine tests (scipy, plain numpy).

The equations are re-typed here from DESIGN.md §1 (not imported from the engine) and
integrated with ``scipy.integrate.solve_ivp(method="DOP853", rtol=1e-12, atol=1e-14)``,
restarted at every square-wave switch ``k pi / omega`` and at every kink of the right-hand
side (``u = 0``; elasto-plastic ``|z| = z_ba``, ``|z| = z_ss``), located as terminal
events. After a kink the first ``NUDGE`` of time is integrated without events so the same
root is not found twice (the error this adds is of order jump * NUDGE**2).

The static laws (coulomb / stribeck) are integrated as a hybrid automaton with exact
sticking (``v + W sq == 0`` held, breakaway when the holding force exceeds the break-away
level): the engine's Karnopp band of width ``stick_band`` must agree with it to O(band).
"""
from __future__ import annotations

import numpy as np
from scipy.integrate import quad, solve_ivp

RTOL, ATOL = 1e-12, 1e-14
NUDGE = 1e-9


def g(u, d):
    return d["fc"] + (d["fs"] - d["fc"]) * np.exp(-abs(u / d["vs"]) ** d["delta"])


def sigma1(u, d):
    return d["sigma1"] * np.exp(-abs(u / d["vd"]) ** d["delta_d"])


def alpha_ep(z, u, d):
    """Eq. 2.7 with |z| (DESIGN.md §1)."""
    if u == 0 or z == 0 or np.sign(u) != np.sign(z):
        return 0.0
    zss = g(u, d) / d["sigma0"]
    zba = d["lam"] * zss
    if abs(z) <= zba:
        return 0.0
    if abs(z) >= zss:
        return 1.0
    return 0.5 * np.sin(np.pi * (abs(z) - 0.5 * (zss + zba)) / (zss - zba)) + 0.5


def interface(t, y, d, dither, sq):
    """(u, f_ext): interface velocity and non-friction force of the slider."""
    e, v = y[0], y[1]
    f = e + d["slow_a"] * np.sin(d["slow_omega"] * t)
    if dither == "square-velocity":
        return v + d["W"] * sq, f
    if dither == "sine-velocity":
        return v + d["W"] * np.sin(d["omega"] * t), f
    if dither == "sine-force":
        return v, f + d["W"] * d["omega"] * np.sin(d["omega"] * t)
    return v, f


def friction(u, z, d, law):
    """(dz, F) of a bristle law, or of a static law while sliding (Eq. 2.2)."""
    if law in ("lugre", "elastoplastic"):
        a = 1.0 if law == "lugre" else alpha_ep(z, u, d)
        dz = u - a * d["sigma0"] * abs(u) * z / g(u, d)
        return dz, d["sigma0"] * z + sigma1(u, d) * dz + d["sigma2"] * u
    level = g(u, d) if law == "stribeck" else d["fc"]
    return 0.0, level * np.sign(u) + d["sigma2"] * u


def slider_rhs(t, y, d, law, dither, sq):
    """(e, v, z, Q, X) with dQ = F and dX = v (DESIGN.md §1 slider)."""
    u, f = interface(t, y, d, dither, sq)
    dz, F = friction(u, y[2], d, law)
    return [d["v_ref"] - y[1], f - F, dz, F, y[1]]


def _kinks(d, law, dither, sq):
    def ev_u(t, y):
        return interface(t, y, d, dither, sq)[0]
    evs = [ev_u]
    if law == "elastoplastic":
        for frac in (d["lam"], 1.0):
            evs.append(lambda t, y, frac=frac: abs(y[2]) - frac * g(ev_u(t, y), d) / d["sigma0"])
    for ev in evs:
        ev.terminal = True
    return evs


def _piece(fun, t0, t1, y, events, atol=ATOL, max_step=np.inf):
    """Integrate fun over [t0, t1] restarting at terminal events; returns y(t1)."""
    t = t0
    while t < t1:
        sol = solve_ivp(fun, (t, t1), y, method="DOP853", rtol=RTOL, atol=atol, events=events,
                        max_step=max_step)
        if sol.status == -1:   # (a reference that failed must not pass for one)
            raise RuntimeError(f"reference: solve_ivp failed at t = {t}: "
                               f"{sol.message}")
        y = sol.y[:, -1]
        if sol.status != 1:
            return y
        t = sol.t[-1]
        t_n = min(t + NUDGE, t1)
        y = solve_ivp(fun, (t, t_n), y, method="DOP853", rtol=RTOL, atol=atol).y[:, -1]
        t = t_n
    return y


def contact(d: dict, law: str, t_end: float, t_transient: float) -> dict:
    """F_mean of the contact of Sec. 3 under sine-velocity dither (DESIGN.md §1: no mass,
    ``u = v_ref + W cos(omega t)`` prescribed, ``dz = law(u, z)``, ``z(0) = 0``) over
    ``[t_transient, t_end]``, from the quadrature ``dQ = F``. The states are SI (``z ~ fc /
    sigma0``), so atol is scaled per state (``z``: 1e-14 fc / sigma0; ``Q``: 1e-14 fc t_end);
    steps span at most 1/200 of the dither period, so a crossing of ``u = 0`` and back is
    seen."""
    def rhs(t, y):
        u = d["v_ref"] + d["W"] * np.cos(d["omega"] * t)
        dz, F = friction(u, y[0], d, law)
        return [dz, F]

    def ev_u(t, y):
        return d["v_ref"] + d["W"] * np.cos(d["omega"] * t)
    evs = [ev_u]
    if law == "elastoplastic":
        for frac in (d["lam"], 1.0):
            evs.append(lambda t, y, frac=frac:
                       abs(y[0]) - frac * g(ev_u(t, y), d) / d["sigma0"])
    for ev in evs:
        ev.terminal = True
    atol = np.array([ATOL * d["fc"] / d["sigma0"], ATOL * d["fc"] * t_end])
    step = 2 * np.pi / d["omega"] / 200 if d["W"] and d["omega"] else np.inf
    y_tr = _piece(rhs, 0.0, t_transient, np.zeros(2), evs, atol, step)
    y_end = _piece(rhs, t_transient, t_end, y_tr, evs, atol, step)
    return {"F_mean": (y_end[1] - y_tr[1]) / (t_end - t_transient)}


def slider(d: dict, law: str, dither: str, y0, t_end: float, stops=()):
    """State (e, v, z, Q, X) of the slider at t_end (bristle laws, or sliding static laws);
    with ``stops``, also the states at those instants, shape ``(len(stops), 5)``."""
    y = np.array(list(y0) + [0.0, 0.0], dtype=float)
    hp = np.pi / d["omega"] if dither == "square-velocity" else t_end
    grid = [k * hp for k in range(1, int(np.ceil(t_end / hp)))]
    ts = sorted(set(grid) | {float(s) for s in stops} | {t_end})
    at = {}
    t = 0.0
    for t_next in ts:
        k = int(np.floor(t / hp + 1e-9)) if dither == "square-velocity" else 0
        sq = 1.0 if k % 2 == 0 else -1.0
        fun = lambda tt, yy, sq=sq: slider_rhs(tt, yy, d, law, dither, sq)
        y = _piece(fun, t, t_next, y, _kinks(d, law, dither, sq))
        at[t_next] = y
        t = t_next
    if len(stops):
        return y, np.array([at[float(s)] for s in stops])
    return y


def static_stick_slip(d: dict, law: str, t_end: float) -> tuple[np.ndarray, list]:
    """Undithered slider with a static law as a hybrid automaton, from rest.

    Stick: ``v = 0``, ``de = v_ref``, until ``|e + f_slow| > f_break``. Slip: Eq. 2.2 until
    ``v`` reaches 0, then stick if ``|e + f_slow| <= f_break``. Returns ``(e, v)`` at t_end and
    the list of (start, end) sticking intervals.
    """
    fb = d["fs"] if law == "stribeck" else d["fc"]
    hold = lambda t, e: e + d["slow_a"] * np.sin(d["slow_omega"] * t)
    t, e, v, sticks = 0.0, 0.0, 0.0, []
    while t < t_end:
        # stick: e(t) = e + v_ref (t - t_s) until breakaway
        brk = lambda tt, yy: abs(hold(tt, yy[0])) - fb
        brk.terminal = True
        sol = solve_ivp(lambda tt, yy: [d["v_ref"]], (t, t_end), [e], events=brk,
                        method="DOP853", rtol=RTOL, atol=ATOL)
        sticks.append((t, sol.t[-1]))
        t, e = sol.t[-1], sol.y[0, -1]
        if t >= t_end:
            return np.array([e, 0.0]), sticks
        sgn = np.sign(hold(t, e))
        def rhs(tt, yy, sgn=sgn):
            vv = yy[1] if yy[1] != 0 else sgn * 1e-300   # slip starts in the sense of hold
            return [d["v_ref"] - yy[1], hold(tt, yy[0]) - friction(vv, 0.0, d, law)[1]]

        def stop(tt, yy, t=t, sgn=sgn):
            return yy[1] if tt > t + NUDGE else sgn
        stop.terminal = True
        sol = solve_ivp(rhs, (t, t_end), [e, 0.0], events=stop, method="DOP853",
                        rtol=RTOL, atol=ATOL)
        t, e, v = sol.t[-1], sol.y[0, -1], sol.y[1, -1]
        if sol.status != 1:
            return np.array([e, v]), sticks
        if abs(hold(t, e)) > fb:
            raise NotImplementedError("slip reversal without sticking: not needed by the tests")
    return np.array([e, v]), sticks


def static_square_stick_slip(d: dict, law: str, t_end: float) -> tuple[np.ndarray, list]:
    """Square-velocity dithered slider with a static law as a hybrid automaton, from rest.

    Between switches ``k pi / omega`` the dither sign ``sq`` is fixed (+1 on the first half
    period) and ``u = v + W sq``. Stick: ``u = 0`` held exactly (``v = -W sq``,
    ``de = v_ref + W sq``) until ``|e + f_slow| > f_break`` or the next switch (where ``u``
    jumps by ``2 W``). Slip: Eq. 2.2 until ``u`` reaches 0, then stick if
    ``|e + f_slow| <= f_break``, else slip on in the sense of the holding force. Returns
    ``(e, v)`` at ``t_end`` and the list of (start, end) sticking intervals.
    """
    fb = d["fs"] if law == "stribeck" else d["fc"]
    W, hp = d["W"], np.pi / d["omega"]
    hold = lambda t, e: e + d["slow_a"] * np.sin(d["slow_omega"] * t)
    t, e, v, k, stuck, sgn, sticks = 0.0, 0.0, 0.0, 0, False, 1.0, []
    while t < t_end:
        sq = 1.0 if k % 2 == 0 else -1.0
        t_sw = min((k + 1) * hp, t_end)
        if not stuck and v + W * sq != 0.0:
            sgn = np.sign(v + W * sq)
        while t < t_sw:
            if stuck:
                brk = lambda tt, yy: abs(hold(tt, yy[0])) - fb
                brk.terminal = True
                sol = solve_ivp(lambda tt, yy: [d["v_ref"] + W * sq], (t, t_sw), [e],
                                events=brk, method="DOP853", rtol=RTOL, atol=ATOL)
                sticks.append((t, sol.t[-1]))
                t, e, v = sol.t[-1], sol.y[0, -1], -W * sq
                if sol.status != 1:
                    break                            # the switch ends the stick
                stuck, sgn = False, np.sign(hold(t, e))
                continue

            def rhs(tt, yy, sgn=sgn):
                u = yy[1] + W * sq
                return [d["v_ref"] - yy[1],
                        hold(tt, yy[0]) - friction(u if u != 0 else sgn * 1e-300, 0.0, d, law)[1]]

            def stop(tt, yy, t0=t, sgn=sgn):
                return yy[1] + W * sq if tt > t0 + NUDGE else sgn
            stop.terminal = True
            sol = solve_ivp(rhs, (t, t_sw), [e, v], events=stop, method="DOP853",
                            rtol=RTOL, atol=ATOL)
            t, e, v = sol.t[-1], sol.y[0, -1], sol.y[1, -1]
            if sol.status != 1:
                break
            if abs(hold(t, e)) <= fb:
                stuck, v = True, -W * sq
            else:
                sgn = np.sign(hold(t, e))              # slip reversal
        if stuck:
            stuck = False                              # u jumps by 2 W at the switch
            sgn = -sq
        k += 1
    return np.array([e, v]), sticks


def contact_static(d: dict, law: str, t_end: float, t_transient: float) -> dict:
    """F_mean of the contact under sine-velocity dither with a static law (Coulomb,
    Stribeck): no state, so ``F(t)`` is known in closed form (``g(u) sgn(u) + sigma2 u``
    outside the Karnopp band ``|u| < stick_band``, 0 inside it: nothing holds the contact)
    and its mean is a quadrature, by ``scipy.integrate.quad`` between the instants where
    ``u`` crosses the band's edges (found from ``cos(omega t)`` in closed form)."""
    vm, va, w, band = d["v_ref"], d["W"], d["omega"], d["stick_band"]

    def force(t):
        u = vm + va * np.cos(w * t)
        if abs(u) < band:
            return 0.0
        level = g(u, d) if law == "stribeck" else d["fc"]
        return level * np.sign(u) + d["sigma2"] * u

    cuts = {t_transient, t_end}
    for edge in (-band, band):
        x = (edge - vm) / va
        if abs(x) <= 1.0:
            a = np.arccos(x)
            for k in range(int(w * t_end / (2 * np.pi)) + 2):
                for phase in (a, 2 * np.pi - a):
                    t = (phase + 2 * np.pi * k) / w
                    if t_transient < t < t_end:
                        cuts.add(t)
    ts = sorted(cuts)
    total = sum(quad(force, a, b, epsabs=0.0, epsrel=1e-13, limit=200)[0]
                for a, b in zip(ts[:-1], ts[1:]))
    return {"F_mean": total / (t_end - t_transient)}
