"""Progress lines on a fake clock: when they come and what time left they state.

``corr_cad/run/progress.py`` reads the time from ``time.monotonic`` and prints
from a ticker thread. Here the module's clock is a counter the test moves and
the ticker a stub the test calls, at the ticker's own cadence (a tenth of the
interval): the lines, their gaps and their "time left" follow from the rules
alone (first line after :data:`QUIET_S`, one at least every interval, the
estimate's time left until 2 % of the work is done, then the measured rate),
whatever the machine's load. What the lines cost and how close their time
left comes on a real run is measured by ``corr-cad bench --study progress``.

Also checks ``tests/helpers.py``: every line the channel prints is
recognised as a progress line, and no line of the run's own output is.
"""

from __future__ import annotations

import io
import math
from types import SimpleNamespace

import pytest

from corr_cad.run import progress
from tests.helpers import is_progress_line, without_progress


class _Clock:
    def __init__(self) -> None:
        self.t = 1000.0

    def __call__(self) -> float:
        return self.t


@pytest.fixture
def clock(monkeypatch):
    """The progress module on a fake clock, its tickers stubs the test calls."""
    c = _Clock()
    c.tickers = []

    class Ticker:
        def __init__(self, interval, fn):
            c.tickers.append(fn)

        def stop(self):
            pass

    monkeypatch.setattr(progress, "time", SimpleNamespace(monotonic=c))
    monkeypatch.setattr(progress, "_Ticker", Ticker)
    monkeypatch.setattr(progress, "_LAST_LINE", [0.0])
    monkeypatch.setattr(progress, "_OPEN", set())
    monkeypatch.setattr(progress, "_ENABLED", True)
    return c


def _run_ticks(clock, tick, until: float, step: float) -> None:
    """Move the clock to ``until`` (s after now) in ``step``s, ticking at each."""
    end = clock.t + until
    while clock.t < end - 1e-9:
        clock.t += step
        tick()


def test_time_left_is_the_estimate_until_two_percent_then_the_measured_rate(clock):
    buf = io.StringIO()
    p = progress.Progress(900, "      sweeps", "points", stream=buf, tty=False, expected=60.0)
    assert p.time_left() == "estimated 1m00s left"
    clock.t += 10.0
    p.update(1)  # one point of 900 says nothing about the rate ("280h22m left" once)
    assert p.time_left() == "estimated 50s left"
    p.update(16)  # 17 < ceil(2 % of 900) = 18
    assert p.time_left() == "estimated 50s left"
    p.update(1)  # 18 done in 10 s: (900 - 18) * 10 / 18 = 490 s left
    assert p.time_left() == "8m10s left"
    clock.t += 100.0  # past the estimate: measured, never negative
    assert p.time_left() == f"{progress.duration((900 - 18) * 110.0 / 18)} left"
    p.close()
    q = progress.Progress(10, "work", stream=buf, tty=False)  # no estimate
    assert q.time_left() == "? left"
    clock.t += 1.0
    q.update(2)  # at least two units before a rate is trusted
    assert q.time_left() == "4s left"
    q.close()


def test_a_line_at_least_every_interval_while_the_counter_does_not_move(clock):
    """The ticker's cadence is a tenth of the interval; it prints from 0.9 of it."""
    buf = io.StringIO()
    p = progress.Progress(900, "      sweeps", "points", stream=buf, tty=False, interval=5.0)
    (tick,) = clock.tickers
    t0, times = clock.t, []

    def counted():
        before = buf.getvalue().count("\n")
        tick()
        if buf.getvalue().count("\n") > before:
            times.append(clock.t - t0)

    end = clock.t + 60.0
    while clock.t < end - 1e-9:
        clock.t += 0.5
        counted()
    p.close()
    assert times[0] == pytest.approx(4.5)  # quiet for QUIET_S, then 0.9 of the interval
    gaps = [b - a for a, b in zip(times, times[1:], strict=False)]
    assert len(times) >= 12 and max(gaps) <= 5.0
    assert all(is_progress_line(ln) for ln in buf.getvalue().splitlines())


def test_work_done_quickly_prints_nothing_and_the_last_unit_prints_the_end(clock):
    buf = io.StringIO()
    with progress.progress(4, "work", "items", stream=buf, tty=False) as p:
        clock.t += 1.0
        p.update(4)  # within QUIET_S: nothing
    assert buf.getvalue() == ""
    with progress.progress(4, "work", "items", stream=buf, tty=False) as p:
        clock.t += 3.0
        p.update(4)
    (line,) = buf.getvalue().splitlines()
    assert line == "work: 4/4 items (100%), 1.33 items/s, 0s left"


def test_heartbeat_states_elapsed_and_the_estimate_then_the_stage_s_counter(clock):
    """A stage prints a line within the interval of its start, even when its counter
    starts late: the heartbeat prints the counter's line then (a counter made 3 s
    into the stage printed its first line 7.4 s after the stage's start)."""
    buf = io.StringIO()
    with progress.heartbeat("      preview_png", 3.0, stream=buf, interval=5.0):
        (tick,) = clock.tickers
        _run_ticks(clock, tick, 4.0, 0.5)
        assert buf.getvalue() == ""
        _run_ticks(clock, tick, 0.5, 0.5)  # 4.5 s: the first line, past the 3 s estimate
        assert buf.getvalue() == "      preview_png: 4s elapsed, past the estimate of 3s\n"
    buf = io.StringIO()
    with progress.heartbeat("      sweeps", 60.0, stream=buf, interval=5.0):
        beat = clock.tickers[-1]
        _run_ticks(clock, beat, 3.0, 0.5)
        counter = progress.Progress(120, "      sweeps", "points", stream=buf, tty=False)
        count = clock.tickers[-1]
        times, t0 = [], clock.t - 3.0
        for _ in range(40):  # 20 s more, both tickers at their cadence
            clock.t += 0.5
            before = buf.getvalue().count("\n")
            count()
            beat()
            if buf.getvalue().count("\n") > before:
                times.append(clock.t - t0)
            counter.update(1)
        counter.close()
    lines = buf.getvalue().splitlines()
    assert times[0] == pytest.approx(4.5)  # from the stage's start, not the counter's
    assert max(b - a for a, b in zip([0.0, *times], times, strict=False)) <= 5.0
    assert len(lines) == len(times)  # one line per due time, never two at once
    assert all(ln.startswith("      sweeps: ") and "points/s" in ln for ln in lines), lines
    buf = io.StringIO()
    with progress.heartbeat("      step_files (in a worker)", None, stream=buf, interval=5.0):
        _run_ticks(clock, clock.tickers[-1], 10.0, 0.5)
    with progress.heartbeat("      forces", 30.0, stream=buf, interval=5.0):
        _run_ticks(clock, clock.tickers[-1], 5.0, 0.5)
    assert buf.getvalue().splitlines() == [
        "      step_files (in a worker): 4s elapsed",
        "      step_files (in a worker): 9s elapsed",
        "      forces: 4s elapsed, estimated 26s left",
    ]


def test_helper_recognises_the_progress_channel_and_nothing_else(clock):
    lines = []
    for total, done, secs, expected in ((900, 17, 10.0, 60.0), (900, 18, 10.0, None),
                                        (5, 5, 7300.0, None), (3, 1, 2.0, None)):  # fmt: skip
        p = progress.Progress(total, "      allocation", "Monte Carlo runs", tty=False,
                              expected=expected)  # fmt: skip
        clock.t += secs
        p.done = done
        lines.append(p.line())
        p.close()
    buf = io.StringIO()
    for desc, expected, secs in (("      preview_png", 3.0, 4.5), ("      dxf", 600.0, 3700.0),
                                 ("      step_files (in a worker)", None, 65.0)):  # fmt: skip
        with progress.heartbeat(desc, expected, stream=buf, interval=5.0):
            _run_ticks(clock, clock.tickers[-1], secs, secs / math.ceil(secs / 0.5))
    lines += buf.getvalue().splitlines()
    assert len(lines) > 6
    for ln in lines:
        assert is_progress_line(ln), ln
    theirs = [
        "[3/5] montecarlo: Monte Carlo over [tolerances]",
        "[10/21] step_files: STEP AP214 parts and assembly, read back (in a worker)",
        "      check montecarlo max_gear_force: pass (failure probability 0, allowed 0.5)",
        "      sweep eccentricity 1.2..1.8 mm (default): 2/2 points solved",
        "      class +0 um: backlash 3.208 arcmin",
        "corr-cad: warning: the run would take about 1m30s (sweeps 1m20s); --warn-time S",
        "corr-cad: error: [export] tolerance = 1e-30: allowed range is [1e-06, 10]",
        "estimate: peak memory ~601 MB (budget 3072 MB), files ~3 MB, time ~13s",
        "corr-cad: interrupted (SIGTERM); previous outputs left as they were",
    ]
    for ln in theirs:
        assert not is_progress_line(ln), ln
    text = "\n".join(theirs[:2] + lines + theirs[2:]) + "\n"
    assert without_progress(text) == "\n".join(theirs) + "\n"


def test_a_long_run_trusts_its_measured_rate_after_thirty_seconds(clock):
    # A million Monte Carlo samples at 40/s stated "estimated 12m20s left" from
    # the resource estimate for 8 minutes (2 % of the work), while 7 hours remained.
    buf = io.StringIO()
    p = progress.Progress(1_000_000, "montecarlo", "samples", stream=buf, tty=False, expected=840.0)
    clock.t += 29.0
    p.update(1160)
    assert p.time_left() == "estimated 13m31s left"  # before TRUST_S: the estimate
    clock.t += 1.0
    p.update(40)  # 1200 in 30 s: 40/s, (1e6 - 1200) / 40 s left
    assert p.time_left() == f"{progress.duration((1_000_000 - 1200) / 40.0)} left"
    p.close()


def test_an_estimate_that_has_run_out_is_not_stated_as_zero_left(clock):
    buf = io.StringIO()
    p = progress.Progress(12, "montecarlo", "samples", stream=buf, tty=False, expected=1.0)
    clock.t += 3.0
    assert p.time_left() == "? left"  # it said "estimated 0s left" at 0 %
    p.update(2)  # past the estimate, two units done: the measured rate
    assert p.time_left() == "15s left"
    p.close()


def test_a_stage_says_it_is_past_its_estimate_once(clock):
    """A stage far past its estimate on a busy machine printed "past the estimate" on
    every heartbeat (27 such lines in one run); once, then the elapsed time alone."""
    buf = io.StringIO()
    with progress.heartbeat("      step", 3.0, stream=buf, interval=5.0):
        (tick,) = clock.tickers
        _run_ticks(clock, tick, 30.0, 0.5)
    lines = buf.getvalue().splitlines()
    assert len(lines) >= 5
    assert [ln for ln in lines if "past the estimate" in ln] == [lines[0]]
    assert lines[1].endswith("s elapsed")
    assert all(is_progress_line(ln) for ln in lines)


@pytest.mark.parametrize(
    "load,workers,factor", [(0.0, 2, 1.0), (1.0, 1, 1.0), (9.0, 2, 5.5), (3.0, 1, 2.0)]
)
def test_the_load_factor_shares_the_cpus_with_the_load(monkeypatch, load, workers, factor):
    """(load + workers) / CPUs, at least 1: 2 CPUs, a load of 9 and 2 workers: 5.5 times."""
    import os

    monkeypatch.setattr(os, "cpu_count", lambda: 2)
    monkeypatch.setattr(os, "getloadavg", lambda: (load, load, load))
    assert progress.load_factor(workers) == (factor, load, 2)


def test_the_estimate_line_says_the_time_at_the_present_load(monkeypatch):
    import os

    from corr_cad.run.budget.resources import Budget, estimate
    from corr_cad.run.scene.scene import parse_scene

    scene = parse_scene({"export": {"formats": ["forces"]}, "load": {"input_torque": 1.1e5}})
    est = estimate(scene, 2, "process")
    monkeypatch.setattr(os, "cpu_count", lambda: 2)
    monkeypatch.setattr(os, "getloadavg", lambda: (0.0, 0.0, 0.0))
    quiet = est.line(Budget())
    assert "present load" not in quiet
    monkeypatch.setattr(os, "getloadavg", lambda: (9.0, 9.0, 9.0))
    busy = est.line(Budget())
    assert busy.startswith(quiet + " on a quiet machine, ~")
    assert busy.endswith(" at the present load (load average 9.0 on 2 CPUs)")
