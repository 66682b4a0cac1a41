"""What a submitter shows while it works, phase by phase: the points (a tqdm bar per run of
blocks, with the error estimate's finer re-runs that run among them counted beside:
``error estimate k/N``), the re-runs still running after the last point (``error estimate
k/N``, a bar of its own) and the cube's last publish. Each phase is named when it starts, so the display never sits at "99 %" while
work it does not mention goes on (the estimate's re-runs took ~20 s on a 100-point draft
Fig. 14 sweep, after the last point).

The runner never imports this module: its caller (the command line, ``run_sweep``, serve)
hands it a display, :func:`shown` (sweeps.run.quiet: the methods a display has). So the
display is off the computing path (sweeps.version), and its wording can change freely."""
from __future__ import annotations

import functools
import os
import sys
import time

MININTERVAL_S = 0.5   # tqdm redraws at most this often (a phase change redraws at once)
REDRAW_S = 5.0        # ... and at least this often while a phase's work goes on (issue 38:
                      # the estimate of a 100-point sweep showed nothing new for 10.2 s)


def bar(plan, phase: str, total: int, unit: str, enabled: bool, initial: int = 0):
    """A tqdm bar ``<name> [<id>] <phase>: k/total`` (from ``initial``); a no-op bar when
    not ``enabled``. Its ``keep_alive()``, called while waiting, redraws it (elapsed time,
    rate, ETA) when nothing was drawn for REDRAW_S: a task can run longer than that."""
    # miniters=1: tqdm's adaptive miniters skipped the redraws of a run's last blocks (it
    # showed 84 % until the bar closed, 13 s later)
    return _bar_class()(total=total, unit=unit,
                        desc=f"{plan.spec.name} [{plan.sweep_id}] {phase}",
                        disable=not enabled, mininterval=MININTERVAL_S, miniters=1,
                        initial=initial, **unsized())


def unsized() -> dict:
    """tqdm's size for a terminal that answers 0 columns and rows (a pty nobody sized:
    ``script``'s, some CI runners'): 80 x 20. tqdm took those zeros as a width of 0 and a
    last row of -1, and drew nothing at all, not even the phase's name, for a whole sweep.
    Elsewhere nothing: tqdm asks the terminal (or takes its defaults off one)."""
    try:
        size = os.get_terminal_size(sys.stderr.fileno())
    except (AttributeError, OSError, ValueError):   # not a terminal
        return {}
    return {} if size.columns > 0 and size.lines > 0 else {"ncols": 80, "nrows": 20}


@functools.cache
def _bar_class():
    from tqdm import tqdm

    class Bar(tqdm):
        def keep_alive(self) -> None:
            if not self.disable and time.time() - self.last_print_t >= REDRAW_S:
                self.refresh()
                # tqdm's refresh() leaves last_print_t alone: without this, every call after
                # the first 5 s redrew (a line per wait-loop turn, thousands a minute in a log)
                self.last_print_t = time.time()

    return Bar


def display(plan, enabled: bool):
    """``display(phase, total, unit, initial=0) -> bar`` for a phase counted elsewhere (the
    error estimate, sweeps.estimates), or None when progress is off."""
    if not enabled:
        return None
    return lambda phase, total, unit, initial=0: bar(plan, phase, total, unit, True, initial)


def say(plan, phase: str, enabled: bool) -> None:
    """One line naming a phase without a count (publishing the cube)."""
    if enabled:
        print(f"{plan.spec.name} [{plan.sweep_id}] {phase}", file=sys.stderr, flush=True)


def close_bars() -> None:
    """Close the bars still open (a run that raised): each draws its last state and ends its
    line, so the fault's one line that follows stands alone (sweeps.cli.main). Where stderr
    was no terminal, that line was glued onto a bar's last redraw, and a bar closed at exit
    drew itself again below it (a fault campaign, 2026-11-29: disk full, Ctrl-C)."""
    tqdm = sys.modules.get("tqdm")
    for open_bar in list(getattr(getattr(tqdm, "tqdm", None), "_instances", None) or ()):
        open_bar.close()


class Timer:
    """A phase without a count that can take seconds to a minute (a cluster starting, a
    first compilation): the first call shows ``<desc>: <elapsed>``, the next calls, made
    while waiting, keep it alive (redrawn every REDRAW_S); :meth:`close` ends it. Nothing
    when not ``enabled``."""

    def __init__(self, desc: str, enabled: bool):
        self.desc, self.enabled, self._bar = desc, enabled, None

    def __call__(self) -> None:
        if not self.enabled:
            return
        if self._bar is None:
            self._bar = _bar_class()(desc=self.desc, bar_format="{desc}: {elapsed}",
                                     mininterval=MININTERVAL_S, **unsized())
        self._bar.keep_alive()

    def close(self) -> None:
        if self._bar is not None:
            self._bar.close()
            self._bar = None


def starting(plan, workers: int, enabled: bool) -> Timer:
    """``<name> [<id>] starting a local cluster of N workers: 00:02``."""
    return Timer(f"{plan.spec.name} [{plan.sweep_id}] starting a local cluster of {workers} "
                 "workers", enabled)


def compiling(enabled: bool) -> Timer:
    """Said after NOTICE_AFTER_S of a kernel's warm-up (sweeps.run.local, the cluster's)."""
    return Timer("ditherlab: compiling the engine for this scene (its first run here; cached "
                 "for later runs)", enabled)


class Shown:
    """The display of a run shown on stderr (sweeps.run.quiet names its methods)."""

    def bar(self, plan, phase: str, total: int, unit: str, initial: int = 0):
        return bar(plan, phase, total, unit, True, initial)

    def display(self, plan):
        return display(plan, True)

    def starting(self, plan, workers) -> Timer:
        return starting(plan, workers, True)

    def compiling(self) -> Timer:
        return compiling(True)

    def say(self, plan, phase: str) -> None:
        say(plan, phase, True)

    def note(self, text: str) -> None:
        print(text, file=sys.stderr, flush=True)

    def attached(self, sweep_id: str):
        from .progress import attached_lines

        return attached_lines(sweep_id)


def shown(progress: bool):
    """The display a caller hands the runner: :class:`Shown`, or False (nothing shown)."""
    return Shown() if progress else False
