"""Timing, tables and CSV for the benchmarks: medians of repeated runs, the machine stated."""

from __future__ import annotations

import os
import statistics
import time
from collections.abc import Callable, Sequence
from pathlib import Path

M0 = 1.1e5


def _median_time(fn: Callable[[], object], repeat: int) -> float:
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return statistics.median(times)


def _median_cpu_time(fn: Callable[[], object], repeat: int) -> float:
    times = []
    for _ in range(repeat):
        t0 = time.process_time()
        fn()
        times.append(time.process_time() - t0)
    return statistics.median(times)


def _machine() -> str:
    return f"{os.cpu_count()} cores"


def _write_csv(out: Path, name: str, header: Sequence[str], rows) -> Path:
    from corr_cad.export.files import write_csv

    return write_csv(out / name, header, ([_cell(x) for x in r] for r in rows))


def _cell(x) -> str:
    return f"{x:.6g}" if isinstance(x, float) else str(x)


def _table(title: str, header: Sequence[str], rows) -> None:
    print(f"\n{title} ({_machine()})")
    print("  ".join(f"{h:>14s}" for h in header))
    for r in rows:
        print("  ".join(f"{_cell(x):>14s}" for x in r))
