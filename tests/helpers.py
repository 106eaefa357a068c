"""Helpers shared by the tests.

``without_progress``: stderr with the progress channel's lines removed. A run
prints progress lines to stderr on a timer (``corr_cad/run/progress.py``:
a counter's ``desc: done/total unit (pct%), rate unit/s, ... left`` and a
stage's heartbeat ``desc: 5s elapsed, ...``) whenever a stage takes longer
than a few seconds, which depends on the machine's load. A test that
compares stderr, or counts its lines, compares it without them.
"""

from __future__ import annotations

import json
import re
from pathlib import Path

__all__ = ["PROGRESS_LINE", "folder_files", "is_progress_line", "without_progress"]

_DURATION = r"(?:\d+s|\d+m\d\ds|\d+h\d\dm)"
_LEFT = rf"(?:(?:estimated )?{_DURATION}|\?) left"
#: One line of the progress channel: a counter's line or a stage's heartbeat.
PROGRESS_LINE = re.compile(
    r"^\s*\S[^:]*: (?:"
    rf"\d+/\d+ (?P<unit>\S.*?) \(\d+%\), \S+ (?P=unit)/s, {_LEFT}"  # Progress.line()
    rf"|{_DURATION} elapsed(?:, estimated {_DURATION} left|, past the estimate of {_DURATION})?"
    r")$"
)


def is_progress_line(line: str) -> bool:
    """Whether ``line`` (without its newline) is a line of the progress channel."""
    return PROGRESS_LINE.match(line.rstrip("\r\n")) is not None


def without_progress(text: str) -> str:
    """``text`` (a captured stderr) without the progress channel's lines."""
    return "".join(line for line in text.splitlines(keepends=True) if not is_progress_line(line))


def folder_files(out: Path) -> dict:
    """Every file's bytes in the output folder ``out``; ``manifest.json`` without its
    stages' timings (the one file two runs of a scene may write differently)."""
    got = {}
    for p in sorted(out.iterdir()):
        if p.name == "manifest.json":
            m = json.loads(p.read_text())
            m.pop("stages", None)
            got[p.name] = m
        else:
            got[p.name] = p.read_bytes()
    return got
