"""An interrupt that must end the run even where Python swallows it.

The command line's SIGINT and SIGTERM handlers record the signal here
before they raise. Python prints and drops an exception raised inside a
garbage-collector callback, a ``__del__`` or a weakref callback ("Exception
ignored in ... KeyboardInterrupt"); the run would then go on, commit and
exit 0. The record survives: the output folder checks it before its commit
(:meth:`corr_cad.run.folder.outputs.StagingDir`), and ``main`` once more at the
end, so the run ends as an interrupt always does (exit 130 or 143, one
line).
"""

from __future__ import annotations

import signal
import sys

__all__ = ["mark", "pending", "clear", "check", "unraisable_hook"]

_PENDING: list[int] = []


def mark(signum: int) -> None:
    """Record that ``signum`` (SIGINT or SIGTERM) arrived."""
    if not _PENDING:
        _PENDING.append(signum)


def pending() -> int | None:
    """The first recorded signal not yet acted on, or None."""
    return _PENDING[0] if _PENDING else None


def clear() -> None:
    _PENDING.clear()


class Terminated(KeyboardInterrupt):
    """SIGTERM, handled like Ctrl-C (exit 143 instead of 130)."""


def check() -> None:
    """Raise the recorded interrupt again (a safe point: nothing is half done)."""
    signum = pending()
    if signum is None:
        return
    raise Terminated() if signum == signal.SIGTERM else KeyboardInterrupt()


def unraisable_hook(unraisable) -> None:
    """An interrupt raised where Python cannot pass it on (a GC callback, ``__del__``).

    Its handler recorded it (:mod:`corr_cad.run.interrupts`): the run still
    ends as interrupted. No "Exception ignored" block; anything else goes to
    Python's own hook.
    """
    if isinstance(unraisable.exc_value, KeyboardInterrupt):
        return
    sys.__unraisablehook__(unraisable)
