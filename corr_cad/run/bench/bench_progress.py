"""How the progress lines behave on a real run: their gaps and how close their time left comes.

A sweeps scene runs through the CLI in a child process (serial executor),
its stderr read line by line and each line stamped as it arrives. For each
counter line (``sweeps: 18/900 points (2%), 1.5 points/s, 9m58s left``) the
study records when it came, the gap since the one before (the first:
since the stage's start line), the time left it
states and the time the run then really took. Table, ``progress.csv`` and
``progress.png``. Nothing is asserted here: the tests check the rules on a
fake clock (``tests/test_progress.py``); this measures them on the machine,
whose load stretches every number.
"""

from __future__ import annotations

import re
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

from corr_cad.run.bench.bench_common import _table, _write_csv

__all__ = ["progress_study", "left_seconds"]

SCENE = '[export]\nformats = ["sweeps"]\n[load]\ninput_torque = 1.1e5\n[sweeps]\npoints = {}\n'
#: A counter line of the progress channel (``corr_cad.run.progress.Progress.line``).
_COUNTER = re.compile(
    r"^\s*(?P<desc>[^:]+): (?P<done>\d+)/(?P<total>\d+) .*?, "
    r"(?P<est>estimated )?(?P<left>\S+) left$"
)
#: A stage's heartbeat line (``corr_cad.run.progress.heartbeat``).
_HEARTBEAT = re.compile(
    r"^\s*(?P<desc>[^:]+): \S+ elapsed"
    r"(?:, estimated (?P<left>\S+) left|, past the estimate of \S+)?$"
)


def left_seconds(text: str) -> float | None:
    """Seconds of a stated time left: ``45s``, ``3m05s``, ``2h10m``; None for ``?``.

    >>> left_seconds("3m05s"), left_seconds("2h10m"), left_seconds("?")
    (185.0, 7800.0, None)
    """
    m = re.fullmatch(r"(?:(\d+)h)?(?:(\d+)m)?(?:(\d+)s)?", text)
    if text == "?" or not m or not any(m.groups()):
        return None
    h, mi, s = (int(g or 0) for g in m.groups())
    return float(3600 * h + 60 * mi + s)


def _stamped_lines(folder: Path, points: int) -> tuple[list[tuple[float, str]], float]:
    """stdout and stderr lines of one run with their arrival times (s), and its duration."""
    (folder / "s.toml").write_text(SCENE.format(points))
    cmd = [sys.executable, "-m", "corr_cad", "run", "s.toml", "--out", "out", "--executor",
           "serial", "--warn-time", "3600"]  # fmt: skip
    t0 = time.monotonic()
    p = subprocess.Popen(cmd, cwd=folder, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                         text=True)  # fmt: skip
    got: list[tuple[float, str]] = []

    def read() -> None:
        for line in p.stdout:
            got.append((time.monotonic() - t0, line.rstrip("\n")))

    reader = threading.Thread(target=read, daemon=True)
    reader.start()
    p.wait()
    total = time.monotonic() - t0
    reader.join()
    if p.returncode != 0:
        raise RuntimeError(f"the progress study's run failed: {got[-3:]}")
    return got, total


def progress_study(out: Path, quick: bool = False) -> list:
    """One row per counter line of a sweeps run; table, CSV and PNG."""
    import shutil

    from corr_cad.export.bench_plots import progress_png

    points = 20 if quick else 300
    folder = Path(tempfile.mkdtemp(prefix="corr-cad-bench-"))
    try:
        got, total = _stamped_lines(folder, points)
    finally:
        shutil.rmtree(folder, ignore_errors=True)
    counted = [(t, m) for t, m in ((t, _COUNTER.match(ln)) for t, ln in got) if m]
    # The counter's work ends at its last line (done = total): the time left it
    # states is that of its stage, not of the run (plots, report and commit follow).
    end = next((t for t, m in counted if m.group("done") == m.group("total")), total)
    # The first gap counts from the stage's own start line ("[2/3] sweeps: ..."); a
    # heartbeat line ("sweeps: 5s elapsed, ...", before the counter starts) is a line too.
    start = next((t for t, ln in got if re.match(r"^\[\d+/\d+\] sweeps: ", ln)), 0.0)
    rows, last = [], start
    for t, line in got:
        m, h = _COUNTER.match(line), _HEARTBEAT.match(line)
        if t < start or not (m or h):
            continue
        stated = left_seconds((m or h).group("left") or "?")
        kind = "heartbeat" if h else ("estimate" if m.group("est") else "measured")
        rows.append(
            [
                round(t, 3),
                round(t - last, 3),
                int(m.group("done")) if m else "",
                int(m.group("total")) if m else "",
                kind if stated is not None or h else "?",
                stated if stated is not None else float("nan"),
                round(end - t, 3),
            ]
        )
        last = t
    header = ["t_s", "gap_s", "done", "total", "time_left_from", "stated_left_s", "actual_left_s"]
    _table(
        f"Progress lines of a sweeps run ({points} points per sweep, {total:.1f} s)", header, rows
    )
    _write_csv(out, "progress.csv", header, rows)
    progress_png(out / "progress.png", rows, total)
    return rows
