"""Ctrl-C or SIGTERM while the command line starts: one line and exit 130 or 143.

``import corr_cad`` loads numpy and scipy (about 0.7 s); the command line's
own SIGINT and SIGTERM handling (:func:`corr_cad.run.cli.main`) starts after
that and after the command line's own modules (seconds on a busy machine).
This module is imported first by ``corr_cad/__init__.py`` and, only when the
process is the ``corr-cad`` command (the console script or ``python -m
corr_cad``), holds SIGINT and SIGTERM until ``main`` takes over: a signal then
has created nothing, so it prints the documented line and exits 130 (SIGINT)
or 143 (SIGTERM), as a run interrupted later does. A library import (a
notebook, the tests) is left alone.
"""

from __future__ import annotations

import os
import signal
import sys
import threading

#: The line printed for an interrupt before the run started (nothing was written).
LINE = b"corr-cad: interrupted (SIGINT); previous outputs left as they were\n"
#: The same for SIGTERM (a service manager, ``timeout``, ``kill``).
LINE_TERM = b"corr-cad: interrupted (SIGTERM); previous outputs left as they were\n"


def is_cli() -> bool:
    """Whether this process is the ``corr-cad`` command."""
    argv0 = os.path.basename(sys.argv[0]) if sys.argv else ""
    if argv0 in ("corr-cad", "corr-cad.exe"):
        return True
    orig = list(getattr(sys, "orig_argv", ()))
    for i, a in enumerate(orig[:-1]):
        if a == "-m" and orig[i + 1] in ("corr_cad", "corr_cad.__main__"):
            return True
    return False


def _interrupted(signum, frame) -> None:
    term = signum == signal.SIGTERM
    os.write(2, LINE_TERM if term else LINE)
    os._exit(143 if term else 130)


def guard() -> None:
    """Install the start-up SIGINT and SIGTERM handler in the ``corr-cad`` process (else
    nothing). SIGTERM is taken unless it was ignored when the process started (``nohup``)."""
    if threading.current_thread() is not threading.main_thread() or not is_cli():
        return
    if signal.getsignal(signal.SIGINT) is signal.default_int_handler:
        signal.signal(signal.SIGINT, _interrupted)
    if signal.getsignal(signal.SIGTERM) is signal.SIG_DFL:
        signal.signal(signal.SIGTERM, _interrupted)


def is_guard(handler: object) -> bool:
    """Whether ``handler`` is the start-up handler (``main`` replaces it)."""
    return handler is _interrupted


guard()
