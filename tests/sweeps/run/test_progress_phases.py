"""The progress display names each phase of a submit (issue 27): the points, with the error
estimate's finer re-runs counted ``k/N`` beside them (they run among the blocks, issue 37)
and on a bar of their own if some are left after the points, then publishing the cube; it
no longer sits at "99 %" while the estimate runs unmentioned (a 100-point draft Fig. 14
sweep showed 95 % for 13 s, then 100 % for 6 s more). Checked on the sequence of states the
display went through (tqdm redraws with a carriage return), not on their timing.

Here a quiet run and the bars' redraw; a submit's phases in order, on threads and on a
local cluster: tests/e2e/test_progress_phases.py."""
import re


from sweeps.planning.plan import make_plan
from sweeps.run.phases import shown
from sweeps.run.submit import submit
from sweeps.spec import parse_spec
from tests.helpers import SIMULATE_OUTPUTS

# 8 points in 4 blocks of 2: a few seconds once the kernel is in the disk cache (the e2e
# spec's outputs: its Scene, one compilation for both)
SPEC = {"name": "phases", "friction": "lugre", "dither": "square-velocity",
        "method": "simulate", "outputs": list(SIMULATE_OUTPUTS), "accuracy": "draft",
        "block_size": 2, "time": {"t_end": 12.0, "t_transient": 4.0},
        "grid": {"W": [0.0, 0.2, 0.4, 0.6], "omega": [300.0, 1000.0], "v_ref": [0.4],
                 "v_d": [0.1]}}


def _states(err: str, plan) -> list[str]:
    """The display's states that belong to this sweep, prefix removed, in order."""
    head = f"{plan.spec.name} [{plan.sweep_id}] "
    return [s.strip()[len(head):] for s in re.split(r"[\r\n]", err)
            if s.strip().startswith(head)]


def test_a_quiet_submit_shows_nothing(tmp_path, capfd):
    avg = {"name": "quiet", "method": "averaged", "friction": "lugre",   # in-process, ms
           "grid": {"W": [0.0, 0.5], "v_ref": [0.1, 0.5]}}
    plan = make_plan(parse_spec(avg))
    assert submit(plan, tmp_path / "store", progress=False).state == "done"
    assert _states(capfd.readouterr().err, plan) == []
    plan = make_plan(parse_spec({**avg, "grid": {"W": [0.0, 0.4], "v_ref": [0.1, 0.5]}}))
    assert submit(plan, tmp_path / "store", progress=shown(True)).state == "done"
    phases = [s.split(":")[0] for s in _states(capfd.readouterr().err, plan)]
    assert phases[0] == "points" and phases[-1] == "publishing the cube", phases


def test_a_bar_left_still_is_redrawn_while_work_goes_on(capfd):
    """A task can run longer than 10 s (a first compilation, a costly re-run): the loops
    that wait call ``keep_alive()``, which redraws a bar nothing redrew for REDRAW_S
    (elapsed time, rate) and leaves a fresh one alone (issue 38)."""
    from sweeps.run import phases

    plan = make_plan(parse_spec(SPEC))
    bar = phases.bar(plan, "points", plan.n_points, "point", True)
    capfd.readouterr()
    bar.keep_alive()
    assert capfd.readouterr().err == ""   # drawn just now
    bar.last_print_t -= phases.REDRAW_S + 1
    bar.keep_alive()
    assert _states(capfd.readouterr().err, plan)[-1].startswith("points:")
    for _ in range(100):   # the wait loops call it every few ms: one redraw per REDRAW_S
        bar.keep_alive()
    assert capfd.readouterr().err == ""
    timer = phases.starting(plan, 2, True)
    timer()
    timer._bar.last_print_t -= phases.REDRAW_S + 1
    timer()
    timer.close()
    states = _states(capfd.readouterr().err, plan)
    assert len(states) >= 2 and all(s.startswith("starting a local cluster of 2 workers: ")
                                    for s in states), states
    bar.close()


def test_a_terminal_of_zero_columns_still_shows_the_phases(monkeypatch):
    """A pty nobody sized (``script``'s, some CI runners') answers 0 columns; tqdm then
    drew nothing, not even the phase's name, for a whole sweep (seen with ``script -q -c
    'ditherlab submit ...'``: blank lines until the summary)."""
    import fcntl
    import os
    import struct
    import termios

    from sweeps.run import phases

    master, slave = os.openpty()
    fcntl.ioctl(slave, termios.TIOCSWINSZ, struct.pack("HHHH", 0, 0, 0, 0))
    with os.fdopen(slave, "w") as tty:
        monkeypatch.setattr("sys.stderr", tty)
        plan = make_plan(parse_spec(SPEC))
        bar = phases.bar(plan, "points", plan.n_points, "point", True)
        bar.update(3)
        bar.close()
        timer = phases.compiling(True)
        timer()
        timer.close()
        tty.flush()
        monkeypatch.undo()
    text = _drain(master).decode()
    assert _states(text, plan)[-1].startswith("points:  38%"), text
    assert "compiling the engine" in text


def _drain(master: int) -> bytes:
    """Everything written to the pty, its other end closed: one read may return only part
    of it (a CI run got the first redraw alone), so read until the end (EIO on Linux)."""
    import os

    out = b""
    try:
        while chunk := os.read(master, 65536):
            out += chunk
    except OSError:   # EIO: drained, and nobody holds the other end
        pass
    finally:
        os.close(master)
    return out


def test_a_fault_line_stands_below_the_bars_not_inside_one(capfd):
    """A run that raised (a full disk, a Ctrl-C) left its bar open: where stderr is no
    terminal, the fault's one line was glued onto the bar's last redraw, and the bar,
    closed at exit, drew itself again below it (a fault campaign, 2026-11-29)."""
    from sweeps.cli.main import _fail
    from sweeps.run import phases

    plan = make_plan(parse_spec(SPEC))
    bar = phases.bar(plan, "points", plan.n_points, "point", True)
    bar.update(3)
    assert _fail("No space left on device", 1) == 1
    del bar   # (as at exit)
    err = capfd.readouterr().err
    assert err.endswith("\nditherlab: No space left on device\n"), repr(err[-300:])
