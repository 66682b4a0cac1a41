"""The exceptions of ``sweeps`` and the exit status each one ends a command with.

Every fault reaches a user as one line: ``ditherlab: <message>`` on the command line, the
exception's message in Python. Exit status (README): 0 success, 1 a run or a lookup failed
(:data:`EXIT_FAILED`), 2 the input was refused (:data:`EXIT_REFUSED`), 130 interrupted.
"""
from __future__ import annotations

EXIT_FAILED, EXIT_REFUSED, EXIT_INTERRUPTED = 1, 2, 130
MAX_PROBLEMS = 20                 # lines of one refusal (then "... and N more")
MAX_LINE = 300                    # characters of one message line, whatever it echoes


class UserError(Exception):
    """A lookup or argument problem, reported as one line without a traceback."""

    exit_status = EXIT_FAILED


class RefusedError(UserError, ValueError):
    """An argument refused before anything ran (exit 2)."""

    exit_status = EXIT_REFUSED


class AmbiguousSweepError(RefusedError, LookupError):
    """A sweep name or id prefix that matches several current sweeps; the message lists
    them and says to pass an id."""


class Interrupted(Exception):
    """Ctrl-C (or SIGTERM to ``submit``), told with what was kept and how to resume."""

    exit_status = EXIT_INTERRUPTED


class Terminated(KeyboardInterrupt):
    """SIGTERM to ``submit`` (a batch system's end of a job, ``kill``): the way of a Ctrl-C,
    the journal kept and the sweep left to resume, one line (exit 143, 128 + SIGTERM). It
    died of the signal instead, printing nothing, its row ``stalled``."""

    exit_status = 143


class InferredPointsWarning(UserWarning):
    """A refined sweep's cube (``refine = true``) holds inferred points, whose outputs are a
    computed neighbour's: they settle the map's class there, not the values. Filter it
    where only classes are read: ``warnings.simplefilter("ignore", InferredPointsWarning)``."""


class SpecError(ValueError):
    """A refused spec; ``problems`` holds one message per fault (at most
    :data:`MAX_PROBLEMS` lines of at most :data:`MAX_LINE` characters)."""

    exit_status = EXIT_REFUSED

    def __init__(self, problems: list[str], more: int = 0):
        lines = [p if len(p) <= MAX_LINE else p[:MAX_LINE - 3] + "..."
                 for p in (" ".join(str(p).split()) for p in problems[:MAX_PROBLEMS])]
        more += max(0, len(problems) - MAX_PROBLEMS)
        if more:
            lines.append(f"spec: ... and {more} more faults")
        self.problems = problems = lines
        super().__init__("invalid sweep spec:\n" + "\n".join(f"  - {p}" for p in problems))
