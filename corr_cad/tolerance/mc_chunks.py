"""Chunks of the Monte Carlo: how many samples a task takes, and what one costs.

The sizes bound a worker's memory whatever the sample count, keep a task's
fixed cost small and let a stall be seen within seconds; the resource model
(:mod:`corr_cad.run.budget.costs_montecarlo`) estimates with the same numbers.
"""

from __future__ import annotations

import math

__all__ = [
    "CELL_SECONDS",
    "CHUNK_BYTES",
    "CHUNK_MAX",
    "CHUNK_SECONDS",
    "CHUNKS_PER_WORKER",
    "DATASHEET_CELL_SECONDS",
    "IN_FLIGHT_PER_WORKER",
    "chunk_size",
    "executor_workers",
    "sample_bytes",
    "sample_seconds",
]

#: Chunks in flight per worker: one running, the next ones queued (a worker
#: never waits for the main process), and no more (their draws and results
#: are what the main process holds besides the summary's columns).
IN_FLIGHT_PER_WORKER = 2
#: Chunks per worker a run is cut into at least, so that the last chunks do
#: not leave most workers idle.
CHUNKS_PER_WORKER = 4
#: Bytes one chunk may take in the worker that solves it (its draws, errors,
#: the datasheet pass's windup angles): this bounds the chunk, and so a
#: worker's memory, whatever the sample count.
CHUNK_BYTES = 16 * 1024**2
#: No chunk has more samples than this: the chunks in flight
#: (``IN_FLIGHT_PER_WORKER`` a worker, their draws and results held by the
#: main process) stay small beside the summary's columns.
CHUNK_MAX = 4_000
#: Estimated seconds of work a chunk is given at most: a task's fixed cost
#: (a few milliseconds) is then small, while a stall is still seen within
#: seconds and the progress moves (``corr_cad.run.dask_exec``'s stall
#: time-out is at least three tasks).
CHUNK_SECONDS = 0.5
#: Estimated seconds a (sample, position, roller) cell takes: the compiled
#: kernel, the numpy solver; and a (sample, datasheet position, roller) cell
#: of the datasheet pass (six windup torques).
CELL_SECONDS = {True: 2.5e-7, False: 6e-7}
DATASHEET_CELL_SECONDS = 1e-6


def sample_seconds(positions: int, roller_count: int, kernel: bool, grid: int = 0) -> float:
    """Estimated seconds of one sample's work (:data:`CELL_SECONDS`)."""
    cells = positions * roller_count
    return cells * CELL_SECONDS[bool(kernel)] + grid * roller_count * DATASHEET_CELL_SECONDS


def chunk_size(samples: int, workers: int, sample_bytes: float, seconds: float = 0.0) -> int:
    """Samples per chunk: ``CHUNKS_PER_WORKER`` chunks a worker at least, at most
    ``CHUNK_BYTES`` of work each and ``CHUNK_SECONDS`` of estimated time (a
    sample's ``seconds``), at least 50 (a task's fixed cost).

    >>> chunk_size(100_000, 16, 2_000.0)
    1563
    >>> chunk_size(1_000_000, 2, 2_000.0)   # at most CHUNK_MAX
    4000
    >>> chunk_size(1_000_000, 2, 40_000.0)   # at most CHUNK_BYTES of work
    419
    >>> chunk_size(1_000_000, 2, 2_000.0, 1e-3)   # at most CHUNK_SECONDS of work
    500
    >>> chunk_size(30, 4, 2_000.0)
    50
    """
    want = math.ceil(samples / (CHUNKS_PER_WORKER * max(workers, 1)))
    cap = max(50, int(CHUNK_BYTES // max(sample_bytes, 1.0)))
    if seconds > 0:
        cap = min(cap, max(50, int(CHUNK_SECONDS / seconds)))
    return max(1, min(max(want, 50), cap, CHUNK_MAX))


def executor_workers(executor) -> int:
    """How many tasks ``executor`` runs at once (a pool's workers, a Dask cluster's threads)."""
    n = getattr(executor, "_max_workers", None)
    if n is None and callable(getattr(executor, "workers", None)):
        n = executor.workers()
    elif n is None and callable(getattr(executor, "nthreads", None)):  # a Dask Client
        n = sum(executor.nthreads().values())
    return max(1, int(n or 1))


def sample_bytes(roller_count: int, width: int, grid: int = 0, torques: int = 0) -> float:
    """Bytes a sample takes in the worker solving its chunk: its ``width`` standard
    draws (``z + 1`` for a per-roller tolerance, else 1) as sent and as
    received, its errors (five arrays, two of ``z + 1``), its metrics, and with
    the datasheet pass three copies of its windup angles (``grid`` positions x
    ``torques``)."""
    return 8.0 * (2 * width + 2 * roller_count + 12) + 24.0 * grid * torques
