"""What a run shows, as the runner sees it: a display handed in by its caller (``progress``
of :func:`sweeps.run.submit.submit`), called and never imported. The display's code (tqdm
bars and lines: :class:`sweeps.run.phases.Shown`) is off the computing path
(sweeps.version): an edit of a progress message keeps every sweep current. Nothing the run
computes comes back from a display's call, so what it shows cannot change a number.

:data:`QUIET` is the display that shows nothing: the runner's when the caller hands none
(``progress=False``). The methods, those of ``Shown`` too:

- ``bar(plan, phase, total, unit, initial=0)``: a counted phase; the bar has ``update(n=1)``,
  ``set_postfix_str(text)``, ``keep_alive()``, ``close()`` and is a context manager;
- ``display(plan)``: ``bar`` for the error estimate's re-runs (sweeps.estimates), or None;
- ``starting(plan, workers)``, ``compiling()``: an uncounted phase (a timer: called while
  waiting, then ``close()``);
- ``say(plan, phase)``, ``note(text)``: one line;
- ``attached(sweep_id)``: ``show(row)``, called on every poll while another process runs
  the sweep (sweeps.run.lease_holder.wait_while_held).
"""
from __future__ import annotations


class Silent:
    """A bar or a timer that shows nothing."""

    def __call__(self) -> None:
        pass

    def update(self, n: int = 1) -> None:
        pass

    def set_postfix_str(self, text: str) -> None:
        pass

    def keep_alive(self) -> None:
        pass

    def close(self) -> None:
        pass

    def __enter__(self) -> Silent:
        return self

    def __exit__(self, *exc) -> bool:
        return False


class Quiet:
    """The display that shows nothing (module docstring)."""

    def bar(self, plan, phase: str, total: int, unit: str, initial: int = 0) -> Silent:
        return Silent()

    def display(self, plan):
        return None

    def starting(self, plan, workers) -> Silent:
        return Silent()

    def compiling(self) -> Silent:
        return Silent()

    def say(self, plan, phase: str) -> None:
        pass

    def note(self, text: str) -> None:
        pass

    def attached(self, sweep_id: str):
        return lambda row: None


QUIET = Quiet()


def display_of(progress) -> Quiet:
    """The display a runner shows: ``progress`` itself, or :data:`QUIET` for a falsy one.
    A caller wanting bars hands a display (``sweeps.run.phases.shown(True)``): ``True``
    is refused here, where the runner would otherwise import the display's code."""
    if progress is True:
        raise TypeError("progress: a display (sweeps.run.phases.shown(True)) or False, not True")
    return progress or QUIET
