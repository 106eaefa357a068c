"""``datasheet.html``: the datasheet page a customer receives, as catalogues print it.

One page per design, from the very dictionary written to ``datasheet.json``
(so every number on the page is one of that file's, rounded for reading):

* the catalogue figures, one value each with its convention (the maximum
  over the positions for backlash, lost motion and transmission error, the
  minimum for rigidities), in N*m, arcmin and arcsec, never in scientific
  notation;
* the hysteresis and transmission-error curves (``hysteresis.png`` and
  ``transmission_error.png`` of the same run, embedded as data URIs so the
  page is one self-contained file);
* the model that produced them: contact law, load share, printed-paper
  variants, which ring (conjugate, modified or measured), the positions and
  torque levels evaluated, the series rigidity, the corr-cad version.

Each figure's cell carries ``data-key`` (its path in ``datasheet.json``) and
``data-value`` (the exact value) for scripts and tests. The page prints on
A4 (print CSS); a browser's "print to PDF" makes the PDF.
Deterministic: no date, no absolute path.
"""

from __future__ import annotations

import base64
import math
from pathlib import Path

from corr_cad.export.datasheet_compliance import budget_rows, rigidity_scope
from corr_cad.export.datasheet_losses import losses_rows
from corr_cad.export.files import writing
from corr_cad.figure_text import catalogue_number, figure

__all__ = [
    "catalogue_number",
    "datasheet_rows",
    "json_numbers",
    "life_short",
    "nominal_geometry",
    "render_datasheet_html",
    "write_datasheet_html",
]


def _get(data: dict, key: str):
    for part in key.split("."):
        data = data[int(part)] if isinstance(data, list) else data[part]
    return data


def json_numbers(data, prefix: str = "") -> list[tuple[str, float]]:
    """Every number of a JSON-ready dictionary as ``(key path, value)``, in the file's order:
    dotted keys, list items by index (``stiffness_Nm_per_arcmin.breakpoints_Nm.0``);
    booleans, ``None`` and texts are not numbers.

    >>> json_numbers({"a": 1, "b": {"c": [2.5, None], "d": True, "e": "3 mm"}})
    [('a', 1.0), ('b.c.0', 2.5)]
    """
    out = []
    items = data.items() if isinstance(data, dict) else enumerate(data)
    for k, v in items:
        key = f"{prefix}{k}"
        if isinstance(v, bool) or v is None or isinstance(v, str):
            continue
        if isinstance(v, (dict, list, tuple)):
            out += json_numbers(v, key + ".")
        elif isinstance(v, (int, float)) and math.isfinite(float(v)):
            out.append((key, float(v)))
    return out


def all_figures(sheet: dict) -> list[dict]:
    """The page's last table: every number of ``datasheet.json``, by its key path."""
    return [
        {"key": key, "value": v, "exact": repr(v), "text": catalogue_number(v)}
        for key, v in json_numbers(sheet)
    ]


def datasheet_rows(sheet: dict) -> list[dict]:
    """The catalogue table: one row per figure (name, key, value, unit, convention)."""
    lm = sheet["lost_motion_arcmin"]
    rig = sheet["torsional_rigidity_Nm_per_arcmin"]
    te = sheet["transmission_error_arcsec"]
    k = sheet["stiffness_Nm_per_arcmin"]["breakpoints_Nm"]
    series = rig.get("series_rigidity_Nm_per_arcmin")
    n = catalogue_number
    whole = sheet.get("whole_drive")
    stage = ", second stage" if whole else ""
    locked = "crank locked" if whole else "input locked"
    nominal = nominal_note(sheet)
    rows = [
        ("Rated output torque T_R", "rated_torque_Nm", "N*m", sheet["rated_torque_source"]),
        *(
            [
                (
                    "Backlash, whole drive",
                    "whole_drive.backlash_arcmin.value",
                    "arcmin",
                    "free output rotation at zero torque, pinion held: the second stage's "
                    "backlash below plus the first stage's backlash at the output "
                    f"({n(sheet['first_stage']['backlash_arcmin'])} arcmin)",
                ),
                (
                    "Lost motion, whole drive",
                    "whole_drive.lost_motion_arcmin.value",
                    "arcmin",
                    "the second stage's lost motion below plus the first stage's at the output "
                    f"({n(sheet['first_stage']['lost_motion_arcmin'])} arcmin: its backlash and "
                    "its meshes' windup); pinion held",
                ),
            ]
            if whole
            else []
        ),
        (
            f"Backlash{stage}",
            "backlash_arcmin.max",
            "arcmin",
            f"theta(0+) - theta(0-): free output rotation at zero torque, {locked}; "
            "largest over the positions" + nominal,
        ),
        (
            f"Lost motion{stage}",
            "lost_motion_arcmin.max",
            "arcmin",
            f"theta(+b T_R) - theta(-b T_R), b = {n(100 * lm['band'])} % "
            f"(+-{n(lm['torque_Nm'])} N*m), {locked}; largest over the positions" + nominal,
        ),
        (
            "Torsional rigidity",
            "torsional_rigidity_Nm_per_arcmin.headline",
            "N*m/arcmin",
            f"(T_2 - T_1) / (theta(T_2) - theta(T_1)), T_1 = {n(rig['from_torque_Nm'])} N*m, "
            f"T_2 = {n(rig['to_torque_Nm'])} N*m, both directions; smallest over the positions; "
            + rigidity_scope(sheet, series),
        ),
    ]
    if series is not None:
        rows.append(
            (
                "Torsional rigidity, contacts and elastic bodies"
                if isinstance(sheet.get("bodies"), dict)
                else "Torsional rigidity, contacts alone",
                "torsional_rigidity_Nm_per_arcmin.contact_only.min",
                "N*m/arcmin",
                "the same, without the series rigidity; smallest over the positions",
            )
        )
    for i, (name, a, b) in enumerate(
        (("K1", 0.0, k[0]), ("K2", k[0], k[1]), ("K3", k[1], k[2])), start=1
    ):
        rows.append(
            (
                f"Torsional stiffness {name}",
                f"stiffness_Nm_per_arcmin.K{i}.min",
                "N*m/arcmin",
                f"slope on [{n(a)}, {n(b)}] N*m, both directions; smallest over the positions",
            )
        )
    rows.append(
        (
            "Transmission error",
            "transmission_error_arcsec.catalogue",
            "arcsec",
            f"peak-to-peak over one output revolution at a driving torque of "
            f"{n(te['driving_torque_Nm'])} N*m, the larger of the two directions" + nominal,
        )
    )
    rows += friction_rows(sheet)
    if "peak_contact_pressure_at_rated_MPa" in sheet:
        rows.append(
            (
                "Peak contact pressure at T_R",
                "peak_contact_pressure_at_rated_MPa",
                "MPa",
                "largest Hertz pressure of any contact at +-T_R over the positions",
            )
        )
    if "rated_torque_from_contact_pressure" in sheet:
        r = sheet["rated_torque_from_contact_pressure"]
        rows.append(
            (
                "Rated torque from contact pressure",
                "rated_torque_from_contact_pressure.torque_Nm",
                "N*m",
                f"smallest |T| at which the peak Hertz pressure reaches "
                f"{n(r['allowable_MPa'])} MPa, the weaker direction",
            )
        )
    if "total_ratio" in sheet:  # the whole drive: a first gear stage ahead
        rows += [
            (
                "Total ratio",
                "total_ratio",
                "",
                "input pinion to output frame, i1 (z + 1); negative: the output turns "
                "against the input",
            ),
            (
                "Backlash, first stage",
                "first_stage.lost_motion_arcmin",
                "arcmin",
                "the gear stage's backlash (pinion held) at the output: at the crank over "
                "z + 1; included in the whole drive's backlash and lost motion",
            ),
            ("Mass", "mass_kg", "kg", "every part (steel), as drawn"),
            (
                "Inertia at the input",
                "input_inertia_kg_m2",
                "kg m^2",
                "every moving part reflected to the pinion by its speed ratio squared"
                + (
                    "; the cams float on their needle bearings, spinning at 2 L / R_j times "
                    "the output (rolling kinematics, as the lives) (inertia_convention)"
                    if "inertia_convention" in sheet
                    else ""
                ),
            ),
        ]
    rows += budget_rows(sheet.get("compliance_budget"))
    rows += losses_rows(sheet)
    out = []
    for name, key, unit, convention in rows:
        try:
            v = _get(sheet, key)
        except (KeyError, TypeError, IndexError):  # a figure this sheet does not hold
            continue
        if v is None or isinstance(v, bool):  # a life without end: said, not a number
            continue
        v = float(v)
        out.append(
            {
                "name": name,
                "key": key,
                "value": v,
                "exact": repr(v),
                "text": catalogue_number(v),
                "unit": unit,
                "convention": convention,
            }
        )
    return out


#: The as-built figures of ``datasheet.json`` ``as_built`` (the Monte Carlo's percentiles):
#: name, metric, unit, percentiles shown (the catalogue side last).
AS_BUILT = (
    ("Lost motion", "lost_motion_arcmin", "arcmin", ("p50", "p95")),
    ("Transmission error", "transmission_error_arcsec", "arcsec", ("p50", "p95")),
    ("Torsional rigidity", "torsional_rigidity_Nm_per_arcmin", "N*m/arcmin", ("p50", "p5")),
)


def as_built_rows(sheet: dict) -> list[dict]:
    """With ``[tolerances]`` and the Monte Carlo: each figure's nominal value beside the
    percentiles of the drives as built (``datasheet.json`` ``as_built``)."""
    ab = sheet.get("as_built")
    if not ab:
        return []
    nominal = {
        "lost_motion_arcmin": "lost_motion_arcmin.max",
        "transmission_error_arcsec": "transmission_error_arcsec.catalogue",
        "torsional_rigidity_Nm_per_arcmin": "torsional_rigidity_Nm_per_arcmin.headline",
    }

    def cell(key: str) -> dict:
        v = float(_get(sheet, key))
        return {"key": key, "exact": repr(v), "text": catalogue_number(v)}

    out = []
    for name, metric, unit, qs in AS_BUILT:
        got = ab.get(metric) or {}
        cells = [cell(nominal[metric])] + [
            cell(f"as_built.{metric}.{q}") if got.get(q) is not None else None for q in qs
        ]
        out.append({"name": name, "unit": unit, "cells": cells})
    return out


def nominal_geometry(d: dict) -> bool:
    """Are the datasheet's figures those of the exact nominal geometry (no error, no
    measured or modified ring)? Then they are a perfect drive's, not an as-built one's."""
    ring = d.get("ring") or {}
    return ring.get("profile") == "nominal" and not ring.get("errors_applied")


def life_short(d: dict) -> str:
    """One sentence when the system L10 at the rated torque is short of ``rated_life_h``
    (``datasheet.json`` ``life_h``, ``rated_torque_from_life_Nm``); ``""`` otherwise."""
    life, rt = d.get("life_h") or {}, d.get("rated_torque_from_life_Nm") or {}
    system, rated = life.get("system"), rt.get("rated_life_h")
    if not isinstance(system, (int, float)) or not isinstance(rated, (int, float)):
        return ""
    if system >= rated or "at_torque_Nm" not in life or "value" not in rt:
        return ""
    return (
        f"life: the system L10 at the rated torque {figure(life['at_torque_Nm'], 5)} N*m is "
        f"{figure(system, 4)} h, short of the rated {figure(rated)} h at "
        f"{figure(rt.get('rated_speed_rpm', life.get('at_output_speed_rpm', 0.0)))} rpm; the "
        "rated torque from life is "
        f"{figure(rt['value'], 4)} N*m"
    )


def nominal_note(sheet: dict) -> str:
    """``"; nominal geometry: ..."`` for figures of the exact nominal geometry, else ``""``."""
    if not nominal_geometry(sheet):
        return ""
    return "; of the exact nominal geometry: a perfect drive's, not an as-built one's"


def friction_rows(sheet: dict) -> list[tuple]:
    """Efficiency, starting and backdriving torque, hysteresis and life (with ``[friction]``
    or ``[life]``): ``(name, key, unit, convention)`` rows of the catalogue table.

    A row whose figures ``datasheet.json`` does not hold is left out (the page's last
    table still lists every number the file holds)."""
    if "efficiency_forward" not in sheet:
        return []
    n = catalogue_number
    at_input = (
        "at the crank, the second stage's input (the first stage's own friction is not in "
        "it; at the pinion: divide by the first stage's ratio)"
        if sheet.get("total_ratio") is not None
        else "at the crank (the input)"
    )

    def eff(key: str, text: str) -> str:
        e = sheet[key]
        return f"{text} (mean {n(e['mean'])}, largest {n(e['max'])})" + (
            "; SELF-LOCKING at some torques" if e.get("self_locking") else ""
        )

    def life_text() -> str:
        life = sheet["life_h"]
        parts = {k: v for k, v in life.items() if k.split("_")[0] in ("bearing", "cam", "ring")}
        kept = [(k, v) for k, v in parts.items() if isinstance(v, (int, float))]
        shortest = min(kept, key=lambda kv: kv[1], default=None)
        return (
            f"90 % reliability, at {n(life['at_torque_Nm'])} N*m and "
            f"{n(life['at_output_speed_rpm'])} rpm at the output; every bearing and raceway "
            "combined" + (f"; the shortest: {shortest[0]}, {n(shortest[1])} h" if shortest else "")
        )

    def rated_text() -> str:
        rt = sheet["rated_torque_from_life_Nm"]
        return (
            f"the output torque at which the L10 is {n(rt['rated_life_h'])} h at "
            f"{n(rt['rated_speed_rpm'])} rpm at the output; bearing rating C_r "
            f"{n(rt['bearing_rating_N'])} N ({rt['bearing_rating_source']})"
        )

    wanted = [
        (
            "Efficiency, forward",
            "efficiency_forward.min",
            "",
            lambda: eff(
                "efficiency_forward",
                "1 - losses / input power over one cycle, the input driving; smallest over "
                "the map of speeds and torques",
            ),
        ),
        (
            "Efficiency, backdriving",
            "efficiency_backdriving.min",
            "",
            lambda: eff(
                "efficiency_backdriving",
                "1 - losses / output power, the output driving; smallest over the map",
            ),
        ),
        (
            "Starting torque",
            "starting_torque_Nm.max",
            "N*m",
            lambda: (
                f"input torque to turn the drive at no output load, {at_input}; largest "
                "over the positions (preload and friction; no seal model)"
            ),
        ),
        (
            "Backdriving torque",
            "backdriving_torque_Nm.max",
            "N*m",
            lambda: (
                "output torque to turn the drive from the output at no input load; "
                "largest over the positions"
            ),
        ),
        (
            "Hysteresis loss",
            "hysteresis_loss_arcmin",
            "arcmin",
            lambda: (
                "the loop's width at zero torque beyond the backlash (friction); largest "
                "over the positions"
            ),
        ),
        (
            "Hysteresis width at T_R",
            "hysteresis_width_at_rated_arcmin.max",
            "arcmin",
            lambda: "loading minus unloading branch at +-T_R; largest over the positions",
        ),
        ("Life L10 at T_R", "life_h.system", "h", life_text),
        ("Rated torque from life", "rated_torque_from_life_Nm.value", "N*m", rated_text),
    ]
    rows = []
    for name, key, unit, text in wanted:
        try:
            _get(sheet, key)
            rows.append((name, key, unit, text()))
        except (KeyError, TypeError, IndexError):
            continue
    return rows


def _model(sheet: dict, design, title: str, modification: str, version: str) -> list[tuple]:
    pos = sheet["positions"]
    ring = sheet["ring"]
    if ring.get("profile") == "measured":
        ring_text = f"measured ring {ring.get('file')}, other parts nominal"
    elif modification:
        ring_text = f"modified profile: {modification}"
    else:
        ring_text = "conjugate (exact working) profile"
    errs = ring.get("errors_applied") or []
    return [
        ("Design", title),
        (
            "Drive",
            f"z = {design.tooth_count} teeth, {design.roller_count} rollers, ratio "
            f"{design.roller_count} (ring fixed, frame output); cam radius "
            f"{catalogue_number(design.cam_radius)} mm, roller radius "
            f"{catalogue_number(design.roller_radius)} mm, eccentricity "
            f"{catalogue_number(design.eccentricity)} mm, roller length "
            f"{catalogue_number(design.roller_length)} mm",
        ),
        *(
            [("First stage", f"a gear stage ahead of it: total ratio {catalogue_number(ratio)}")]
            if (ratio := sheet.get("total_ratio")) is not None
            else []
        ),
        ("Ring", ring_text),
        ("Errors applied", ", ".join(errs) if errs else "none (nominal parts)"),
        ("Contact model", model_text(sheet)),
        *(
            [
                (
                    "Elastic bodies",
                    "in the figures: "
                    + ", ".join(b["in_figure"])
                    + "; not in them: "
                    + ", ".join(b["not_in_figure"])
                    + f" (FE mesh {b['mesh_size_mm']:g} mm)",
                )
            ]
            if isinstance(b := sheet.get("bodies"), dict)
            else []
        ),
        (
            "Positions",
            f"{pos['count']} output positions over {pos['span']} "
            f"({pos['positions_per_mesh']} per mesh period), {sheet['torque_levels']} torque "
            f"levels from -T_R to +T_R; transmission error at "
            f"{sheet['transmission_error_arcsec']['positions']} positions over one output "
            "revolution",
        ),
        ("Windup", sheet["conventions"]["windup"]),
        ("Hysteresis loss", sheet["hysteresis_loss_note"]),
        ("Made by", f"corr-cad {version}; the numbers are those of datasheet.json"),
    ]


def render_datasheet_html(
    sheet: dict,
    design,
    out: Path,
    title: str,
    modification: str = "",
    version: str = "",
) -> str:
    """The page's HTML text; the PNGs are read from ``out``."""
    from corr_cad.export.html import render_template

    figures = []
    for name, caption in (
        (
            "hysteresis.png",
            "Hysteresis: output windup against output torque, input locked, at every "
            "position evaluated (the catalogue bench's loop 0 -> +T_R -> 0 -> -T_R -> 0).",
        ),
        (
            "transmission_error.png",
            "Transmission error over one output revolution, both driving directions.",
        ),
    ):
        data = base64.b64encode((Path(out) / name).read_bytes()).decode("ascii")
        figures.append({"name": name, "data": data, "caption": caption})
    if "compliance_budget" in sheet:
        data = base64.b64encode((Path(out) / "compliance.png").read_bytes()).decode("ascii")
        caption = (
            "Compliance budget: the windup at T_R and over the rigidity range split by "
            "component (each element's force times its own deflection, over the torque: "
            "they add up); grey: held rigid or not modelled."
        )
        figures.append({"name": "compliance.png", "data": data, "caption": caption})
    notes = []
    if short := life_short(sheet):
        notes.append("Short life: " + short.removeprefix("life: ") + ".")
    if nominal_note(sheet):
        notes.append(
            "The figures are those of the exact nominal geometry (no manufacturing error, no "
            "measured or modified ring): a perfect drive's. A drive as built has the play, "
            "rigidity and transmission error its tolerances give"
            + (
                "; the as-built figures below are the Monte Carlo's."
                if sheet.get("as_built")
                else " (give [tolerances] and the montecarlo format for them)."
            )
        )
    return render_template(
        "datasheet.html.j2",
        {
            "title": title,
            "notes": notes,
            "rows": datasheet_rows(sheet),
            "as_built": as_built_rows(sheet),
            "figures": figures,
            "model": _model(sheet, design, title, modification, version),
            "all_figures": all_figures(sheet),
        },
    )


def write_datasheet_html(
    sheet: dict, design, out: Path, title: str, modification: str = "", version: str = ""
) -> Path:
    """Write ``datasheet.html`` into ``out`` (beside the PNGs it embeds); returns its path."""
    html = render_datasheet_html(sheet, design, out, title, modification, version)
    path = Path(out) / "datasheet.html"
    with writing(path) as tmp:
        tmp.write_text(html, encoding="utf-8")
    return path


def model_text(sheet: dict) -> str:
    """The model behind the figures: contact law, one row or the drive, friction."""
    if sheet.get("contact_law") == "palmgren":
        law = "Palmgren steel line contacts (delta = 3.84e-5 Q^0.9 / l^0.8)"
    else:
        law = f"Hertz line contacts ({sheet.get('contact_model', 'nonlinear')})"
    if sheet.get("model") == "drive":
        bearing = sheet.get("bearing")
        cams = (
            f"cams on {bearing['needles']}-needle bearings"
            if isinstance(bearing, dict)
            else "cams fixed on the crank"
        )
        rows = f"both rows solved together, {cams}"
        share = sheet.get("row_a_share_by_direction")
        if isinstance(share, dict):
            n = catalogue_number
            rows += "; row A carries " + " and ".join(
                f"{n(share[d]['min'])} to {n(share[d]['max'])} of the crank moment at {s}T_R"
                for d, s in (("positive", "+"), ("negative", "-"))
            )
        elif isinstance(share := sheet.get("row_a_share"), dict):
            rows += (
                f"; row A carries {catalogue_number(share['min'])} to "
                f"{catalogue_number(share['max'])} of the crank moment"
            )
    else:
        rows = (
            f"one row carrying a load share {catalogue_number(sheet['load_share'])} "
            "(the paper's model: an upper bound on rigidity)"
        )
    friction = (
        "Coulomb friction in the efficiency and hysteresis figures"
        if "efficiency_forward" in sheet
        else "frictionless"
    )
    text = f"{law}; {rows}; {friction}"
    if v := sheet.get("variants"):
        text += f"; printed-paper variants {', '.join(v)}"
    return text
