"""Ctrl-C while the command line starts: one line and exit 130, never a traceback.

``import corr_cad`` loads numpy and scipy (about 0.7 s); the command line's
own SIGINT handling (:func:`corr_cad.run.cli.main`) starts after that. This
module is imported first by ``corr_cad/__init__.py`` and, only when the
process is the ``corr-cad`` command (the console script or ``python -m
corr_cad``), holds SIGINT until ``main`` takes over: an interrupt then has
created nothing, so it prints the documented line and exits 130. A library
import (a notebook, the tests) is left alone.
"""

from __future__ import annotations

import os
import signal
import sys
import threading

#: The line printed for an interrupt before the run started (nothing was written).
LINE = b"corr-cad: interrupted (SIGINT); previous outputs left as they were\n"


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
    os.write(2, LINE)
    os._exit(130)


def guard() -> None:
    """Install the start-up SIGINT handler in the ``corr-cad`` process (else nothing)."""
    if threading.current_thread() is not threading.main_thread() or not is_cli():
        return
    if signal.getsignal(signal.SIGINT) is signal.default_int_handler:
        signal.signal(signal.SIGINT, _interrupted)


def is_guard(handler: object) -> bool:
    """Whether ``handler`` is the start-up handler (``main`` replaces it)."""
    return handler is _interrupted


guard()
