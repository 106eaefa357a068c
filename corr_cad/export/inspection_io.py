"""Inspection outputs: ``inner_gear_nominal.csv`` (CMM), ``inspection.csv/.json/.png``."""

from __future__ import annotations

import csv
import io
import math
from pathlib import Path

import numpy as np

from corr_cad.export.files import _atomic_text, write_csv, write_json
from corr_cad.geometry.design import GearDesign
from corr_cad.tolerance.inspection import InspectionResult

__all__ = [
    "CSV_COLUMNS",
    "PASS_COLUMNS",
    "write_nominal_csv",
    "write_inspection",
    "verdict_line",
    "inspection_png",
]

#: ``[inspection]`` limit -> its pass column in ``inspection.csv`` (``true``,
#: ``false``, or empty when the scene sets no such limit).
PASS_COLUMNS = {
    "profile_tolerance": "profile_pass",
    "position_tolerance_arcsec": "position_pass",
    "single_pitch_tolerance_arcsec": "single_pitch_pass",
    "cumulative_pitch_tolerance_arcsec": "cumulative_pitch_pass",
    "runout_tolerance": "runout_pass",
}

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
    *PASS_COLUMNS.values(),
    "tooth_pass",
)
_NUMBERS = CSV_COLUMNS[1 : CSV_COLUMNS.index("points")]


def write_nominal_csv(tooth, t, points, normals, path: Path, profile: str = "") -> Path:
    """CMM nominal points: ``tooth, t_deg, x, y, nx, ny`` (12 decimals, mm).

    With ``profile`` (:func:`corr_cad.geometry.modification.describe_profile`)
    the file starts with one ``#`` comment line naming the profile the points
    lie on, before the column names.
    """
    rows = (
        [str(int(k)), f"{math.degrees(tt):.12f}", f"{p[0]:.12f}", f"{p[1]:.12f}"]
        + [f"{n[0]:.15f}", f"{n[1]:.15f}"]
        for k, tt, p, n in zip(tooth, t, points, normals, strict=True)
    )
    cols = ["tooth", "t_deg", "x", "y", "nx", "ny"]
    if not profile:
        return write_csv(path, cols, rows)
    buf = io.StringIO()
    buf.write(f"# corr_cad CMM nominal points of the inner gear, mm; profile: {profile}\n")
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(cols)
    w.writerows(rows)
    return _atomic_text(path, buf.getvalue())


def _flag(ok) -> str:
    return "" if ok is None else ("true" if ok else "false")


def write_inspection(res: InspectionResult, summary: dict, out: Path) -> list[str]:
    """``inspection.csv`` (one row per tooth space, a pass column per limit) and the JSON.

    The pass columns are the verdicts of ``summary["limits"]`` (their
    ``failing_teeth``), so the CSV and the JSON cannot disagree; ``tooth_pass``
    is ``false`` when the tooth fails any limit that is set.
    """
    verdicts = summary["limits"]
    rows = []
    for r in res.teeth:
        ok = {k: r.tooth not in v["failing_teeth"] for k, v in verdicts.items()}
        rows.append(
            [str(r.tooth)]
            + [f"{getattr(r, c):.9g}" for c in _NUMBERS]
            + [str(r.points)]
            + [_flag(ok.get(k)) for k in PASS_COLUMNS]
            + [_flag(all(ok.values()) if ok else None)]
        )
    write_csv(out / "inspection.csv", list(CSV_COLUMNS), rows)
    write_json(out / "inspection.json", summary)
    return ["inspection.csv", "inspection.json"]


def _teeth(teeth: list[int]) -> str:
    return ("tooth " if len(teeth) == 1 else "teeth ") + ", ".join(str(k) for k in teeth)


def verdict_line(key: str, v: dict) -> str:
    """One limit's verdict as the console prints it and ``inspection.png`` shows it.

    >>> verdict_line("position_tolerance_arcsec", {"passed": False, "tooth": 5,
    ...     "value": 9.4213, "unit": "arcsec", "limit": 5.0, "failing_teeth": [5]})
    'position_tolerance_arcsec: FAIL tooth 5 (worst tooth 5, value 9.421 arcsec, limit 5)'
    """
    worst = f"worst tooth {v['tooth']}, value {v['value']:.4g} {v['unit']}, limit {v['limit']:g}"
    if v["passed"]:
        return f"{key}: pass ({worst})"
    return f"{key}: FAIL {_teeth(v['failing_teeth'])} ({worst})"


_PITCH_LIMITS = (
    ("position_tolerance_arcsec", "position"),
    ("single_pitch_tolerance_arcsec", "single pitch"),
    ("cumulative_pitch_tolerance_arcsec", "cumulative pitch"),
)


def _failing(verdicts: dict, key: str) -> list[int]:
    v = verdicts.get(key)
    return list(v["failing_teeth"]) if v else []


def inspection_png(
    res: InspectionResult,
    limits: dict,
    verdicts: dict,
    path: Path,
    design: GearDesign | None = None,
) -> Path:
    """Gear-lab chart: profile deviation against angle per tooth with the band; pitch; runout.

    Each panel marks in red the teeth that fail its own limits, taken from
    ``verdicts`` (:func:`~corr_cad.tolerance.inspection.evaluate_limits`), and
    the verdict of every limit is printed above the panels as the console
    prints it (:func:`verdict_line`). Legends sit beside the panels.
    """
    from matplotlib.lines import Line2D
    from matplotlib.patches import Patch

    from corr_cad.export import plots

    plt = plots.plt
    z = len(res.teeth)
    um = 1e3
    k = np.arange(1, z + 1)
    legend = dict(loc="upper left", bbox_to_anchor=(1.01, 1.0), borderaxespad=0, fontsize=8)
    fig, axes = plt.subplots(3, 1, figsize=(13, 12), gridspec_kw={"height_ratios": [2, 1, 1]})

    # Profile deviation per tooth space; red = fails profile_tolerance.
    ax = axes[0]
    bad_profile = set(_failing(verdicts, "profile_tolerance"))
    t_deg = np.degrees(np.mod(res.t + math.pi / z, 2 * math.pi)) - 180.0 / z
    for j in k:
        sel = res.tooth_of_point == j
        order = np.argsort(t_deg[sel])
        colour = "tab:red" if j in bad_profile else ("tab:blue" if j % 2 else "tab:cyan")
        ax.plot(t_deg[sel][order], res.deviation[sel][order] * um, ".-", ms=1.5, lw=0.6, c=colour)
    handles = [Line2D([], [], color="tab:blue", lw=0.8, label="tooth spaces (alternate colours)")]
    tol = limits.get("profile_tolerance")
    if tol is not None:
        for s in (-1, 1):
            ax.axhline(s * tol * um, color="k", ls="--", lw=0.8)
        band = ax.axhspan(-tol * um, tol * um, color="tab:green", alpha=0.08)
        band.set_label(f"tolerance band +-{tol * um:g} um")
        handles += [band, Line2D([], [], color="tab:red", lw=0.8, label="fails profile_tolerance")]
    for j in range(z):
        ax.axvline(j * 360.0 / z + 180.0 / z, color="0.85", lw=0.5)
    yhi = ax.get_ylim()[1]
    for j in k:
        ax.text(
            (j - 1) * 360.0 / z,
            yhi,
            str(j),
            ha="center",
            va="bottom",
            fontsize=7,
            color="tab:red" if j in bad_profile else "k",
            weight="bold" if j in bad_profile else "normal",
        )
    ax.set_xlim(-180.0 / z, 360.0 - 180.0 / z)
    ax.set_ylabel("profile deviation, um (+ = material added)")
    ax.set_xlabel("polar angle t, deg (tooth space k centred at (k - 1) 360/z)")
    ax.set_title("profile deviation against polar angle per tooth space (numbers on top)", pad=14)
    ax.legend(handles=handles, **legend)

    # Position and pitch; shaded = fails a pitch limit.
    ax2 = axes[1]
    ax2.bar(k - 0.2, res.column("position_arcsec"), 0.4, label="position")
    ax2.bar(k + 0.2, res.column("single_pitch_arcsec"), 0.4, label="single pitch")
    cum = res.column("cumulative_pitch_arcsec")
    ax2.plot(k, cum, "k.-", lw=0.8, label="cumulative from tooth 1")
    for key, style, name in (
        ("position_tolerance_arcsec", "--", "position"),
        ("single_pitch_tolerance_arcsec", ":", "single pitch"),
    ):
        if limits.get(key) is not None:
            for s in (-1, 1):
                ax2.axhline(
                    s * limits[key],
                    color="0.3",
                    ls=style,
                    lw=0.8,
                    label=f"{name} limit +-{limits[key]:g}" if s > 0 else None,
                )
    cum_lim = limits.get("cumulative_pitch_tolerance_arcsec")
    if cum_lim is not None:
        ax2.axhline(
            float(cum.min()) + cum_lim,
            color="0.3",
            ls="-.",
            lw=0.8,
            label=f"cumulative limit {cum_lim:g},\nany span (from the lowest)",
        )
    bad_pitch = {}
    for key, name in _PITCH_LIMITS:
        for j in _failing(verdicts, key):
            bad_pitch.setdefault(j, []).append(name)
    for j in sorted(bad_pitch):
        ax2.axvspan(j - 0.5, j + 0.5, color="tab:red", alpha=0.15, lw=0)
    if bad_pitch:
        which = "; ".join(
            f"{name} {', '.join(str(j) for j in _failing(verdicts, key))}"
            for key, name in _PITCH_LIMITS
            if _failing(verdicts, key)
        )
        extra = [Patch(color="tab:red", alpha=0.15, lw=0, label=f"fails {which}")]
    else:
        extra = []
    ax2.set_ylabel("arcsec")
    ax2.set_xlabel("tooth space")
    ax2.set_xlim(0.4, z + 0.6)
    ax2.legend(handles=ax2.get_legend_handles_labels()[0] + extra, **legend)
    ax2.set_title(
        f"position, single and cumulative pitch; any-span cumulative "
        f"{res.cumulative_pitch_total_arcsec:.3g} arcsec"
    )

    # Radial position of each tooth space; shaded = fails the runout limit.
    ax3 = axes[2]
    bad_runout = _failing(verdicts, "runout_tolerance")
    rr = res.column("runout_mm") * um
    colours = ["tab:red" if j in bad_runout else "tab:olive" for j in k]
    ax3.bar(k, rr, 0.6, color=colours, label="radial position above the lowest")
    if limits.get("runout_tolerance") is not None:
        ax3.axhline(
            limits["runout_tolerance"] * um,
            color="k",
            ls="--",
            lw=0.8,
            label=f"runout limit {limits['runout_tolerance'] * um:g} um",
        )
    for j in bad_runout:
        ax3.axvspan(j - 0.5, j + 0.5, color="tab:red", alpha=0.15, lw=0)
    if bad_runout:
        teeth = ", ".join(str(j) for j in bad_runout)
        extra = [Patch(color="tab:red", alpha=0.15, lw=0, label=f"fails runout {teeth}")]
    else:
        extra = []
    ax3.set_xlim(0.4, z + 0.6)
    ax3.set_xlabel("tooth space")
    ax3.set_ylabel("um")
    ax3.legend(handles=ax3.get_legend_handles_labels()[0] + extra, **legend)
    ax3.set_title(f"radial position of each tooth space (runout {res.runout_mm * um:.3g} um)")

    plots._title(
        fig,
        f"Inspection of the measured ring: {int(np.count_nonzero(res.tooth_of_point))} points "
        f"on {z} tooth spaces",
        design,
        None,
    )
    lines = [(verdict_line(key, verdicts[key]), verdicts[key]["passed"]) for key in verdicts]
    if not lines:
        lines = [("no [inspection] limit set: no verdict", True)]
    top = 0.925
    for i, (line, passed) in enumerate(lines):
        fig.text(
            0.06,
            top - 0.014 * i,
            line,
            fontsize=8,
            family="monospace",
            color="tab:green" if passed else "tab:red",
            va="top",
        )
    fig.subplots_adjust(
        left=0.06, right=0.8, top=top - 0.014 * len(lines) - 0.035, bottom=0.05, hspace=0.42
    )
    return plots._save(fig, path)
