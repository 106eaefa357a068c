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
from corr_cad.run.bench_common import M0, _machine, _table, _write_csv

__all__ = ["datasheet_speed"]


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
    return rows
