"""The datasheet page's rows of the compliances: what the rigidity holds, and the
compliance budget (each component's windup at T_R, the support bearings' loads and lives)."""

from __future__ import annotations

from corr_cad.figure_text import catalogue_number

__all__ = ["budget_rows", "rigidity_scope"]


def rigidity_scope(sheet: dict, series) -> str:
    """What the rigidity holds: the contacts alone, with a series rigidity, or the
    compliances ``datasheet.json`` lists."""
    n = catalogue_number
    if "compliances" in sheet:
        text = "the model's compliances: " + "; ".join(sheet["compliances"]["in_figure"])
        text += " (not: " + "; ".join(sheet["compliances"]["not_in_figure"]) + ")"
        if series is not None:
            text += f"; in series with {n(series)} N*m/arcmin"
        return text
    if series is not None:
        return f"contacts in series with {n(series)} N*m/arcmin (bearings, shafts, housing)"
    if isinstance(sheet.get("bodies"), dict):
        return (
            "the contacts and the elastic rings, frame and cams (no series rigidity given: "
            "crank, bearings and housing rigid)"
        )
    if sheet.get("model") == "drive" and isinstance(sheet.get("bearing"), dict):
        return (
            "the contacts of both rows and the cams' needle bearings (no series rigidity "
            "given: crank, its bearings, ring, frame and housing rigid)"
        )
    return "the contacts alone (no series rigidity given: far stiffer than a reducer)"


def budget_rows(budget: dict | None) -> list[tuple]:
    """The compliance budget's rows: each component's windup at T_R, the support bearings."""
    if not budget:
        return []
    n = catalogue_number
    rows = [
        (
            "Windup at T_R",
            "compliance_budget.windup_arcmin",
            "arcmin",
            f"theta(T_R) from the kinematic zero at {n(budget['torque_Nm'])} N*m, mean over "
            "the positions; split below by component (compliance.png)",
        )
    ]
    for name, c in budget["components"].items():
        if not c["in_model"]:
            continue
        rows.append(
            (
                f"  of it: {name.replace('_', ' ')}",
                f"compliance_budget.components.{name}.windup_arcmin",
                "arcmin",
                f"{n(100 * c['share'])} % of the windup; the element's force times its own "
                "deflection over the torque (virtual work: the parts add up)",
            )
        )
    absent = [k.replace("_", " ") for k, c in budget["components"].items() if not c["in_model"]]
    if absent and rows:
        name, key, unit, conv = rows[0]
        rows[0] = (name, key, unit, conv + "; not in it: " + ", ".join(absent))
    for i, s in enumerate(budget.get("support_bearings", []), 1):
        key = f"compliance_budget.support_bearings.{i - 1}"
        rows.append(
            (
                f"Support bearing {i}, radial load",
                f"{key}.radial_load_at_rated_N.max",
                "N",
                f"at z = {n(s['position_mm'])} mm, largest over the positions at +-T_R",
            )
        )
        if "L10_h" in s:
            rows.append(
                (
                    f"Support bearing {i}, life L10",
                    f"{key}.L10_h",
                    "h",
                    f"ISO 281 at {n(s['output_speed_rpm'])} rpm of the output",
                )
            )
    return rows
