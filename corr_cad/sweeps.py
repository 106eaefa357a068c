"""Parametric sweeps as in the paper's Section 4, and the comparison with its numbers.

Each sweep varies one design parameter or one error over the paper's range
and solves a full cycle per point. Points where the design is undercut (or
invalid) are reported as such, not computed.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from .design import GearDesign
from .deviations import ManufacturingErrors
from .errors import CorrCadError
from .profile import undercut_analysis
from .solver import solve_forces

__all__ = ["PAPER_SWEEPS", "PAPER_QUOTES", "sweep_point", "run_sweeps", "comparison_rows"]

#: name -> (what varies, start, end); the paper's Section 4 ranges.
PAPER_SWEEPS = {
    "eccentricity": ("design", 2.5, 4.0),
    "roller_radius": ("design", 7.0, 20.0),
    "cam_radius": ("design", 125.0, 170.0),
    "cam_radius_error": ("errors", -0.02, 0.02),
    "eccentricity_error": ("errors", -0.01, 0.05),
    "roller_radius_error": ("errors", -0.02, 0.02),
}

#: What the paper quotes at the ends of each range (N), Section 4 text.
PAPER_QUOTES = {
    "eccentricity": {"F_j_mean": (2430, 2050), "F_j_peak": (4100, 2100)},
    "roller_radius": {
        "F_j_mean": (1735, 1724),
        "F_n_mean": (1770, 1757),
        "F_s_mean": (229, 221),
        "F_j_peak": (2990, 2970),
        "F_s_peak_to_peak": (1140, 1050),
    },
    "cam_radius": {
        "F_j_mean": (1733, 1710),
        "F_n_mean": (1775, 1746),
        "F_s_mean": (245, 180),
        "F_j_peak": (2999, 2952),
        "F_n_peak": (3003, 2955),
        "F_s_peak_to_peak": (1200, 920),
    },
    "cam_radius_error": {
        "F_j_mean": (1745, 1710),
        "F_n_mean": (1784, 1749),
        "F_s_mean": (229, 225),
        "F_j_peak": (2960, 3230),
        "F_n_peak": (2958, 3022),
        "F_s_peak_to_peak": (1120, 1139),
    },
    "eccentricity_error": {"F_s_mean": (239, 181), "F_s_peak_to_peak": (1150, 960)},
    "roller_radius_error": {
        "F_j_mean": (1800, 1680),
        "F_n_mean": (1840, 1720),
        "F_s_mean": (246, 210),
        "F_j_peak": (2860, 3100),
    },
}

METRICS = ("F_j_mean", "F_n_mean", "F_s_mean", "F_j_peak", "F_n_peak", "F_s_peak_to_peak")


def sweep_point(
    design: GearDesign,
    name: str,
    value: float,
    input_torque: float,
    positions: int,
    load_share: float,
) -> dict:
    """One sweep point: status ``ok``, ``undercut`` or ``invalid``, and roller 1's forces."""
    where, _, _ = PAPER_SWEEPS[name]
    rec = {"sweep": name, "value": float(value), "status": "ok"}
    try:
        # Radii derived from the design (ring rim, bore, frame plate) follow the
        # swept value; they do not enter the forces.
        derived = dict.fromkeys(
            ("ring_outer_radius", "cam_bore_radius", "frame_inner_radius", "frame_outer_radius")
        )
        d = replace(design, **{name: value}, **derived) if where == "design" else design
        info = undercut_analysis(d)
        if info.undercut:
            rec["status"] = (
                f"undercut (admissible roller radius {info.admissible_roller_radius:.4g} mm)"
            )
            return rec
        errors = ManufacturingErrors(**{name: value}) if where == "errors" else None
        res = solve_forces(
            d, input_torque, positions=positions, load_share=load_share, errors=errors
        )
    except CorrCadError as exc:
        rec["status"] = f"invalid: {exc}"
        return rec
    s = res.summary()
    rec.update({k: s[k] for k in METRICS})
    rec["loaded_rollers_min"] = s["loaded_rollers_min"]
    rec["loaded_rollers_max"] = s["loaded_rollers_max"]
    return rec


def run_sweeps(
    design: GearDesign,
    input_torque: float,
    points: int,
    positions: int,
    load_share: float = 0.55,
    executor=None,
    names=tuple(PAPER_SWEEPS),
) -> dict[str, list[dict]]:
    """All sweeps, each point a task on ``executor`` (``submit`` interface)."""
    from .tolerance import SerialExecutor

    executor = executor or SerialExecutor()
    jobs = {}
    for name in names:
        _, lo, hi = PAPER_SWEEPS[name]
        jobs[name] = [
            executor.submit(
                sweep_point, design, name, float(v), input_torque, positions, load_share
            )
            for v in np.linspace(lo, hi, points)
        ]
    return {name: [f.result() for f in futs] for name, futs in jobs.items()}


def comparison_rows(results: dict[str, list[dict]]) -> list[dict]:
    """Our values at the ends of each range beside the paper's, with the change in %."""
    rows = []
    for name, quotes in PAPER_QUOTES.items():
        pts = results.get(name)
        if not pts:
            continue
        ok = [p for p in pts if p["status"] == "ok"]
        if not ok:
            continue
        # Our end of range: the last point that could be computed (the paper's
        # range runs into undercut for the roller radius).
        first, last = ok[0], ok[-1]
        for metric, (p0, p1) in quotes.items():
            ours0 = first.get(metric)
            ours1 = last.get(metric)
            rows.append(
                {
                    "sweep": name,
                    "metric": metric,
                    "paper_range": f"{pts[0]['value']:g} .. {pts[-1]['value']:g}",
                    "ours_range": f"{first['value']:g} .. {last['value']:g}",
                    "paper_start": p0,
                    "paper_end": p1,
                    "paper_change_pct": 100.0 * (p1 - p0) / p0,
                    "ours_start": ours0,
                    "ours_end": ours1,
                    "ours_change_pct": (
                        100.0 * (ours1 - ours0) / ours0 if ours0 and ours1 is not None else None
                    ),
                    "beyond_our_range": "; ".join(
                        sorted({p["status"].split(":")[0] for p in pts if p["status"] != "ok"})
                    ),
                }
            )
    return rows
