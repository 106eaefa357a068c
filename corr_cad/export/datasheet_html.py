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

from corr_cad.export.files import writing

__all__ = ["catalogue_number", "datasheet_rows", "render_datasheet_html", "write_datasheet_html"]


def catalogue_number(value: float, digits: int = 4) -> str:
    """``value`` with ``digits`` significant digits, thousands separated, never in e-notation.

    >>> catalogue_number(21256.3), catalogue_number(0.0123456), catalogue_number(2.2e-19)
    ('21,256', '0.01235', '0')
    >>> catalogue_number(2860.0), catalogue_number(-0.5)
    ('2,860', '-0.5')
    """
    v = float(value)
    if not math.isfinite(v):
        raise ValueError(f"not a finite number: {v!r}")
    if abs(v) < 1e-9:
        return "0"
    decimals = max(0, digits - 1 - math.floor(math.log10(abs(v))))
    text = f"{v:,.{decimals}f}"
    if "." in text:
        text = text.rstrip("0").rstrip(".")
    return text


def _get(data: dict, key: str):
    for part in key.split("."):
        data = data[part]
    return data


def datasheet_rows(sheet: dict) -> list[dict]:
    """The catalogue table: one row per figure (name, key, value, unit, convention)."""
    lm = sheet["lost_motion_arcmin"]
    rig = sheet["torsional_rigidity_Nm_per_arcmin"]
    te = sheet["transmission_error_arcsec"]
    k = sheet["stiffness_Nm_per_arcmin"]["breakpoints_Nm"]
    series = rig.get("series_rigidity_Nm_per_arcmin")
    n = catalogue_number
    rows = [
        ("Rated output torque T_R", "rated_torque_Nm", "N*m", sheet["rated_torque_source"]),
        (
            "Backlash",
            "backlash_arcmin.max",
            "arcmin",
            "theta(0+) - theta(0-): free output rotation at zero torque, input locked; "
            "largest over the positions",
        ),
        (
            "Lost motion",
            "lost_motion_arcmin.max",
            "arcmin",
            f"theta(+b T_R) - theta(-b T_R), b = {n(100 * lm['band'])} % "
            f"(+-{n(lm['torque_Nm'])} N*m); largest over the positions",
        ),
        (
            "Torsional rigidity",
            "torsional_rigidity_Nm_per_arcmin.catalogue",
            "N*m/arcmin",
            f"(T_2 - T_1) / (theta(T_2) - theta(T_1)), T_1 = {n(rig['from_torque_Nm'])} N*m, "
            f"T_2 = {n(rig['to_torque_Nm'])} N*m, both directions; smallest over the positions; "
            + (
                f"contacts in series with {n(series)} N*m/arcmin (bearings, shafts, housing)"
                if series is not None
                else "the contacts and the elastic rings, frame and cams (no series rigidity "
                "given: crank, bearings and housing rigid)"
                if isinstance(sheet.get("bodies"), dict)
                else "the contacts alone (no series rigidity given: far stiffer than a reducer)"
            ),
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
            f"{n(te['driving_torque_Nm'])} N*m, the larger of the two directions",
        )
    )
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
                "z + 1; adds to the backlash and lost motion above",
            ),
            ("Mass", "mass_kg", "kg", "every part (steel), as drawn"),
            (
                "Inertia at the input",
                "input_inertia_kg_m2",
                "kg m^2",
                "every moving part reflected to the pinion by its speed ratio squared",
            ),
        ]
    out = []
    for name, key, unit, convention in rows:
        v = float(_get(sheet, key))
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
    return render_template(
        "datasheet.html.j2",
        {
            "title": title,
            "rows": datasheet_rows(sheet),
            "figures": figures,
            "model": _model(sheet, design, title, modification, version),
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
        share = sheet.get("row_a_share")
        if isinstance(share, dict):
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
