"""Inspection outputs: ``inner_gear_nominal.csv`` (CMM), ``inspection.csv/.json/.png``."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from corr_cad.export.files import write_csv, write_json
from corr_cad.tolerance.inspection import InspectionResult

__all__ = ["CSV_COLUMNS", "write_nominal_csv", "write_inspection", "inspection_png"]

CSV_COLUMNS = (
    "tooth",
    "profile_deviation_mm",
    "form_deviation_mm",
    "position_arcsec",
    "single_pitch_arcsec",
    "cumulative_pitch_arcsec",
    "runout_mm",
    "profile_min_mm",
    "profile_max_mm",
    "points",
)


def write_nominal_csv(tooth, t, points, normals, path: Path) -> Path:
    """CMM nominal points: ``tooth, t_deg, x, y, nx, ny`` (12 decimals, mm)."""
    rows = (
        [str(int(k)), f"{math.degrees(tt):.12f}", f"{p[0]:.12f}", f"{p[1]:.12f}"]
        + [f"{n[0]:.15f}", f"{n[1]:.15f}"]
        for k, tt, p, n in zip(tooth, t, points, normals, strict=True)
    )
    return write_csv(path, ["tooth", "t_deg", "x", "y", "nx", "ny"], rows)


def write_inspection(res: InspectionResult, summary: dict, out: Path) -> list[str]:
    rows = (
        [str(r.tooth)] + [f"{getattr(r, c):.9g}" for c in CSV_COLUMNS[1:-1]] + [str(r.points)]
        for r in res.teeth
    )
    write_csv(out / "inspection.csv", list(CSV_COLUMNS), rows)
    write_json(out / "inspection.json", summary)
    return ["inspection.csv", "inspection.json"]


def inspection_png(res: InspectionResult, limits: dict, verdicts: dict, path: Path) -> Path:
    """Gear-lab chart: profile deviation against angle per tooth with the band; pitch; runout."""
    from corr_cad.export.plots import _save, plt

    z = len(res.teeth)
    fail_teeth = set()
    for v in verdicts.values():
        fail_teeth.update(v.get("failing_teeth", []) if not v["passed"] else [])
        if not v["passed"] and "failing_teeth" not in v:
            fail_teeth.add(v["tooth"])
    fig, axes = plt.subplots(3, 1, figsize=(13, 10), gridspec_kw={"height_ratios": [2, 1, 1]})
    ax = axes[0]
    um = 1e3
    t_deg = np.degrees(np.mod(res.t + math.pi / z, 2 * math.pi)) - 180.0 / z
    for k in range(1, z + 1):
        sel = res.tooth_of_point == k
        order = np.argsort(t_deg[sel])
        colour = "tab:red" if k in fail_teeth else ("tab:blue" if k % 2 else "tab:cyan")
        ax.plot(t_deg[sel][order], res.deviation[sel][order] * um, ".-", ms=1.5, lw=0.6, c=colour)
    tol = limits.get("profile_tolerance")
    if tol is not None:
        for s in (-1, 1):
            ax.axhline(s * tol * um, color="k", ls="--", lw=0.8)
        ax.axhspan(-tol * um, tol * um, color="tab:green", alpha=0.08, label="tolerance band")
    for k in range(z):
        ax.axvline(k * 360.0 / z + 180.0 / z, color="0.85", lw=0.5)
    ylo, yhi = ax.get_ylim()
    for k in range(1, z + 1):
        ax.text(
            (k - 1) * 360.0 / z,
            yhi,
            str(k),
            ha="center",
            va="bottom",
            fontsize=7,
            color="tab:red" if k in fail_teeth else "k",
            weight="bold" if k in fail_teeth else "normal",
        )
    ax.set_xlim(-180.0 / z, 360.0 - 180.0 / z)
    ax.set_ylabel("profile deviation, um (+ = material added)")
    ax.set_xlabel("polar angle t, deg (tooth space k centred at (k - 1) 360/z)")
    ax.set_title(
        "profile deviation against polar angle per tooth space (numbers on top; red = failing)",
        pad=14,
    )
    if tol is not None:
        ax.legend(loc="lower right", fontsize=8)
    k = np.arange(1, z + 1)
    ax2 = axes[1]
    ax2.bar(k - 0.2, res.column("position_arcsec"), 0.4, label="position")
    ax2.bar(k + 0.2, res.column("single_pitch_arcsec"), 0.4, label="single pitch")
    ax2.plot(k, res.column("cumulative_pitch_arcsec"), "k.-", lw=0.8, label="cumulative from 1")
    for key, style in (("position_tolerance_arcsec", "--"), ("single_pitch_tolerance_arcsec", ":")):
        if limits.get(key) is not None:
            for s in (-1, 1):
                ax2.axhline(s * limits[key], color="0.3", ls=style, lw=0.8)
    for j in fail_teeth:
        ax2.axvspan(j - 0.5, j + 0.5, color="tab:red", alpha=0.15)
    ax2.set_ylabel("arcsec")
    ax2.set_xlim(0.4, z + 0.6)
    ax2.legend(fontsize=8, ncol=3)
    ax2.set_title(
        f"position, single and cumulative pitch; any-span cumulative "
        f"{res.cumulative_pitch_total_arcsec:.3g} arcsec"
    )
    ax3 = axes[2]
    ax3.bar(k, res.column("runout_mm") * um, 0.6, color="tab:olive")
    if limits.get("runout_tolerance") is not None:
        ax3.axhline(limits["runout_tolerance"] * um, color="k", ls="--", lw=0.8, label="limit")
        ax3.legend(fontsize=8)
    ax3.set_xlim(0.4, z + 0.6)
    ax3.set_xlabel("tooth space")
    ax3.set_ylabel("um")
    ax3.set_title(f"radial position of each tooth space (runout {res.runout_mm * um:.3g} um)")
    fig.tight_layout()
    return _save(fig, path)
