"""Every gallery figure at the small size: its PNG renders, and the numbers behind each
verdict match an expected value whose source is named (the paper's figure or equation, an
exact result, or an independent computation written out here).

The two figures of dask sweeps over the elasto-plastic slider (fig14, beyond_scaling:
~1 min) are marked slow.
"""
import numpy as np
import pytest

from engine import params as P
from sweeps.gallery.build import FIGURES, build
from sweeps.gallery.context import Context
from sweeps.gallery.verdicts import HOLDS, PARTLY

SLOW = {"fig14", "beyond_scaling"}
# the module's fixture draws 15 figures (about 2 min of CPU): on a 2-core machine shared by
# seven jobs (load 30) it took over 15 min, past the suite's 900 s hang guard
pytestmark = [pytest.mark.long, pytest.mark.timeout(2400),   # long: whole figures of the gallery
              pytest.mark.cluster]
PNG = b"\x89PNG\r\n\x1a\n"


@pytest.fixture(scope="module")
def gallery(tmp_path_factory):
    root = tmp_path_factory.mktemp("gallery")
    ctx = Context(size="small", outdir=root / "out", store=root / "store", workers=1)
    return {r.key: r for r in build(ctx, only=set(FIGURES) - SLOW, log=lambda m: None)}, ctx


def test_every_figure_renders_and_the_page_is_written(gallery):
    results, ctx = gallery
    assert set(results) == set(FIGURES) - SLOW
    for r in results.values():
        data = r.png.read_bytes()
        assert data[:8] == PNG and len(data) > 10_000, r.key
        assert not any(c.claim == "computation" for c in r.checks), (r.key, r.reason)
    html = (ctx.outdir / "index.html").read_text()
    md = (ctx.outdir / "gallery.md").read_text()
    for r in results.values():
        assert f"src='{r.png.name}'" in html and f"]({r.png.name})" in md
        assert r.verdict in md


def test_small_verdicts(gallery):
    """The paper model's verdicts (per reading too) at the small size: what the wrong models
    of tests/sweeps/gallery/test_wrong_models.py must change."""
    from tests.sweeps.gallery.test_wrong_models import CORRECT

    results = gallery[0]
    assert {k: (results[k].verdict, results[k].readings) for k in CORRECT} == CORRECT


def test_the_page_has_conventions_readings_and_the_loose_section(gallery):
    results, ctx = gallery
    md, html = (ctx.outdir / "gallery.md").read_text(), (ctx.outdir / "index.html").read_text()
    assert "## Where the paper is loose or wrong" in md and "id='loose'" in html
    for r in results.values():
        for x in r.loose:
            assert x in md
    assert "convention: 'strong attenuation'" in md and "*vd = 0.01*" in md
    assert "align-items:flex-start" in html            # no stretched images
    assert "<div class='fig wide' id='fig01'>" in html  # 1188 x 324 px: above its text


def _contact_asymptote(n_max=5, n=4096):
    """Independent: the omega -> infinity friction of the Sec. 3 contact model. The bristle
    state freezes at Z, and <dz/dt> = 0 gives Y = sigma0 Z = v_m / <|u|/g(u)> (average over
    one period); F(t) = Y + sigma1(u) (u - |u| Y / g(u)) with u = v_m + v_a cos(theta).
    Returns F at the least velocity and the harmonic amplitudes |F_1..F_n_max| (N)."""
    c = P.CONTACT_DEFAULTS
    th = 2 * np.pi * np.arange(n) / n
    u = 1e-3 + 1e-3 * np.cos(th)
    g = c["fc"] + (c["fs"] - c["fc"]) * np.exp(-np.abs(u) / c["vs"])
    Y = 1e-3 / np.mean(np.abs(u) / g)
    F = Y + c["sigma1"] * np.exp(-(u / c["vd"]) ** 2) * (u - np.abs(u) * Y / g)
    amps = 2 * np.abs(np.fft.rfft(F)) / n
    return Y, amps[1:n_max + 1]


def test_fig01_loops(gallery):
    r = gallery[0]["fig01"]
    Y, _ = _contact_asymptote()
    assert r.numbers["F_vmin_high"] == pytest.approx(Y, abs=1e-3)   # independent asymptote
    assert r.numbers["F_vmin_low"] > r.numbers["F_vmin_high"]       # Fig. 1 text: decreases
    assert r.numbers["area_end_ratio"] < 0.01                       # Fig. 1: negligible loop
    assert r.numbers["stiff_shift"] > 1.0                           # Sec. 3: stiffer, higher
    assert r.verdict == HOLDS


def test_fig02_harmonics_at_high_frequency_are_the_asymptote_s(gallery):
    r = gallery[0]["fig02"]
    _, amps = _contact_asymptote()
    for n in range(1, 6):
        assert r.numbers[f"F{n}_high_dd2"] == pytest.approx(amps[n - 1], abs=5e-4), n
    # the asymptote's third harmonic exceeds the low-frequency one: the total fails, ...
    assert amps[2] > 2 * r.numbers["F3_low_dd2"]
    # ... while the bristle force sigma0 z loses every harmonic (its asymptote is the
    # constant Y: no harmonics at all)
    for dd in ("dd2", "dd1"):
        assert max(r.numbers[f"ratio_sigma0_F{n}_{dd}"] for n in range(2, 6)) < 1e-3
    assert r.verdict == PARTLY
    assert set(r.readings.values()) == {PARTLY}


def test_fig05_slopes(gallery):
    r = gallery[0]["fig05"]
    for W in (0.25, 0.5, 1.0):
        assert r.numbers[f"eq513_dev_W{W}"] < 0.05       # Eq. 5.13 against the curve
        # Eq. 5.14 at v = 0: slope sigma2 + g'(W), g'(W) = -(fs - fc) 2 W / vs^2 e^-(W/vs)^2
        g1 = -0.5 * 2 * W / 0.01 * np.exp(-(W / 0.1) ** 2)
        assert r.numbers[f"static_slope_W{W}"] == pytest.approx(0.004 + g1, abs=1e-6)
    assert r.numbers["n_secondary_vd0.1_W0.5"] >= 1      # Fig. 5(a): a secondary zone
    assert r.numbers["secondary_ratio"] < 1 / 3          # much smaller at vd = 0.01 ...
    assert r.numbers["secondary_width_vd0.01_W0.5"] > 0  # ... but not gone
    assert r.verdict == PARTLY                           # the static slope at W = 0.25


def test_fig07_slopes_are_eq_5_21(gallery):
    r = gallery[0]["fig07"]
    for a in (0.5, 0.75):   # the full model (Stribeck, damping) near Eq. 5.21's slope
        assert r.numbers[f"slope_{a}"] == pytest.approx(np.pi / (2 * a) + 0.004, rel=0.01)
    assert r.numbers["eq520_gap"] < 1e-8                 # Eq. 5.20 = scipy's average
    assert r.verdict == HOLDS


@pytest.mark.parametrize("key", ["fig06", "fig08"])
def test_simulated_friction_follows_the_averaged_curve(gallery, key):
    r = gallery[0][key]
    for vd in (0.1, 0.01):        # Figs. 6, 8: the simulation validates the averaged theory
        assert r.numbers[f"rms_{vd}"] < 0.05


def test_fig09_zones(gallery):
    from sweeps.gallery.reference import averaged_max_eig

    r = gallery[0]["fig09"]
    limit = r.numbers["v_ref_limit"]
    # independent: the undithered system's growth rate changes sign within 1e-5 of it
    assert averaged_max_eig(limit - 1e-5, 0.0, 0.1) > 0 > averaged_max_eig(limit + 2e-5, 0.0, 0.1)
    assert r.numbers["SU_0.1"] > 0 and r.numbers["SU_0.1_beyond"] > 0  # Fig. 9(a): the minor zone
    assert r.numbers["ref_points"] > 50 and r.numbers["ref_disagree"] == 0
    assert r.numbers["stable_share_above_vref"] == 1.0              # Sec. 6 text, v_ref ~ vs


def test_fig09b_thin_strips_remain_at_vd_001(gallery):
    """Fig. 9(b) shows no secondary zone for vd = 0.01, but a fine W grid finds thin SU
    strips along W = v_ref + 0.01. Independent check at v_ref = 0.005: central differences
    of the averaged right-hand side (Eqs. 6.4-6.6) at the equilibrium (Eq. 6.7) give an
    unstable eigenvalue at W = 0.017, inside the strip, and none at W = 0.008 and 0.03, on
    either side of it, so the strip is cut off from W = 0 (SU, not PU)."""
    from engine.analysis.stability import averaged_rhs, equilibrium

    r = gallery[0]["fig09"]
    assert r.numbers["fine_SU_vref_0.01"] >= 1
    assert 1e-3 < r.numbers["fine_SU_width_0.01"] < 2e-2
    assert r.verdict != HOLDS       # the claim holds only at the scene's coarser grid

    def growth(W, v_ref=0.005, vd=0.01):
        x0 = np.array([float(c) for c in equilibrium(v_ref, W, P.pack(), vd=vd)])
        J = np.empty((3, 3))
        for k in range(3):
            e = np.zeros(3)
            e[k] = 1e-7 * max(1.0, abs(x0[k]))
            J[:, k] = (averaged_rhs(x0 + e, v_ref, W, P.pack(), vd=vd)
                       - averaged_rhs(x0 - e, v_ref, W, P.pack(), vd=vd)) / (2 * e[k])
        return np.linalg.eigvals(J).real.max()

    assert growth(0.017) > 0 > max(growth(0.008), growth(0.03))


def test_fig10_quenching(gallery):
    r = gallery[0]["fig10"]
    assert r.numbers["p2p_0.1_W0.0"] > 0.5                # Fig. 10(a): self-sustained
    assert r.numbers["p2p_0.1_W0.4"] < 0.01               # Fig. 10(d): quenched
    assert r.numbers["p2p_0.1_W0.6"] < 0.01               # Fig. 10(f): quenched


def test_fig12_undithered_stick_share_is_the_reference(gallery):
    r = gallery[0]["fig12"]
    # DESIGN.md / docs/MODEL.md Sec. 7 (scripts/reference_phases.py): stick 0.5269104
    assert r.numbers["stick_W0.0_vd0.1"] == pytest.approx(0.5269104, abs=1e-3)
    for vd in (0.1, 0.01):
        n = {k[: -len(f"_vd{vd}")]: x for k, x in r.numbers.items() if k.endswith(f"_vd{vd}")}
        assert n["max_stick_W0.0"] > 0.5                       # Fig. 12(a): long stick
        assert max(n["max_stick_W1.5"], n["max_stick_W2.5"]) < 0.5   # 12(c), (e)
        assert n["slip_W2.5"] > n["slip_W1.5"]                 # Figs. 12(d), (f)
    assert r.readings == {"vd = 0.1": PARTLY, "vd = 0.01": HOLDS}


def test_fig11_fig13_sticking(gallery):
    r11, r13 = gallery[0]["fig11"], gallery[0]["fig13"]
    assert r11.numbers["stop_W0.0"] > 0.5 > max(r11.numbers["stop_W1.5"],
                                                  r11.numbers["stop_W2.5"])
    assert r13.numbers["stop_W0.5"] > 0.5 > r13.numbers["stop_W1.5"]   # Figs. 13(a), (c)
    assert r13.numbers["extent_W0.5"] > r13.numbers["extent_W0.8"]      # Sec. 7 text


def test_fig15_to_17(gallery):
    r15, r16 = gallery[0]["fig15"], gallery[0]["fig16"]
    for v in (0.1, 0.5, 1.0):
        assert r15.numbers[f"max_stick_v{v}"] > 0.5 > r16.numbers[f"max_stick_v{v}_W1.5"]
    F = [r16.numbers[f"F_mean_v{v}_W1.5"] for v in (0.1, 0.5, 1.0)]
    assert F == sorted(F)                                  # Figs. 16(b), (d), (f)


def test_beyond_sine_slope_ratio_is_pi_over_2(gallery):
    # independent: <|W sin|> = 2 W / pi against the square wave's W (fc dominates g at W)
    assert gallery[0]["beyond_sine"].numbers["slope_ratio"] == pytest.approx(np.pi / 2, rel=0.02)


@pytest.mark.slow
def test_fig14_zone_and_scaling(tmp_path):
    ctx = Context(size="small", outdir=tmp_path / "out", store=tmp_path / "store", workers=2)
    res = {r.key: r for r in build(ctx, only=SLOW, log=lambda m: None)}
    wc = [v for k, v in res["fig14"].numbers.items() if k.startswith("omega_c_W")]
    assert len(wc) >= 3 and wc == sorted(wc)               # Fig. 14: omega_c grows with W
    assert res["beyond_scaling"].numbers["ratio_spread"] < 2.0
    for r in res.values():
        assert r.png.read_bytes()[:8] == PNG
