"""What Monte Carlo sample work costs: the main process, each pool worker, the time.

The model follows :func:`corr_cad.tolerance.montecarlo.monte_carlo`: draws
made a chunk at a time, chunks of :func:`~corr_cad.tolerance.montecarlo.chunk_size`
samples, at most ``IN_FLIGHT_PER_WORKER`` chunks a worker in flight, each
chunk's rows written as they return. What grows with the sample count is
the main process's columns for the summary (one float per sample for each
metric and each tolerance's magnitude) and, while the summary ranks them,
a few temporaries; a worker holds one chunk, bounded in bytes.

Memory is the machine's: a forked pool worker adds its own (anonymous)
pages; the library files it maps (numba's LLVM, numpy) are the same pages
in every process and are counted once, as a library of the run
(:data:`corr_cad.run.budget.costs.LIBRARY_BYTES`). ``corr-cad bench --study
resources`` measures the same way (``tree``: anonymous pages of every
process plus the file pages of the process that maps most). Measured on
the 2-core machine, 2 tolerances, 36 positions a sample (``bench_resources``'s
``measure``); see ``docs/resources.md``.
"""

from __future__ import annotations

__all__ = [
    "WORKER_ANON_BYTES",
    "NUMBA_WORKER_BYTES",
    "kept_bytes_per_sample",
    "datasheet_pass",
    "sample_work",
]

MB = 1024.0**2
#: A forked pool worker before its first task: its own pages (the parent's
#: heap, copied on write; 45 MB measured) and the task's imports.
WORKER_ANON_BYTES = 55 * MB
#: What numba and the two compiled kernels (loaded from the cache) add to a
#: worker's own pages (38 MB measured; its library files, ~90 MB, are shared).
NUMBA_WORKER_BYTES = 45 * MB
#: Windup torques the datasheet pass solves at most per position.
DATASHEET_TORQUES = 8
#: The drive's datasheet pass (both rows, six windup torques and the zero-moment
#: preload a grid position, :mod:`corr_cad.tolerance.mc_drive_datasheet`), seconds a
#: (sample, grid position, roller), without and with eccentric bearings: 7.4 and
#: 20.6 ms of CPU a prototype sample of 104 positions measured (load average 6.5 on 2
#: cores), 2.7 and 7.6 us a cell, rounded up.
DRIVE_DATASHEET_SECONDS = {False: 3e-6, True: 8e-6}
#: A bearing with a diametral clearance slows the drive's pass: a z = 9 drive with
#: 30-needle bearings ran its datasheet Monte Carlo at 272 samples/s without and 53-74
#: with 2 um clearance (2 workers, load average 3-4, the same minute), taken as 5 times.
DRIVE_CLEARANCE_FACTOR = 5.0
#: The summary's temporaries per sample, bytes: a metric's ranks and their
#: argsort (Spearman), a percentile's sorted copy.
SUMMARY_TEMP_BYTES = 64
#: Bytes a value takes while a chunk's rows are formatted (Python floats in
#: lists, the argument tuple, the text).
FORMAT_BYTES_PER_VALUE = 90


def kept_bytes_per_sample(metrics: int, kinds: int) -> float:
    """The main process's bytes per sample: one float per metric and per tolerance
    (the summary needs every sample: percentiles, Spearman ranks) and the
    summary's temporaries."""
    return 8.0 * (metrics + kinds) + SUMMARY_TEMP_BYTES


def sample_work(
    R: int,
    width: int,
    kinds: int,
    samples: int,
    positions: int,
    kernel: bool,
    grid: int,
    workers: int,
    local: int,
    remote: bool,
) -> dict:
    """Main-process and per-machine worker bytes of ``samples`` samples.

    ``width``: standard draws a sample (``draw_width``); ``kinds``:
    tolerances; ``grid``: positions of the datasheet pass (0: none);
    ``workers``: processes the chunks are cut for; ``local``: pool workers on
    this machine (0: serial or Dask).
    """
    from corr_cad.tolerance.montecarlo import (
        _BLOCK_ROWS,
        IN_FLIGHT_PER_WORKER,
        chunk_size,
        sample_bytes,
        sample_seconds,
    )

    per = sample_bytes(R, width, grid, DATASHEET_TORQUES if grid else 0)
    seconds = sample_seconds(positions, R, kernel, grid)
    chunk = chunk_size(samples, workers, per, seconds)
    compiled = kernel or grid > 0
    if kernel:
        geometry = 300.0 * positions * R  # the nominal geometry of every position
    else:  # numpy path: blocks of samples x positions x rollers, ~700 bytes a cell
        geometry = 700.0 * min(max(1, _BLOCK_ROWS // max(positions, 1)), chunk) * positions * R
    geometry += 300.0 * grid * R
    in_worker = geometry + chunk * per
    metrics = 4 + (5 if grid else 0)
    columns = 1 + kinds + metrics
    # The main process: the chunks in flight (draws as made and pickled for the
    # queue, magnitudes, results as received and unpickled), one chunk's rows
    # being formatted, the draw stream's skipping block (8 MB).
    in_flight = (
        IN_FLIGHT_PER_WORKER * max(workers, 1) * chunk * 8.0 * (2 * width + kinds + 2 * metrics)
    )
    main = (
        28 * MB
        + kept_bytes_per_sample(metrics, kinds) * samples
        + (0.0 if remote else in_flight)
        + FORMAT_BYTES_PER_VALUE * columns * chunk
    )
    if not local and not remote:  # serial: the chunk is solved here
        main += in_worker + (NUMBA_WORKER_BYTES if compiled else 0.0)
    worker = WORKER_ANON_BYTES + in_worker + (NUMBA_WORKER_BYTES if compiled else 0.0)
    return {
        "memory": main,
        "workers": local * worker,
        "libraries": ("numba",) if compiled else (),
        "chunk": chunk,
        "task_seconds": chunk * seconds,
    }


def datasheet_pass(scene, samples: int, workers: int) -> tuple[float, int]:
    """Seconds and grid positions of the samples' datasheet pass (0, 0 when not asked).

    Six windup torques at each position of the sample's grid by the compiled
    kernel: 12.6 us a position at 26 rollers measured (2.47 ms a sample of 104
    positions with the 1.16 ms force pass, 18.0 ms at 1300; ``bench --study
    datasheet``), taken as 1 us a (position, roller), about twice that; and
    ~8 s to compile the kernel once per process. Under ``model = "drive"`` the drive's
    pass (:data:`DRIVE_DATASHEET_SECONDS`) over the grid of the row that repeats last.
    """
    from corr_cad.run.scene.scene_montecarlo import wants_datasheet_metrics

    if not wants_datasheet_metrics(scene):
        return 0.0, 0
    from dataclasses import replace as _replace

    from corr_cad.tolerance.mc_datasheet import grid_positions

    base = scene.errors
    if scene.measured_profile is not None and base.profile_deviation is None:
        base = _replace(base, profile_deviation=lambda t: 0.0 * t)
    if scene.solver.drive:  # the row that repeats last sets the span
        from corr_cad.mechanics.datasheet import span_errors

        base = span_errors(scene.design, base, {"errors_b": scene.errors_b})
    grid = len(
        grid_positions(
            scene.design,
            base,
            tuple(scene.tolerances),
            scene.montecarlo["datasheet_positions_per_mesh"],
        )
    )
    R = scene.design.roller_count
    per = 1e-6
    if scene.solver.drive:
        per = DRIVE_DATASHEET_SECONDS[scene.bearing is not None]
        bearings = (scene.bearing, scene.bearing_b)
        if any(b is not None and b.diametral_clearance > 0 for b in bearings):
            per *= DRIVE_CLEARANCE_FACTOR
    return 8.0 + samples * grid * R * per / max(workers, 1), grid
