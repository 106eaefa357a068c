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
    "DRIVE_BLOCK_BYTES",
    "DRIVE_DATASHEET_SECONDS",
    "DRIVE_FORCE_SECONDS",
    "drive_seconds",
    "CHAIN_FACTORS",
    "CHAIN_FORCE_SECONDS",
    "chain_factor",
    "WORKER_ANON_BYTES",
    "NUMBA_WORKER_BYTES",
    "kept_bytes_per_sample",
    "datasheet_pass",
    "sample_work",
    "POOL_MIN_SECONDS",
    "sample_seconds_one_core",
    "pool_pays",
]

MB = 1024.0**2
#: A forked pool worker before its first task: its own pages (the parent's
#: heap, copied on write; 45 MB measured) and the task's imports.
WORKER_ANON_BYTES = 55 * MB
#: What numba and the two compiled kernels (loaded from the cache) add to a
#: worker's own pages (38 MB measured; its library files, ~90 MB, are shared).
NUMBA_WORKER_BYTES = 45 * MB
#: A drive Monte Carlo's block in a worker: the stacked drive solver of
#: ``BLOCK_POSITIONS`` (1,000) positions of both rows and its Newton's arrays. 473 MB
#: peak measured for 400 samples x 72 positions on 2 workers (Palmgren, 40 needles, 5 um
#: clearance) where the estimate without numba (its worker pages and its library files)
#: gave 353 MB; with them 573 MB, and this.
DRIVE_BLOCK_BYTES = 10 * MB
#: Windup torques the datasheet pass solves at most per position.
DATASHEET_TORQUES = 8
#: The drive's Monte Carlo, seconds a (sample, position, roller of a row) per contact
#: model, with the cams fixed, on needles, on needles with a diametral clearance
#: (:func:`drive_seconds`). Force metrics (each sample's drive solve and its free
#: interval, a preloaded row's cam centre included): CPU time of 30 prototype samples
#: of 72 positions under a +-1 um (1 sigma) roller tolerance, 40 needles 6 x 12 mm, 5 um
#: clearance, load average 10.5-10.9 on 2 cores: 2.58, 4.54, 12.0 ms a sample (paper's
#: law), 1.80, 2.70, 7.09 ms (Palmgren's); then scaled by what the force pass's own
#: rigid start and shared nominal rows take off (60 samples, the code before and after
#: alternated, load average 4.2-5.5: x 0.81, 0.97, 0.99 paper's law, x 0.55, 0.70, 0.78
#: Palmgren's; the paper's law on needles kept).
DRIVE_FORCE_SECONDS = {
    "nonlinear": (1.1e-6, 2.4e-6, 6.4e-6),
    "palmgren": (0.55e-6, 0.98e-6, 3.0e-6),
}
#: The drive's datasheet pass (both rows, six windup torques and the zero-moment
#: preload a grid position, :mod:`corr_cad.tolerance.mc_drive_datasheet`), seconds a
#: (sample, grid position, roller), in the same three cases: CPU time of 30 prototype
#: samples under the same tolerance with the datasheet metrics (104 grid positions)
#: less their force metrics, load average 7.3 on 2 cores: 12.9, 17.8, 18.9 ms a sample
#: (paper's law) and 5.2, 10.4, 10.4 ms (Palmgren's).
DRIVE_DATASHEET_SECONDS = {
    "nonlinear": (4.8e-6, 6.6e-6, 7.0e-6),
    "palmgren": (1.9e-6, 3.8e-6, 3.9e-6),
}


#: The samples on the nominal drive's chain beyond the contacts (``[crankshaft]`` /
#: ``[bearings.crank]``; ``[solver] bodies = "elastic"``): the factor on the rigid chain's
#: seconds, for the force metrics and the datasheet pass, in the three cases above. CPU
#: time of 20 prototype samples of 72 positions (force metrics) and of 4 samples with
#: their datasheet metrics (4 positions a mesh, 8 force positions), Palmgren's law, under
#: a 1 um (1 sigma) roller tolerance, load average 0.7 on 2 cores; the crank as derived
#: from the design (its default layout), the bodies' tables of the prototype (cached).
#: Force: 2.44 / 22.9 / 33.1 ms a sample (rigid / crank / bodies) with the cams fixed,
#: 3.13 / 15.6 / 27.3 ms on needles, 3.33 / 17.3 / 35.5 ms on needles with 5 um of
#: clearance; with the datasheet pass 16.2 / 256 / 196, 16.7 / 187 / 265, 18.1 / 325 /
#: 281 ms (``benchmarks/bench_chain_samples.py``).
CHAIN_FACTORS = {
    "crank": {"force": (9.4, 5.0, 5.2), "datasheet": (15.8, 11.2, 18.0)},
    "bodies": {"force": (13.6, 8.7, 10.7), "datasheet": (12.1, 15.9, 15.5)},
}


def _bearing_case(scene) -> int:
    """0: the cams fixed, 1: on needle bearings, 2: on needle bearings with a clearance."""
    bearings = [b for b in (scene.bearing, scene.bearing_b) if b is not None]
    case = 0 if not bearings else 1
    if any(b.diametral_clearance > 0 for b in bearings):
        case = 2
    return case


def chain_factor(scene, part: str) -> float:
    """:data:`CHAIN_FACTORS` of the scene's chain (1 without a crank or elastic bodies);
    ``part``: ``"force"`` or ``"datasheet"``. A crank and elastic bodies together count
    both."""
    f = 1.0
    if getattr(scene, "crank", None) is not None:
        f *= CHAIN_FACTORS["crank"][part][_bearing_case(scene)]
    if scene.solver.bodies == "elastic":
        f *= CHAIN_FACTORS["bodies"][part][_bearing_case(scene)]
    return f


#: The rigid chain's force metrics, seconds a cell, without the compiled force pass
#: (:data:`DRIVE_FORCE_SECONDS` before it): the samples on a crankshaft or elastic bodies
#: solve on the chain's own solver, not the force pass, and :data:`CHAIN_FACTORS`' force
#: factors were measured against this.
CHAIN_FORCE_SECONDS = {
    "nonlinear": (1.4e-6, 2.4e-6, 6.4e-6),
    "palmgren": (1.0e-6, 1.4e-6, 3.8e-6),
}


def drive_seconds(scene, table: dict) -> float:
    """Seconds a cell of the drive's Monte Carlo for the scene's contact law, bearings and
    chain (``table``: :data:`DRIVE_FORCE_SECONDS` or :data:`DRIVE_DATASHEET_SECONDS`; on
    a crankshaft or elastic bodies the force metrics start from
    :data:`CHAIN_FORCE_SECONDS`)."""
    part = "datasheet" if table is DRIVE_DATASHEET_SECONDS else "force"
    chain = getattr(scene, "crank", None) is not None or scene.solver.bodies == "elastic"
    if part == "force" and chain:
        table = CHAIN_FORCE_SECONDS
    return table[scene.solver.contact_model][_bearing_case(scene)] * chain_factor(scene, part)


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
    drive: bool = False,
) -> dict:
    """Main-process and per-machine worker bytes of ``samples`` samples.

    ``width``: standard draws a sample (``draw_width``); ``kinds``:
    tolerances; ``grid``: positions of the datasheet pass (0: none);
    ``workers``: processes the chunks are cut for; ``local``: pool workers on
    this machine (0: serial or Dask); ``drive``: the samples solve the drive
    (compiled, a block of :data:`DRIVE_BLOCK_BYTES`).
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
    compiled = kernel or grid > 0 or drive  # the drive's samples run its compiled solver
    if kernel:
        geometry = 300.0 * positions * R  # the nominal geometry of every position
    else:  # numpy path: blocks of samples x positions x rollers, ~700 bytes a cell
        geometry = 700.0 * min(max(1, _BLOCK_ROWS // max(positions, 1)), chunk) * positions * R
    geometry += 300.0 * grid * R
    in_worker = geometry + chunk * per + (DRIVE_BLOCK_BYTES if drive else 0.0)
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
    if scene.solver.drive:  # the drive's kernels load from the cache (compiled ahead)
        per = drive_seconds(scene, DRIVE_DATASHEET_SECONDS)
        return DRIVE_DATASHEET_FIXED_S + samples * grid * R * per / max(workers, 1), grid
    return DATASHEET_COMPILE_S + samples * grid * R * 1e-6 / max(workers, 1), grid


#: The datasheet pass's fixed seconds: the drive's kernels loaded from the cache; the
#: paper's row's kernel compiled once per process (:func:`datasheet_pass`).
DRIVE_DATASHEET_FIXED_S = 1.0
DATASHEET_COMPILE_S = 8.0
#: Estimated sample work (seconds on one core, :func:`sample_seconds_one_core`) from which
#: a Monte Carlo's samples go to the process pool. Below it the pool cannot pay for itself:
#: a worker pays its own start before its first sample (its imports, numba and the kernels
#: from the cache: 0.35-0.5 s of CPU measured on the prototype drive) while the main
#: process loads the same kernels for the nominal pass, and one chunk leaves the other
#: workers idle. Decided from the scene alone, never from a timer; the files are the same
#: bytes on either executor.
POOL_MIN_SECONDS = 1.0


def sample_seconds_one_core(scene) -> float:
    """The estimated seconds of a Monte Carlo's samples on one core, their fixed costs
    (kernels loaded or compiled, the process's imports) left out: the force metrics and,
    where asked, the datasheet pass (the estimate's own figures)."""
    from corr_cad.tolerance.mc_chunks import CELL_SECONDS
    from corr_cad.tolerance.montecarlo import KERNEL_MIN_WORK

    mc = scene.montecarlo
    n, pos, R = mc["samples"], mc["positions"], scene.design.roller_count
    if scene.solver.drive:
        force = n * pos * R * drive_seconds(scene, DRIVE_FORCE_SECONDS)
    else:
        force = n * pos * R * CELL_SECONDS[n * pos >= KERNEL_MIN_WORK]
    sheet, grid = datasheet_pass(scene, n, 1)
    if grid:
        sheet -= DRIVE_DATASHEET_FIXED_S if scene.solver.drive else DATASHEET_COMPILE_S
    return force + sheet


def pool_pays(scene) -> bool:
    """Do the scene's Monte Carlo samples go to the process pool (else the main process)?
    From :data:`POOL_MIN_SECONDS` of estimated sample work on one core.

    >>> from corr_cad.run.scene.scene import parse_scene
    >>> few = {"tolerances": {"roller_radius": {"normal": 0.001}}, "montecarlo": {"samples": 10}}
    >>> pool_pays(parse_scene(few))
    False
    >>> many = {**few, "montecarlo": {"samples": 100_000}}
    >>> pool_pays(parse_scene(many))
    True
    """
    return sample_seconds_one_core(scene) >= POOL_MIN_SECONDS
