"""A friction law a user brings by import path (issue 35): the worked example of docs/MODELS.md
runs like a built-in law, its source is in the sweep id, and bad user code is one line.

The example (docs/examples/mylab/laws.py, a GMS written as a user would) must give the
built-in GMS's numbers (same equations: within 1e-9); each bad module gives one line naming
what is wrong, no traceback, through the same spec loading that ``ditherlab plan`` and
``submit`` use (tests/e2e of the CLI: test_models_cli.py).
"""
from __future__ import annotations

import sys
import textwrap
from pathlib import Path

import pytest

from engine import Scene, Settings, registry, simulate
from sweeps.planning.plan import make_plan
from sweeps.spec import SpecError, load_spec

ROOT = Path(__file__).resolve().parents[2]
EXAMPLES = ROOT / "docs" / "examples"
GMS = {"k": [40.0, 100.0, 250.0], "alpha": [0.2, 0.3, 0.5], "C": 20.0}


@pytest.fixture
def examples_on_path(monkeypatch):
    monkeypatch.syspath_prepend(str(EXAMPLES))


@pytest.mark.long   # 17-30 s of first compilations (2 cores): quick set <= 3 min, issue 38
def test_the_worked_example_gives_the_builtin_gms_numbers(examples_on_path):
    kw = dict(W=0.3, omega=20.0, v_ref=0.1, t_end=8.0, t_transient=2.0)
    outs = ("v_mean", "F_mean", "stick_fraction", "slip_fraction")
    got = {}
    for ref in ("gms", "mylab.laws:MaxwellSlip"):
        p = registry.pack(ref, "slider", GMS, **kw)
        scene = Scene.from_params(p, friction=ref, dither="sine-velocity", outputs=outs,
                                  sizes=registry.sizes_of(ref, "slider", GMS))
        r = simulate(scene, p, Settings(rtol=1e-10, atol=1e-13))
        assert r.status == 0
        got[ref] = r.outputs
    for o in outs:
        assert got["mylab.laws:MaxwellSlip"][o] == pytest.approx(got["gms"][o], rel=1e-9,
                                                                 abs=1e-9), o


def test_a_spec_names_the_example_and_its_source_is_in_the_sweep_id(tmp_path, monkeypatch):
    pkg = tmp_path / "lab"
    pkg.mkdir()
    (pkg / "__init__.py").write_text("")
    source = (EXAMPLES / "mylab" / "laws.py").read_text()
    (pkg / "laws.py").write_text(source)
    monkeypatch.syspath_prepend(str(tmp_path))
    spec = {"friction": "lab.laws:MaxwellSlip", "dither": "sine-velocity",
            "outputs": ["v_mean"], "accuracy": "draft", "time": {"t_end": 2.0, "t_transient": 1.0},
            "params": {"gms": GMS}, "grid": {"W": [0.1, 0.2]}}
    first = load_spec(spec).sweep_id
    assert load_spec(spec).sweep_id == first
    (pkg / "laws.py").write_text(source + "\n# an edit\n")
    registry.resolve.cache_clear()
    second = load_spec(spec).sweep_id
    assert second != first
    # a helper module of the package is code of the model too (before, only laws.py was
    # hashed: an edit of a helper it imports kept the id, and the old cube was served)
    (pkg / "common.py").write_text("SCALE = 1.0\n")
    registry.resolve.cache_clear()
    third = load_spec(spec).sweep_id
    (pkg / "common.py").write_text("SCALE = 2.0\n")
    registry.resolve.cache_clear()
    assert len({first, second, third, load_spec(spec).sweep_id}) == 4
    # the plan's effects: a brought law's Stribeck curve and bristle damping are its own to
    # name (``effects()``); the plan listed the scene's flags as compiled in (a newcomer's
    # pass: "compiled in: stribeck, bristle damping" for a Dahl law of their own)
    effects = make_plan(load_spec(spec)).effects()
    assert not {"stribeck", "bristle damping"} & effects.keys(), effects
    assert {"stribeck", "bristle damping"} <= make_plan(load_spec(
        {**spec, "friction": "lugre", "params": {}})).effects().keys()


BAD = {
    # name: (module source, friction ref suffix, params, what the line must say)
    "syntax": ("class X(:\n", "X", {}, "SyntaxError"),
    "raises-on-import": ("1 / 0\n", "X", {}, "ZeroDivisionError"),
    "misspelt": ("from engine.contract import FrictionLaw\nclass Dahl2(FrictionLaw):\n"
                 "    name = 'd'\n", "Dahl3", {}, "has no 'Dahl3' (did you mean 'Dahl2'?)"),
    "not-a-law": ("class X:\n    pass\n", "X", {}, "not a subclass of engine.contract.FrictionLaw"),
    "constructor": ("from engine.contract import FrictionLaw\nclass X(FrictionLaw):\n"
                    "    name = 'x'\n    def __init__(self):\n        raise RuntimeError('no')\n",
                    "X", {}, "X() failed: RuntimeError: no"),
    "bad-params": ("from engine.contract import FrictionLaw\nclass X(FrictionLaw):\n"
                   "    name = 'x'\n    params = {'a': 1.0}\n", "X", {},
                   "params must be a dict of engine.contract.Param"),
    "bad-name": ("from engine.contract import FrictionLaw\nclass X(FrictionLaw):\n"
                 "    name = 'my law'\n", "X", {}, "its name must be an identifier"),
    # accepted before: plan showed "z (lugre)" for the states of a Dahl law (a newcomer)
    "a-builtin-name": ("from engine.contract import FrictionLaw\nclass X(FrictionLaw):\n"
                       "    name = 'lugre'\n", "X", {},
                       "its name 'lugre' is a built-in friction's; give it another"),
}
_LAW = '''
from engine.contract import FrictionLaw, LawKernels, Param

class X(FrictionLaw):
    name = "x"
    params = {{"a": Param(1.0, "1", "a number", lo=0.0, hi=2.0)}}

    def n_states(self, size):
        return {n}

    def build(self, b):
        Z, ia = b.z0, b.ix["a"]

        @b.jit(inline="always")
        def rates(u, y, dy, hold, p):
{rates}

        @b.jit(inline="always")
        def force(u, y, hold, p):
            return p[ia] * y[Z], 1.0

        @b.jit(inline="always")
        def init(p, y):
            y[Z] = 0.0

        @b.jit(inline="always")
        def scales(p, out):
            out[Z] = 1.0

        return LawKernels(rates, force, 0, None, init, scales)
'''
_GOOD_RATES = "            dy[Z] = u - y[Z]\n            return p[ia] * y[Z]"


def _law(n=1, rates=_GOOD_RATES):
    return _LAW.format(n=n, rates=rates)


BAD.update({
    "too-many-writes": (_law(n=1, rates="            dy[Z] = u\n            dy[Z + 1] = u\n"
                                        "            dy[Z + 2] = u\n            return y[Z]"),
                        "X", {}, "rates writes slot 3 of the state vector, outside its 1 "
                        "states (slots 2 to 2) and 0 modes"),
    "too-few-states-written": (_law(n=2), "X", {}, "gives no rate for state 3"),
    "numba-cannot-compile": (_law(rates="            dy[Z] = u + 'a'\n            return u"),
                             "X", {}, "numba cannot compile"),
    "rates-returns-a-dict": (_law(rates="            dy[Z] = u\n            return {'a': u}"),
                             "X", {}, "rates must return the friction force (a number), "
                             "got Dict (at badlaw_rates_returns_a_dict.py line"),
    "nan-at-first-step": (_law(rates="            dy[Z] = u\n            return math.nan"
                               ).replace("from engine", "import math\nfrom engine"),
                          "X", {}, "NaN or infinite at the first step"),
    "inf-rate": (_law(rates="            dy[Z] = math.inf\n            return 0.0"
                      ).replace("from engine", "import math\nfrom engine"),
                 "X", {}, "NaN or infinite at the first step"),
    "unknown-parameter": (_law(), "X", {"b": 1.0}, "unknown parameter 'b'"),
    "out-of-range-parameter": (_law(), "X", {"a": 3.0}, "params.a: 3.0 is outside the allowed range [0, 2]"),
    "missing-ix": (_law().replace('b.ix["a"]', 'b.ix["nope"]'), "X", {},
                   "KeyError while building"),
    # found by review (2026-11-28): an internal error (exit 1) or silently taken before
    "n-states-raises": (_law(n='size["k"]'), "X", {},
                        "'badlaw_n_states_raises:X': n_states failed: KeyError: 'k' (at "
                        "badlaw_n_states_raises.py line 9)"),
    "n-states-not-whole": (_law(n="2.5"), "X", {}, "n_states must return a whole number, "
                           "got 2.5"),
    "phases-typo": (_law().replace('name = "x"', 'name = "x"\n    phases = "Band"'), "X", {},
                    "phases must be 'band' or 'alpha' (docs/MODELS.md rule 6), got 'Band'"),
    "lo-above-hi": (_law().replace("lo=0.0, hi=2.0", "lo=2.0, hi=0.0"), "X", {},
                    "parameter 'a': lo and hi must be numbers with lo <= hi"),
    # alpha_hist bins alpha: a negative alpha indexed the accumulators before the histogram
    "alpha-outside-0-1": (_law().replace("return p[ia] * y[Z], 1.0", "return p[ia] * y[Z], -0.5"),
                          "X", {}, "force gives alpha = -0.5 at the first step; alpha is the "
                          "phase, in [0, 1] (0 stick, 1 slip)"),
    # a mode update that also moved a state at every accepted step, unnoticed
    "update-modes-writes-a-state": (
        _law().replace("    def build(self, b):", "    def n_modes(self, size):\n        return 1\n\n"
                       "    def build(self, b):")
        .replace('Z, ia = b.z0, b.ix["a"]', 'Z, M, ia = b.z0, b.m0, b.ix["a"]')
        .replace("        return LawKernels(rates, force, 0, None, init, scales)",
                 "        @b.jit(inline=\"always\")\n        def modes(u, y, hold, p, landed):\n"
                 "            y[M] = 1.0\n            y[Z] = 0.5\n            return True\n\n"
                 "        return LawKernels(rates, force, 0, None, init, scales, modes)"),
        "X", {}, "update_modes writes slot 2 of the state vector, outside its 1 modes (slots 3 "
        "to 3): it sets the modes y[m0 + i] only"),
    # with atol_units = "natural" an unwritten scale left that state at atol squared (the
    # atol is filled with atol, then scaled by it), a tolerance nobody asked for
    "scales-writes-nothing": (_law().replace("out[Z] = 1.0", "pass"), "X", {},
                              "scales gives no scale for slot 2, a state under error control: "
                              "write a finite natural scale for each of its slots 2 to 2"),
})


def test_a_write_past_the_laws_states_into_another_slot_is_refused(tmp_path, monkeypatch):
    """One state declared, two used: with F_mean asked for, slot Z + 1 is the system's F
    quadrature, so the write stayed inside the vector (no bounds fault, no rate left unset)
    and the law's second "state" was the integral of F: wrong numbers, no word (found by
    review, 2026-11-28). The law's own writes are now checked against its slots."""
    rates = ("            dy[Z] = u - y[Z]\n            dy[Z + 1] = y[Z]\n"
             "            return p[ia] * (y[Z] + y[Z + 1])")
    (tmp_path / "strayslot.py").write_text(textwrap.dedent(_law(rates=rates)))
    monkeypatch.syspath_prepend(str(tmp_path))
    spec = {"friction": "strayslot:X", "dither": "none", "outputs": ["v_mean", "F_mean"],
            "time": {"t_end": 2.0, "t_transient": 1.0}}
    with pytest.raises(SpecError, match=r"strayslot:X: rates writes slot 3 of the state "
                       r"vector, outside its 1 states \(slots 2 to 2\) and 0 modes: index "
                       r"them from b\.z0 and check n_states \(at strayslot\.py line 14\)"):
        load_spec(spec)
    sys.modules.pop("strayslot", None)


_SYSTEM = '''
from engine.contract import MechanicalSystem, Param, SystemKernels, SystemOutputs

class Mass(MechanicalSystem):
    name = "mass"
    state_names = ("v",)
    dithers = ("none",)
    params = {{"c": Param(1.0, "1", "a damper", lo=0.0)}}

    def build(self, b):
        ic = b.ix["c"]

        @b.jit(inline="always")
        def drive(t, y, p, sq):
            return {drive}

        @b.jit(inline="always")
        def dynamics(t, y, p, sq, u, fext, F, dy):
            dy[0] = 1.0 - p[ic] * y[0] - F
{dynamics}

        @b.jit(inline="always")
        def position(t, y, p):
            return 0.0

        @b.jit(inline="always")
        def velocity(t, y, p, sq):
            return y[0]

        @b.jit(inline="always")
        def init(p, y):
            y[0] = 0.0

        @b.jit(inline="always")
        def scales(p, out):
{scales}

        @b.jit(inline="always")
        def start(t, y, p, sq, o):
{start}

        @b.jit(inline="always")
        def observe(t0, y0, t1, y1, ymid, p, sq, o):
            o[0] = max(o[0], y1[0])

        @b.jit(inline="always")
        def finish(t, y, p, o, out, span):
{finish}

        so = SystemOutputs(("v_peak",), 1, start, observe, finish)
        return SystemKernels(drive, dynamics, position, velocity, init, scales,
                             so if "v_peak" in b.scene.outputs else None)

    outputs = {{"v_peak": ("the largest velocity", "1")}}
'''
_SYSTEM_OK = {"drive": "y[0], 0.0, 0.0", "dynamics": "            pass",
              "start": "            o[0] = y[0]", "finish": "            out[0] = o[0]",
              "scales": "            out[0] = 1.0"}


_BAD_SYSTEMS = [
    # its one state is slot 0; the law's z is slot 1: the write was overwritten by (or
    # overwrote) the law's rate, inside the vector, without a word (found by review)
    ("into-the-law", {"dynamics": "            dy[1] = 0.5 * y[0]"},
     "badsys_into_the_law:Mass: dynamics writes slot 1 of the state vector, outside its 1 "
     "states (slots 0 to 0); the friction law's states start at b.z0 = 1: check state_names "
     "and n_tail (at badsys_into_the_law.py line 17)"),
    ("drive-returns-two", {"drive": "y[0], 0.0"},
     "badsys_drive_returns_two:Mass: drive must return (u, fext, hold), three numbers, got a "
     "tuple of 2 (at badsys_drive_returns_two.py line 13)"),
    # in the kernel `out` is a view of the point's row: out[1] was the next column (another
    # output or an alpha_hist share), `o[1]` past the accumulator's end, unchecked
    ("finish-past-its-outputs", {"finish": "            out[0] = o[0]\n            out[1] = 1.0"},
     "badsys_finish_past_its_outputs:Mass: finish writes out[1], past its 1 outputs (v_peak) "
     "(at badsys_finish_past_its_outputs.py line 46)"),
    ("start-past-its-slots", {"start": "            o[0] = y[0]\n            o[1] = 0.0"},
     "badsys_start_past_its_slots:Mass: start writes accumulator slot 1, past its 1 "
     "(SystemOutputs size) (at badsys_start_past_its_slots.py line 38)"),
    ("finish-leaves-an-output", {"finish": "            pass"},
     "badsys_finish_leaves_an_output:Mass: finish gives no value for its output 'v_peak'"),
    ("scales-into-the-law", {"scales": "            out[0] = 1.0\n            out[1] = 1.0"},
     "badsys_scales_into_the_law:Mass: scales writes slot 1, outside its own slots 0 to 0"),
]


@pytest.mark.parametrize("case, change, says", _BAD_SYSTEMS, ids=[c[0] for c in _BAD_SYSTEMS])
def test_a_brought_systems_bad_kernels_are_one_line(case, change, says, tmp_path, monkeypatch):
    """A system brought by import path is probed like a law (docs/MODELS.md rule 8): its
    init and dynamics write only its own slots, drive returns three numbers, and its own
    observables' hooks write only their slots and outputs."""
    name = f"badsys_{case.replace('-', '_')}"
    source = _SYSTEM.format(**{**_SYSTEM_OK, **change})
    (tmp_path / f"{name}.py").write_text(textwrap.dedent(source))
    monkeypatch.syspath_prepend(str(tmp_path))
    spec = {"system": f"{name}:Mass", "friction": "lugre", "dither": "none",
            "outputs": ["v_mean", "v_peak"], "time": {"t_end": 2.0, "t_transient": 1.0}}
    with pytest.raises(SpecError) as err:
        load_spec(spec)
    lines = [ln for ln in str(err.value).splitlines() if ln.strip().startswith("- ")]
    assert len(lines) == 1 and says in lines[0], str(err.value)
    sys.modules.pop(name, None)


def test_a_first_step_that_never_returns_is_one_line(tmp_path, monkeypatch):
    """A law whose rates loop forever hung ``plan`` and ``submit`` at the first-step check
    (found by review, 2026-11-28); the child running it is now killed after
    $DITHERLAB_MODEL_TIMEOUT_S, and that is one line."""
    rates = ("            k = 0\n            while k >= 0:\n                k = (k + 1) % 7\n"
             "            dy[Z] = u\n            return y[Z]")
    (tmp_path / "endless.py").write_text(textwrap.dedent(_law(rates=rates)))
    monkeypatch.syspath_prepend(str(tmp_path))
    monkeypatch.setenv("DITHERLAB_MODEL_TIMEOUT_S", "4")
    spec = {"friction": "endless:X", "dither": "none", "outputs": ["v_mean"],
            "time": {"t_end": 2.0, "t_transient": 1.0}}
    with pytest.raises(SpecError, match=r"- friction 'endless:X' on system 'slider': no "
                       r"result after 4 s -- an endless loop in its kernels, or a stiff "
                       r"model spending its step budget \(integrator = \"rodas4\"\)\? "
                       r"\(DITHERLAB_MODEL_TIMEOUT_S sets how long to wait\)"):
        load_spec(spec)
    monkeypatch.setenv("DITHERLAB_MODEL_TIMEOUT_S", "soon")
    with pytest.raises(SpecError, match="DITHERLAB_MODEL_TIMEOUT_S='soon': expected a "
                       "number of seconds"):
        load_spec({**spec, "name": "again"})
    sys.modules.pop("endless", None)


def test_a_law_and_a_system_that_share_a_parameter_name_are_refused(tmp_path, monkeypatch):
    """Before, one value set both the law's own ``m`` and the servo's mass ``m`` (one slot of
    p, one spec key), and the law's range was never checked."""
    source = _law().replace('"a": Param', '"m": Param').replace('b.ix["a"]', 'b.ix["m"]')
    (tmp_path / "clashlaw.py").write_text(textwrap.dedent(source))
    monkeypatch.syspath_prepend(str(tmp_path))
    spec = {"friction": "clashlaw:X", "system": "servo", "dither": "none",
            "outputs": ["v_mean"], "params": {"m": 0.3}}
    with pytest.raises(SpecError, match="parameter 'm' is declared by both friction "
                       "'clashlaw:X' and system 'servo': rename it in one of the two models"):
        load_spec(spec)
    sys.modules.pop("clashlaw", None)


def test_a_number_where_a_vector_parameter_takes_a_list_is_one_line():
    """``gms = { k = 100.0, ... }`` (a one-element GMS written without brackets) was an
    internal error, exit 1: ``TypeError: 'float' object is not iterable``."""
    spec = {"friction": "gms", "dither": "none", "outputs": ["v_mean"],
            "params": {"gms": {"k": 100.0, "alpha": 1.0, "C": 20.0}}}
    with pytest.raises(SpecError, match=r"params\.k: expected a list of numbers, got 100\.0"):
        load_spec(spec)


def test_a_law_whose_init_allocates_runs_in_a_block_as_in_the_api(tmp_path, monkeypatch):
    """docs/MODELS.md does not forbid allocating in a model's kernels. The block kernel
    compiles run_point into itself; compiled without numba's runtime (a review of 33cdc22)
    it refused ``np.zeros`` in such an ``init``, after the spec check had passed: every
    block failed. The block and the API give the same bits."""
    import numpy as np

    from engine import params as P
    from engine.blocks import run_block

    source = _law().replace("from engine", "import numpy as np\nfrom engine").replace(
        "            y[Z] = 0.0", "            tmp = np.zeros(2)\n            y[Z] = tmp[0]")
    (tmp_path / "allocinit.py").write_text(textwrap.dedent(source))
    monkeypatch.syspath_prepend(str(tmp_path))
    plan = make_plan(load_spec({"friction": "allocinit:X", "dither": "sine-velocity",
                                "outputs": ["v_mean"], "time": {"t_end": 0.5,
                                                                "t_transient": 0.1},
                                "grid": {"W": [0.3], "omega": [20.0], "v_ref": [0.1]}}))
    res = run_block(plan.scene, plan.block_points(0), plan.params, plan.numerics.settings)
    q = plan.params.copy()
    q[[P.W, P.OMEGA, P.V_REF, P.VD]] = plan.block_points(0)[0]
    one = simulate(plan.scene, q, plan.numerics.settings)
    assert list(res.status) == [one.status] == [0]
    assert res.outputs["v_mean"][0].tobytes() == np.float64(one.outputs["v_mean"]).tobytes()
    sys.modules.pop("allocinit", None)


@pytest.mark.parametrize("case", sorted(BAD))
def test_bad_user_code_is_one_line(case, tmp_path, monkeypatch):
    source, attr, params, says = BAD[case]
    name = f"badlaw_{case.replace('-', '_')}"
    (tmp_path / f"{name}.py").write_text(textwrap.dedent(source))
    monkeypatch.syspath_prepend(str(tmp_path))
    spec = {"friction": f"{name}:{attr}", "dither": "none", "outputs": ["v_mean"],
            "time": {"t_end": 2.0, "t_transient": 1.0}, "params": params}
    with pytest.raises(SpecError) as err:
        load_spec(spec)
    text = str(err.value)
    lines = [ln for ln in text.splitlines() if ln.strip().startswith("- ")]
    assert len(lines) == 1, text
    assert says in lines[0], text
    assert "Traceback" not in text
    sys.modules.pop(name, None)


def test_the_averaged_path_of_a_law_with_a_steady_curve(examples_on_path):
    """F_eff of the brought GMS is the phase average of its steady curve (checked against
    scipy's adaptive quad to 1e-10), and the chart's class follows the slope's sign."""
    import numpy as np
    from scipy.integrate import quad

    from engine.analysis.block import analysis_block

    own = {"k": [40.0, 100.0], "alpha": [0.4, 0.6], "C": 20.0}
    ref = "mylab.laws:MaxwellSlip"
    p = registry.pack(ref, "slider", own)
    scene = Scene.from_params(p, friction=ref, dither="sine-velocity", path="averaged",
                              outputs=("F_eff", "stable"),
                              sizes=registry.sizes_of(ref, "slider", own))
    pts = np.array([[W, np.inf, v, 0.1] for W in (0.0, 0.2, 0.5) for v in (0.05, 0.1, 0.3)])
    out, status = analysis_block(scene, pts, p)
    assert (status == 0).all()

    def f_ss(u):
        s = 1.0 + 0.5 * np.exp(-(u / 0.1) ** 2)
        return np.sign(u) * s + 0.004 * u

    for (W, _, v, _), F in zip(pts, out["F_eff"]):
        kink = [np.arccos(-v / W)] if W > abs(v) else None
        exact = quad(lambda phi: f_ss(v + W * np.cos(phi)), 0.0, np.pi, points=kink,
                     epsabs=1e-13, epsrel=1e-13, limit=200)[0] / np.pi
        assert F == pytest.approx(exact, abs=1e-10), (W, v)
    # no dither: the Stribeck branch (v < ~0.1) falls with v (unstable), beyond it rises
    assert out["stable"][:3].tolist() == [0.0, 0.0, 1.0]


NO_STEADY = _law()


def test_averaged_is_refused_for_a_law_without_a_steady_curve(tmp_path, monkeypatch):
    (tmp_path / "nosteady.py").write_text(textwrap.dedent(NO_STEADY))
    monkeypatch.syspath_prepend(str(tmp_path))
    with pytest.raises(SpecError, match="needs the law's steady-state friction curve"):
        load_spec({"friction": "nosteady:X", "method": "averaged", "dither": "sine-velocity"})
    sys.modules.pop("nosteady", None)
