"""Benchmark of the datasheet: the windup curve and the transmission error, timed.

``corr-cad bench --study datasheet``. The target (issue 19): for the
prototype the ``datasheet`` stage (41 torque levels over one mesh period,
the transmission error over one output revolution at 360 positions per
crank turn, both directions) in 0.5 s or less. The cases add the error
kinds that lengthen the span (per-roller errors: one tooth pitch; a ring
profile deviation: a full output revolution, nothing repeats).
"""

from __future__ import annotations

import statistics
import time
from pathlib import Path

from corr_cad.export.bench_plots import figure as _figure
from corr_cad.geometry.design import GearDesign
from corr_cad.geometry.deviations import ManufacturingErrors, harmonic_deviation
from corr_cad.run.bench.bench_common import M0, _machine, _table, _write_csv

__all__ = ["datasheet_speed", "datasheet_montecarlo"]


def _cases() -> list[tuple[str, ManufacturingErrors]]:
    per = tuple(0.001 * ((7 * i) % 5 - 2) - 0.003 for i in range(26))
    return [
        ("prototype (nominal)", ManufacturingErrors()),
        ("rollers -2 um", ManufacturingErrors(roller_radius_error=-0.002)),
        ("per-roller errors", ManufacturingErrors(roller_radius_errors=per)),
        (
            "ring deviation (full revolution)",
            ManufacturingErrors(
                roller_radius_error=-0.003, profile_deviation=harmonic_deviation([(3, 0.001, 0.0)])
            ),
        ),
    ]


def datasheet_speed(out: Path, quick: bool = False) -> list:
    """Median wall time of the datasheet computation per case; the split into windup and TE."""
    from corr_cad.mechanics.datasheet import DatasheetSpec, datasheet

    design = GearDesign()
    spec = DatasheetSpec(rated_torque=design.roller_count * M0)
    rows = []
    repeat = 3 if quick else 9
    cases = _cases()[:2] if quick else _cases()
    for name, err in cases:
        datasheet(design, spec, errors=err)  # warm-up (imports, caches)
        times = []
        for _ in range(repeat if "ring" not in name else max(1, repeat // 3)):
            t0 = time.perf_counter()
            ds = datasheet(design, spec, errors=err)
            times.append(time.perf_counter() - t0)
        L, P = ds.windup.shape
        rows.append(
            [
                name,
                L,
                P,
                len(ds.te_output_angles),
                ds.te_positions_solved,
                statistics.median(times),
                min(times),
                max(times),
            ]
        )
    header = [
        "case",
        "torque_levels",
        "windup_positions",
        "te_positions",
        "te_positions_solved",
        "median_s",
        "min_s",
        "max_s",
    ]
    _table(
        "datasheet stage (41 levels + band rows; TE 360 per crank turn, both ways)", header, rows
    )
    _write_csv(out, "datasheet_speed.csv", header, rows)

    def draw(ax):
        names = [r[0] for r in rows]
        ax.barh(names, [r[5] for r in rows], color="C0", label="median")
        ax.errorbar(
            [r[5] for r in rows],
            names,
            xerr=[[r[5] - r[6] for r in rows], [r[7] - r[5] for r in rows]],
            fmt="none",
            color="0.3",
            capsize=3,
            label="min-max",
        )
        ax.axvline(0.5, color="C3", ls="--", lw=1, label="target 0.5 s (prototype)")
        ax.set_xscale("log")
        ax.set_xlabel("datasheet stage wall time [s]")
        ax.set_title(f"datasheet: windup curve and transmission error ({_machine()})", fontsize=10)
        ax.legend(fontsize=8, loc="lower right")

    _figure(out, "datasheet_speed.png", draw)
    return rows + datasheet_montecarlo(out, quick)


def datasheet_montecarlo(out: Path, quick: bool = False) -> list:
    """Monte Carlo samples per second with the datasheet metrics, on 2 pool workers.

    Issue 19's target: 500 samples/s on 2 cores for a full output revolution
    per sample where the errors need one. Each run is a whole
    :func:`~corr_cad.tolerance.montecarlo.monte_carlo` (the force metrics at
    360 crank positions plus the datasheet pass), median of 3 runs after a
    warm-up that compiles or loads the kernels. The machine is shared, so each
    case also gives its CPU time per sample (one process, serial) and the
    rate two idle cores would reach from it.
    """
    from concurrent.futures import ProcessPoolExecutor

    from corr_cad.mechanics.datasheet import DatasheetSpec
    from corr_cad.tolerance.mc_datasheet import DatasheetMC, grid_positions
    from corr_cad.tolerance.montecarlo import Distribution, monte_carlo

    design = GearDesign()
    per_roller = {
        "roller_radius": Distribution("normal", 0.001),
        "slot_angle": Distribution("normal", 0.002),
        "cam_radius": Distribution("uniform", 0.002),
        "eccentricity": Distribution("uniform", 0.002),
    }
    alike = {"cam_radius": Distribution("uniform", 0.002)}
    ring = ManufacturingErrors(profile_deviation=harmonic_deviation([(3, 0.001, 0.0)]))
    n = 1000 if quick else 4000
    cases = [
        ("per-roller, 16/mesh (tooth pitch)", per_roller, ManufacturingErrors(), 16, n),
        ("per-roller, 8/mesh (tooth pitch)", per_roller, ManufacturingErrors(), 8, n),
        ("per-roller, 4/mesh (tooth pitch)", per_roller, ManufacturingErrors(), 4, n),
        ("alike parts, 16/mesh (mesh period)", alike, ManufacturingErrors(), 16, n),
        ("ring deviation, 2/mesh (revolution)", per_roller, ring, 2, max(200, n // 20)),
        ("force metrics only (no datasheet)", per_roller, ManufacturingErrors(), None, n),
    ]
    if quick:
        cases = cases[1:2] + cases[-1:]
    rows = []
    with ProcessPoolExecutor(2) as ex:
        for name, tol, base, ppm, samples in cases:
            cfg = None
            if ppm is not None:
                spec = DatasheetSpec(rated_torque=design.roller_count * M0)
                cfg = DatasheetMC(spec, positions_per_mesh=ppm)
            grid = 0 if cfg is None else len(grid_positions(design, base, tol, ppm))

            def once(k, tol=tol, base=base, cfg=cfg):
                t0 = time.perf_counter()
                monte_carlo(
                    design,
                    M0,
                    tol,
                    k,
                    1,
                    360,
                    base_errors=base,
                    executor=ex,
                    datasheet=cfg,
                    kernel=True,
                )
                return time.perf_counter() - t0

            once(100)  # warm-up: compile or load the kernels, start the workers
            times = [once(samples) for _ in range(1 if "ring" in name and not quick else 3)]
            med = statistics.median(times)
            # CPU time per sample in this process: what the machine's other load
            # cannot inflate; two idle cores give about 2 / cpu samples per second.
            k = max(20, samples // 10)
            c0 = time.process_time()
            monte_carlo(design, M0, tol, k, 1, 360, base_errors=base, datasheet=cfg, kernel=True)
            cpu = (time.process_time() - c0) / k
            rows.append(
                [name, grid, samples, med, samples / med, samples / max(times), 1e3 * cpu, 2 / cpu]
            )
    header = ["case", "grid_positions", "samples", "median_s", "samples_per_s", "worst_per_s"]
    header += ["cpu_ms_per_sample", "idle_2_core_per_s"]
    _table("Monte Carlo with the datasheet metrics, 2 pool workers (target 500/s)", header, rows)
    _write_csv(out, "datasheet_montecarlo.csv", header, rows)

    def draw(ax):
        names = [r[0] for r in rows]
        y = list(range(len(rows)))
        ax.barh(
            [v - 0.2 for v in y],
            [r[4] for r in rows],
            height=0.4,
            color="C0",
            label="measured, 2 workers (median)",
        )
        ax.barh(
            [v + 0.2 for v in y],
            [r[7] for r in rows],
            height=0.4,
            color="C1",
            label="2 / CPU time per sample (idle 2 cores)",
        )
        ax.set_yticks(y)
        ax.set_yticklabels(names, fontsize=8)
        ax.invert_yaxis()
        ax.axvline(500, color="C3", ls="--", lw=1, label="target 500 samples/s")
        ax.set_xscale("log")
        ax.set_xlabel("samples per second (2 workers)")
        ax.set_title(f"Monte Carlo with datasheet metrics ({_machine()})", fontsize=10)
        ax.legend(fontsize=8, loc="upper right")  # the top rows end left of 600/s

    _figure(out, "datasheet_montecarlo.png", draw)
    return rows
