"""The verdict of a design search that found nothing: which requirement binds, and by how much.

One line for the console and ``manifest.json``: the candidate (at the
scene's own resolution) that misses the requirements least, what it
reaches, the requirement it misses most (it binds), and the requirement
values at which it would fit.
"""

from __future__ import annotations

import math
from collections import Counter

from corr_cad.figure_text import figure

__all__ = ["verdict", "relaxations"]

#: Requirement -> (figure column, unit, "max"/"min") of what a candidate reaches.
_REACH = {
    "rated_life_h": ("life_h", "h", "min"),
    "max_outer_diameter_mm": ("outer_diameter_mm", "mm", "max"),
    "max_length_mm": ("length_mm", "mm", "max"),
    "max_mass_kg": ("mass_kg", "kg", "max"),
    "min_torsional_rigidity_Nm_per_arcmin": (
        "torsional_rigidity_Nm_per_arcmin",
        "N*m/arcmin",
        "min",
    ),
    "max_lost_motion_arcmin": ("lost_motion_arcmin", "arcmin", "max"),
    "min_efficiency": ("efficiency", "", "min"),
    "max_contact_pressure_MPa": ("peak_contact_pressure_MPa", "MPa", "max"),
    "max_first_stage_bending_MPa": ("first_stage_bending_MPa", "MPa", "max"),
    "max_first_stage_contact_MPa": ("first_stage_contact_MPa", "MPa", "max"),
}


#: Figure column -> how the verdict names it.
_NAMES = {
    "life_h": "a life of",
    "outer_diameter_mm": "an outer diameter of",
    "length_mm": "a length of",
    "mass_kg": "a mass of",
    "torsional_rigidity_Nm_per_arcmin": "a rigidity of",
    "lost_motion_arcmin": "a lost motion of",
    "efficiency": "an efficiency of",
    "peak_contact_pressure_MPa": "a contact pressure of",
    "first_stage_bending_MPa": "a first-stage bending stress of",
    "first_stage_contact_MPa": "a first-stage contact stress of",
    "total_ratio": "a total ratio of",
}


def relaxations(row: dict, req: dict) -> list[str]:
    """The requirement values at which ``row`` would fit, each as ``key value``."""
    out = []
    for key, miss in sorted(row["violations"].items(), key=lambda kv: -kv[1]):
        if miss <= 0:
            continue
        if key == "total_ratio":
            out.append(f"total_ratio [{figure(row['total_ratio'], 6)}]")
            continue
        col, _, sense = _REACH[key]
        v = row.get(col)
        if v is None:
            continue
        # a figure rounded away from the limit, so that the relaxed value does fit
        text = figure(v, 3)
        shown = float(text.replace(",", ""))
        if (sense == "max" and shown < v) or (sense == "min" and shown > v):
            step = 10 ** (math.floor(math.log10(abs(v))) - 2)
            shown = math.ceil(v / step) * step if sense == "max" else math.floor(v / step) * step
            text = figure(shown, 3)
        out.append(f"{key} {text}")
        if key == "rated_life_h" and row.get("rated_torque_from_life_Nm") is not None:
            t = math.floor(row["rated_torque_from_life_Nm"] / 10.0) * 10.0
            out.append(f"rated_torque_Nm {figure(t)}")
    return out


def verdict(scene, rows: list[dict], full: list[dict]) -> str:
    """The line of a search without a feasible design (``rows``: every candidate)."""
    req = scene.sizing["requirements"]
    judged = [r for r in full if math.isfinite(r["violation"])]
    if not judged:
        judged = [r for r in rows if math.isfinite(r["violation"])]
    if not judged:
        why = Counter(r["refused_by"] for r in rows)
        check, n = why.most_common(1)[0]
        example = next(r["reason"] for r in rows if r["refused_by"] == check)
        return (
            f"no design fits: every one of the {len(rows)} candidates was refused, {n} by "
            f"{check} (e.g. {example}); widen [sizing.variables]"
        )
    best = min(judged, key=lambda r: r["violation"])
    binds = best["refused_by"]
    col, unit, _ = _REACH.get(binds, ("total_ratio", "", "min"))
    value = best.get(col)
    envelope = ", ".join(
        f"{k} {figure(req[k])}" for k in ("max_outer_diameter_mm", "max_length_mm")
        if req.get(k) is not None
    )  # fmt: skip
    where = f" within {envelope}" if envelope else ""
    name = _NAMES.get(col, col.replace("_", " "))
    reach = f"{name} {figure(value)}{' ' + unit if unit else ''}"
    fits = relaxations(best, req)
    return (
        f"no design fits: the best design{where} (candidate {best['candidate']}) reaches {reach} "
        f"at {figure(req['rated_torque_Nm'])} N*m: {binds} binds ({best['reason']}); "
        + (" or ".join(fits) + " would fit" if fits else "no single requirement frees it")
    )
