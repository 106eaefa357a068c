"""Progress of long work: a bar on a terminal, plain lines otherwise, nothing when quiet.

``tqdm`` draws the bar (it is a small pure-Python dependency and the common
choice; it measures the rate and the time left). When stderr is not a
terminal (a log file, CI, a pipe) a line with the count, rate and time left
is printed every ``interval`` seconds (5) while the work lasts and at the
end, so logs stay short; work done within 2 s prints none. ``corr-cad run
--quiet`` switches all of it off.

The lines keep coming when the counter does not move: a thread prints the
line again every ``interval`` (the time left from the elapsed time). The
time left is measured only once enough of the work is done
(:data:`TRUST_SHARE` of it, at least :data:`TRUST_DONE` units), or after
:data:`TRUST_S` seconds or the estimate's own time: before that
it is the resource estimate's (``estimated 2m50s left``) or ``? left``; a
rate from the first point or two once read "280h22m left". :func:`heartbeat`
does the same for a stage with no counter of its own (a solve, an export);
it counts from the stage's start, and once a counter of the stage exists it
prints that counter's line in its place, so a stage whose counter starts
late still prints a line within ``interval`` of its start.
"""

from __future__ import annotations

import math
import sys
import threading
import time
from collections.abc import Iterator
from contextlib import contextmanager
from typing import TextIO

__all__ = [
    "set_enabled",
    "enabled",
    "load_factor",
    "Progress",
    "progress",
    "heartbeat",
    "close_all",
    "duration",
]

_ENABLED = True
#: When any progress line was last printed, or a stage started (monotonic s):
#: a line is due when none came for ``_DUE * interval``.
_LAST_LINE = [0.0]
#: Counters not closed yet (:func:`close_all` ends them when their stage ends; a
#: heartbeat prints the newest one's line).
_OPEN: set = set()
#: Held while a line is judged due and printed (re-entrant: a heartbeat prints
#: a counter's line under it).
_LOCK = threading.RLock()


def set_enabled(on: bool) -> None:
    """Switch every progress display on or off (``--quiet`` switches it off)."""
    global _ENABLED
    _ENABLED = bool(on)


def enabled() -> bool:
    return _ENABLED


def load_factor(workers: int = 1) -> tuple[float, float, int]:
    """``(factor, load average, CPUs)``: how many times longer work takes at the machine's
    present load than on a quiet one. ``workers`` processes of this run share the CPUs
    with the one-minute load average's runnable processes: ``(load + workers) / CPUs``,
    at least 1 (1 where the load average is unknown)."""
    import os

    cpus = os.cpu_count() or 1
    try:
        load = os.getloadavg()[0]
    except (OSError, AttributeError):  # no load average on this platform
        return 1.0, 0.0, cpus
    return max(1.0, (load + max(workers, 1)) / cpus), load, cpus


def duration(seconds: float) -> str:
    """``45s``, ``3m05s``, ``2h10m``."""
    s = int(round(seconds))
    if s < 60:
        return f"{s}s"
    if s < 3600:
        return f"{s // 60}m{s % 60:02d}s"
    return f"{s // 3600}h{(s % 3600) // 60:02d}m"


#: Plain progress lines start only once the work has taken this long, s.
QUIET_S = 2.0
#: The measured rate gives the time left from this share of the work on ...
TRUST_SHARE = 0.02
#: ... and at least this many units (all of them if fewer).
TRUST_DONE = 2
#: ... or, with TRUST_DONE units done, from this many seconds on (or once the
#: estimate has run out), s.
TRUST_S = 30.0


#: A thread checks ten times an interval and prints from 0.9 of it: no gap passes it.
_DUE = 0.9


def _emit(stream: TextIO, text: str) -> None:
    with _LOCK:
        print(text, file=stream, flush=True)
        _LAST_LINE[0] = time.monotonic()


class _Ticker:
    """A daemon thread calling ``fn`` every ``interval`` s until stopped."""

    def __init__(self, interval: float, fn) -> None:
        self._stop = threading.Event()
        self._fn, self._interval = fn, interval
        self._thread = threading.Thread(target=self._loop, name="corr-cad-progress", daemon=True)
        self._thread.start()

    def _loop(self) -> None:
        while not self._stop.wait(self._interval / 10.0):
            self._fn()

    def stop(self) -> None:
        self._stop.set()
        if self._thread is not threading.current_thread():
            self._thread.join(1.0)


class Progress:
    """Counts ``total`` units of work; ``update(n)`` after each piece is done.

    ``expected``: the estimated seconds of the whole work (the resource
    estimate), shown as the time left until the measured rate is trusted.
    """

    def __init__(
        self,
        total: int,
        desc: str,
        unit: str = "it",
        *,
        stream: TextIO | None = None,
        interval: float = 5.0,
        tty: bool | None = None,
        expected: float | None = None,
    ) -> None:
        self.total, self.desc, self.unit = int(total), desc, unit
        self.stream = stream or sys.stderr
        self.interval = interval
        self.expected = expected
        self.done = 0
        self.t0 = time.monotonic()
        self._last = self.t0
        self._bar = None
        self._ticker = None
        self.on = _ENABLED and self.total > 0
        is_tty = tty if tty is not None else getattr(self.stream, "isatty", lambda: False)()
        if self.on and is_tty:
            from tqdm import tqdm

            self._bar = tqdm(total=self.total, desc=desc, unit=unit, file=self.stream, leave=False)
        elif self.on and interval >= 1.0:
            self._ticker = _Ticker(interval, self._tick)
            with _LOCK:
                _OPEN.add(self)

    def time_left(self) -> str:
        """``2m50s left`` (measured), ``estimated 2m50s left`` or ``? left``."""
        elapsed = max(time.monotonic() - self.t0, 1e-9)
        need = min(self.total, max(TRUST_DONE, math.ceil(TRUST_SHARE * self.total)))
        # A long run's rate is trusted after TRUST_S too, and once the estimate has
        # run out: a million samples at 40/s read "estimated 12m left" for 8 minutes.
        waited = elapsed >= TRUST_S or (self.expected is not None and elapsed >= self.expected)
        if self.done > 0 and (self.done >= need or (waited and self.done >= TRUST_DONE)):
            return f"{duration((self.total - self.done) * elapsed / self.done)} left"
        if self.expected is not None and elapsed < self.expected:
            return f"estimated {duration(self.expected - elapsed)} left"
        return "? left"

    def line(self) -> str:
        """``desc: done/total unit (pct%), rate unit/s, left ETA``."""
        elapsed = max(time.monotonic() - self.t0, 1e-9)
        rate = self.done / elapsed
        pct = 100.0 * self.done / self.total if self.total else 100.0
        return (
            f"{self.desc}: {self.done}/{self.total} {self.unit} ({pct:.0f}%), "
            f"{rate:.3g} {self.unit}/s, {self.time_left()}"
        )

    def _print(self, now: float) -> None:
        self._last = now
        _emit(self.stream, self.line())

    def _tick(self) -> None:
        """The line again when the counter has not printed for an interval."""
        with _LOCK:  # a heartbeat may be printing this line now
            now = time.monotonic()
            if now - self.t0 >= QUIET_S and now - self._last >= _DUE * self.interval:
                self._print(now)

    def update(self, n: int = 1) -> None:
        self.done += n
        if not self.on:
            return
        if self._bar is not None:
            self._bar.update(n)
            return
        now = time.monotonic()
        if now - self.t0 < min(self.interval, QUIET_S):
            return  # work done within a couple of seconds needs no progress line
        if now - self._last >= self.interval or self.done >= self.total:
            self._print(now)

    def close(self) -> None:
        if self._ticker is not None:
            self._ticker.stop()
            self._ticker = None
            with _LOCK:
                _OPEN.discard(self)
        if self._bar is not None:
            self._bar.close()
            self._bar = None


def close_all() -> None:
    """Close every counter still open (a stage that raised left its own running)."""
    for p in list(_OPEN):
        p.close()


@contextmanager
def progress(total: int, desc: str, unit: str = "it", **kw) -> Iterator[Progress]:
    """``with progress(n, "montecarlo", "samples") as p: ... p.update(k)``."""
    p = Progress(total, desc, unit, **kw)
    try:
        yield p
    finally:
        p.close()


@contextmanager
def heartbeat(
    desc: str,
    expected: float | None = None,
    *,
    stream: TextIO | None = None,
    interval: float = 5.0,
) -> Iterator[None]:
    """``desc: 10s elapsed, estimated 25s left`` every ``interval`` s while the block runs.

    Quiet while another progress line was printed within the interval, on
    a terminal (the bar shows the work) and with ``--quiet``; while a counter
    runs, its line instead of the elapsed time.
    """
    stream = stream or sys.stderr
    if not _ENABLED or getattr(stream, "isatty", lambda: False)() or interval < 1.0:
        yield
        return
    t0 = time.monotonic()
    past = [False]  # "past the estimate" said
    with _LOCK:
        _LAST_LINE[0] = max(_LAST_LINE[0], t0)  # the stage's start counts as its first line

    def tick() -> None:
        with _LOCK:
            now = time.monotonic()
            if now - _LAST_LINE[0] < _DUE * interval:
                return
            counters = [p for p in _OPEN if p.on and p.stream is stream]
            if counters:  # the stage's counter says more than "elapsed"
                max(counters, key=lambda p: p.t0)._print(now)
                return
            elapsed = now - t0
            if expected is None:
                left = ""
            elif elapsed <= expected:
                left = f", estimated {duration(expected - elapsed)} left"
            elif not past[0]:  # said once a stage; then the elapsed time alone
                left, past[0] = f", past the estimate of {duration(expected)}", True
            else:
                left = ""
            _emit(stream, f"{desc}: {duration(elapsed)} elapsed{left}")

    ticker = _Ticker(interval, tick)
    try:
        yield
    finally:
        ticker.stop()
