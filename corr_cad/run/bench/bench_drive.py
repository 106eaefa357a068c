"""Benchmark of the two-row drive (``[solver] model = "drive"``), timed.

``corr-cad bench --study drive``. The targets (the drive model's issue): on
the prototype, 3,600 positions of the drive with bearings in 0.3 s or less;
the datasheet stage in 1.5 s or less; the Monte Carlo with the datasheet
metrics at 300 samples/s or more on 2 cores at the default grid. Measured,
never asserted; ``cpu_s``: the median CPU seconds of this process per timed call
(``time.process_time``), what the shared machine's load cannot inflate. The Monte
Carlo rows measure the force metrics alone and with the datasheet metrics
(``datasheet_positions_per_mesh`` 4: 104 grid positions a sample under a roller
tolerance), in this process and on 2 pool workers, and with the cams fixed.
"""

from __future__ import annotations

import statistics
import time
from pathlib import Path

from corr_cad.geometry.design import GearDesign
from corr_cad.run.bench.bench_common import M0, _table, _write_csv

__all__ = ["drive_speed"]


def _timed(fn, repeat: int) -> tuple[float, float, float, float]:
    """Wall median, min and max, and the median CPU seconds of this process."""
    fn()  # warm-up
    times, cpu = [], []
    for _ in range(repeat):
        t0, c0 = time.perf_counter(), time.process_time()
        fn()
        times.append(time.perf_counter() - t0)
        cpu.append(time.process_time() - c0)
    return statistics.median(times), min(times), max(times), statistics.median(cpu)


def drive_speed(out: Path, quick: bool = False) -> list:
    """Wall time of the drive's solve, datasheet and Monte Carlo, per contact law."""
    from concurrent.futures import ProcessPoolExecutor

    from corr_cad.mechanics.bearing import EccentricBearing
    from corr_cad.mechanics.datasheet import DatasheetSpec, datasheet
    from corr_cad.mechanics.drive import solve_drive
    from corr_cad.tolerance.mc_datasheet import DatasheetMC
    from corr_cad.tolerance.montecarlo import Distribution, monte_carlo

    design = GearDesign()
    needles = EccentricBearing(40, 6.0, 12.0)
    spec = DatasheetSpec(rated_torque=design.roller_count * M0)
    tol = {"roller_radius": Distribution("normal", 0.001)}
    repeat = 1 if quick else 3
    samples = 20 if quick else 100
    many = 4 * samples
    rows = []
    for law in ("nonlinear", "palmgren"):
        drive = {"errors_b": None, "bearing": needles, "bearing_b": None}
        t = _timed(
            lambda law=law: solve_drive(
                design, M0, positions=3600, bearing=needles, contact_model=law
            ),
            repeat,
        )
        rows.append([f"3600 positions, bearings, {law}", *t[:3], 0.3, "", "", t[3]])
        t = _timed(
            lambda law=law, drive=drive: datasheet(design, spec, contact_model=law, drive=drive),
            repeat,
        )
        rows.append([f"datasheet stage, bearings, {law}", *t[:3], 1.5, "", "", t[3]])
        mc = {"bearing": needles, "contact_model": law}
        t = _timed(lambda law=law, mc=mc: monte_carlo(design, M0, tol, samples, 1, 72, drive=mc), 1)
        # CPU time per sample in this process: what the machine's other load cannot
        # inflate; two idle cores give about 2 / cpu samples per second.
        c0 = time.process_time()
        monte_carlo(design, M0, tol, samples, 1, 72, drive=mc)
        cpu = (time.process_time() - c0) / samples
        rows.append(
            [
                f"Monte Carlo {samples} samples (72 positions), {law}",
                *t[:3],
                "",
                samples / t[0],
                2.0 / cpu,
                cpu * samples,
            ]
        )
        with ProcessPoolExecutor(2) as ex:
            t = _timed(
                lambda mc=mc, ex=ex: monte_carlo(
                    design, M0, tol, many, 1, 72, drive=mc, executor=ex, chunk=many // 2
                ),
                repeat,
            )
        rows.append(
            [
                f"Monte Carlo {many} samples (72 positions), {law}, 2 workers",
                *t[:3],
                "",
                many / t[0],
                "",
                "",  # the workers' CPU is not this process's
            ]
        )
        rows.extend(_with_datasheet(design, tol, mc, law, samples, repeat, DatasheetMC(spec)))
    rows.extend(_with_crank(design, needles, spec, repeat))
    header = [
        "case",
        "median_s",
        "min_s",
        "max_s",
        "target_s",
        "samples_per_s",
        "two_idle_cores_per_s",
        "cpu_s",
    ]
    _table("drive model, prototype, one process", header, rows)
    _write_csv(out, "drive_speed.csv", header, rows)
    return rows


def _with_crank(design, needles, spec, repeat) -> list:
    """The drive with the crankshaft on its support bearings (the design's defaults,
    ``[bearings.crank]`` cylindrical), Palmgren's law: the solve and the datasheet."""
    from corr_cad.mechanics.datasheet import datasheet
    from corr_cad.mechanics.drive import solve_drive
    from corr_cad.run.scene.scene import parse_scene

    bearing = {"needles": 40, "needle_diameter": 6.0, "needle_length": 12.0}
    scene = parse_scene(
        {
            "solver": {"model": "drive", "contact_law": "palmgren"},
            "load": {"input_torque": M0},
            "bearings": {"eccentric": bearing, "crank": {"type": "cylindrical"}},
        }
    )
    crank = scene.crank
    t = _timed(
        lambda: solve_drive(
            design, M0, positions=3600, bearing=needles, contact_model="palmgren", crank=crank
        ),
        repeat,
    )
    rows = [["3600 positions, bearings and crank, palmgren", *t[:3], "", "", "", t[3]]]
    drive = {"errors_b": None, "bearing": needles, "bearing_b": None, "crank": crank}
    t = _timed(lambda: datasheet(design, spec, contact_model="palmgren", drive=drive), repeat)
    rows.append(["datasheet stage, bearings and crank, palmgren", *t[:3], "", "", "", t[3]])
    return rows


def _with_datasheet(design, tol, mc, law, samples, repeat, sheet) -> list:
    """The Monte Carlo with the datasheet metrics: in this process (its wall rate and 2 / the
    CPU seconds a sample) and on 2 pool workers."""
    from concurrent.futures import ProcessPoolExecutor

    from corr_cad.tolerance.montecarlo import monte_carlo

    def run(n, **kw):
        return monte_carlo(design, M0, tol, n, 1, 72, drive=mc, datasheet=sheet, **kw)

    t = _timed(lambda: run(samples), 1)
    c0 = time.process_time()
    run(samples)
    cpu = (time.process_time() - c0) / samples
    name = f"Monte Carlo + datasheet metrics {samples} samples (72 + 104 positions), {law}"
    rows = [[name, *t[:3], "", samples / t[0], 2.0 / cpu, cpu * samples]]
    many = 2 * samples
    with ProcessPoolExecutor(2) as ex:
        t = _timed(lambda: run(many, executor=ex, chunk=max(1, many // 4)), repeat)
    rows.append([f"{name}, {many} samples, 2 workers", *t[:3], "", many / t[0], "", ""])
    fixed = {**mc, "bearing": None}  # the cams fixed: the rigid solve alone
    t = _timed(
        lambda: monte_carlo(design, M0, tol, samples, 1, 72, drive=fixed, datasheet=sheet), 1
    )
    c0 = time.process_time()
    monte_carlo(design, M0, tol, samples, 1, 72, drive=fixed, datasheet=sheet)
    cpu = (time.process_time() - c0) / samples
    rows.append([f"{name}, cams fixed", *t[:3], "", samples / t[0], 2.0 / cpu, cpu * samples])
    return rows
