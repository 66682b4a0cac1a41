"""A simulated sweep's blocks: balanced by the price :func:`work_s` puts on them (the
dither's amplitude included), and about BLOCK_SECONDS each when the points are dear, so
that many workers finish within a block of each other (issue 37: Fig. 14's 961 points
were 61 blocks of 16 points, 5.7 s each on the lent 16-core machine, and 16 workers ran
their points phase at 0.94: a fourth round of blocks for 13 of them), with the work of
the last ones in smaller blocks (scripts/schedule_projection.py: Fig. 14's measured point
costs list-scheduled on 16 workers run at 0.957 in the old blocks, 0.989 in these)."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from sweeps.planning.blocks import TAIL_BLOCKS
from sweeps.planning.plan import BLOCK_SECONDS, make_plan, work_s
from sweeps.spec import load_spec, parse_spec

FIG14 = Path(__file__).resolve().parents[3] / "specs" / "fig14.toml"


def _prices(plan):
    return np.array([work_s(plan, b) for b in plan.blocks])


def test_fig14s_blocks_are_about_block_seconds_and_alike_with_a_tail_of_smaller_ones():
    plan = make_plan(load_spec(FIG14))
    prices = _prices(plan)
    assert np.isclose(prices.sum(), work_s(plan, np.arange(961)))   # every point, once
    assert sorted(np.concatenate(plan.blocks).tolist()) == list(range(961))
    # enough for 16 workers to take 8 rounds each (was 61 blocks: under 4 rounds)
    n, t = len(plan.blocks), TAIL_BLOCKS
    assert n >= 8 * 16, n
    # in the dispatch's order, longest expected first: whole blocks, then the work of the
    # last TAIL_BLOCKS in halves and quarters (a point dearer than a quarter alone in one)
    assert np.all(np.diff(prices) <= 0)
    whole, halves, quarters = prices[:n - 3 * t], prices[n - 3 * t:n - 2 * t], prices[n - 2 * t:]
    assert 0.9 <= whole.min() / BLOCK_SECONDS and whole.max() / BLOCK_SECONDS <= 1.1, whole
    assert 0.45 <= halves.min() / BLOCK_SECONDS and halves.max() / BLOCK_SECONDS <= 0.55, halves
    assert 0.2 <= quarters.min() / BLOCK_SECONDS and quarters.max() / BLOCK_SECONDS <= 0.4, \
        quarters


def test_blocks_balance_the_dither_amplitudes_price():
    """A grid from W = 0 (hardly dithered: W_SHARE) to W = 3 and omega 100 to 1000: the
    blocks carry the same price, W included. Balanced by omega alone, as before, they
    spread 1.6x (Fig. 14: 2.0 to 3.2 s)."""
    spec = parse_spec({
        "name": "amplitudes", "friction": "lugre", "dither": "sine-velocity",
        "method": "simulate", "outputs": ["v_mean"], "accuracy": "standard",
        "time": {"t_end": 10.0, "t_transient": 5.0},
        "grid": {"W": {"start": 0.0, "stop": 3.0, "num": 20},
                 "omega": {"start": 100.0, "stop": 1000.0, "num": 20, "scale": "log"},
                 "v_ref": [0.2], "v_d": [0.1]}})
    plan = make_plan(spec)
    prices = _prices(plan)
    assert 8 < len(plan.blocks) < 3 * TAIL_BLOCKS   # (no tail of smaller blocks)
    assert prices.max() / prices.min() < 1.15, (prices.min(), prices.max())
