"""Progress of long loops: a bar on a terminal, plain lines otherwise, nothing when quiet.

``tqdm`` draws the bar (it is a small pure-Python dependency and the common
choice; it measures the rate and the time left). When stderr is not a
terminal (a log file, CI, a pipe) a line with the count, rate and time left
is printed at most every ``interval`` seconds and at the end, so logs stay
short. ``corr-cad run --quiet`` switches all of it off.
"""

from __future__ import annotations

import sys
import time
from collections.abc import Iterator
from contextlib import contextmanager
from typing import TextIO

__all__ = ["set_enabled", "enabled", "Progress", "progress"]

_ENABLED = True


def set_enabled(on: bool) -> None:
    """Switch every progress display on or off (``--quiet`` switches it off)."""
    global _ENABLED
    _ENABLED = bool(on)


def enabled() -> bool:
    return _ENABLED


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


class Progress:
    """Counts ``total`` units of work; ``update(n)`` after each piece is done."""

    def __init__(
        self,
        total: int,
        desc: str,
        unit: str = "it",
        *,
        stream: TextIO | None = None,
        interval: float = 5.0,
        tty: bool | None = None,
    ) -> None:
        self.total, self.desc, self.unit = int(total), desc, unit
        self.stream = stream or sys.stderr
        self.interval = interval
        self.done = 0
        self.t0 = time.monotonic()
        self._last = self.t0
        self._bar = None
        self.on = _ENABLED and self.total > 0
        is_tty = tty if tty is not None else getattr(self.stream, "isatty", lambda: False)()
        if self.on and is_tty:
            from tqdm import tqdm

            self._bar = tqdm(total=self.total, desc=desc, unit=unit, file=self.stream, leave=False)

    def line(self) -> str:
        """``desc: done/total unit (pct%), rate unit/s, left ETA``."""
        elapsed = max(time.monotonic() - self.t0, 1e-9)
        rate = self.done / elapsed
        left = (self.total - self.done) / rate if rate > 0 else float("inf")
        eta = duration(left) if left != float("inf") else "?"
        pct = 100.0 * self.done / self.total if self.total else 100.0
        return (
            f"{self.desc}: {self.done}/{self.total} {self.unit} ({pct:.0f}%), "
            f"{rate:.3g} {self.unit}/s, {eta} left"
        )

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
            self._last = now
            print(self.line(), file=self.stream, flush=True)

    def close(self) -> None:
        if self._bar is not None:
            self._bar.close()
            self._bar = None


@contextmanager
def progress(total: int, desc: str, unit: str = "it", **kw) -> Iterator[Progress]:
    """``with progress(n, "montecarlo", "samples") as p: ... p.update(k)``."""
    p = Progress(total, desc, unit, **kw)
    try:
        yield p
    finally:
        p.close()
