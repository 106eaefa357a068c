"""Benchmark of the efficiency map, hysteresis and life: what ``[friction]``/``[life]`` add.

``corr-cad bench --study friction``. The target: the efficiency map over 10
torques and 3 speeds, the hysteresis and starting torque and the life (with
the rated torque from life) add at most 2 s to the prototype's datasheet
run. Wall time is shared-machine time; the CPU time of the process is given
beside it (a loaded machine inflates the first, not the second).
"""

from __future__ import annotations

import statistics
import tempfile
import time
from pathlib import Path

import numpy as np

from corr_cad.export.bench_plots import figure as _figure
from corr_cad.geometry.design import GearDesign
from corr_cad.geometry.deviations import ManufacturingErrors
from corr_cad.run.bench.bench_common import M0, _machine, _table, _write_csv

__all__ = ["friction_speed"]


def friction_speed(out: Path, quick: bool = False) -> list:
    """Median wall and CPU time of the datasheet, and of what friction and life add."""
    from corr_cad.export.friction_io import efficiency_png, write_friction_files
    from corr_cad.mechanics.datasheet import DatasheetSpec, datasheet
    from corr_cad.mechanics.life import LifeSpec
    from corr_cad.mechanics.losses.efficiency import friction_figures
    from corr_cad.mechanics.losses.friction import Friction
    from corr_cad.mechanics.losses.hysteresis import hysteresis_figures
    from corr_cad.mechanics.row.windup import Windup, mesh_period_rad, result_period_rad
    from corr_cad.run.scene.scene_schema_friction import EFFICIENCY_SPEEDS_RPM, EFFICIENCY_TORQUES

    design = GearDesign()
    T_R = design.roller_count * M0
    spec = DatasheetSpec(rated_torque=T_R)
    fr = Friction(0.05, 0.05, 0.05, 0.0025, "bearing", 2.0 * design.cam_bore_radius - 12.0)
    per = tuple(0.001 * ((7 * i) % 5 - 2) - 0.003 for i in range(26))
    cases = [("prototype (nominal)", ManufacturingErrors())]
    if not quick:
        cases.append(("per-roller errors", ManufacturingErrors(roller_radius_errors=per)))
    repeat = 3 if quick else 5
    rows = []
    tmp = Path(tempfile.mkdtemp())
    for name, err in cases:
        period = result_period_rad(design, err)
        n = int(round(period / mesh_period_rad(design))) * 4

        def parts(err=err, n=n, period=period):
            t = [time.perf_counter(), time.process_time()]
            datasheet(design, spec, errors=err)
            t += [time.perf_counter(), time.process_time()]
            w = Windup(design, period * np.arange(n) / n, errors=err)
            ff = friction_figures(
                design, w, T_R, fr, EFFICIENCY_TORQUES, EFFICIENCY_SPEEDS_RPM, LifeSpec()
            )
            ff.hysteresis = hysteresis_figures(design, w, T_R, fr)
            t += [time.perf_counter(), time.process_time()]
            write_friction_files(ff, tmp)
            efficiency_png(ff, tmp / "efficiency.png")
            t += [time.perf_counter(), time.process_time()]
            return [t[i + 2] - t[i] for i in range(0, 6, 2)], [
                t[i + 3] - t[i + 1] for i in range(0, 6, 2)
            ]

        parts()  # warm-up (imports, caches)
        wall, cpu = zip(*(parts() for _ in range(repeat)), strict=True)
        med = [statistics.median(x[k] for x in wall) for k in range(3)]
        cmed = [statistics.median(x[k] for x in cpu) for k in range(3)]
        rows.append([name, n, *med, *cmed, med[1] + med[2], cmed[1] + cmed[2]])
    header = [
        "case",
        "friction_positions",
        "datasheet_s",
        "friction_life_hysteresis_s",
        "files_s",
        "datasheet_cpu_s",
        "friction_life_hysteresis_cpu_s",
        "files_cpu_s",
        "added_s",
        "added_cpu_s",
    ]
    _table("friction and life added to the datasheet (median)", header, rows)
    _write_csv(out, "friction_speed.csv", header, rows)

    def draw(ax):
        names = [r[0] for r in rows]
        ax.barh(names, [r[8] for r in rows], color="C0", label="added, wall")
        ax.barh(names, [r[9] for r in rows], color="C1", height=0.4, label="added, CPU")
        ax.axvline(2.0, color="C3", ls="--", lw=1, label="target 2 s (prototype)")
        ax.set_xlabel("time added to the datasheet run [s]")
        ax.set_title(f"efficiency map 10 x 3, hysteresis, life ({_machine()})", fontsize=10)
        ax.legend(fontsize=8, loc="lower right")

    _figure(out, "friction_speed.png", draw)
    return rows
