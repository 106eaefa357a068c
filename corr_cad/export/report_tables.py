"""The report's tables of figures: the datasheet, friction and life, the whole drive,
the Monte Carlo's binding share and the selective assembly.

Each function turns a block of ``datasheet.json``, ``manifest.json`` or
``assembly.json`` into the rows ``report.html.j2`` lays out, every number
through one formatter (:func:`fmt`, the console's and the plots'
:func:`~corr_cad.figure_text.figure`).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from corr_cad.figure_text import figure

__all__ = [
    "assembly_rows",
    "binding_row",
    "datasheet_rows",
    "drive_rows",
    "fmt",
    "friction_rows",
    "from_drive",
    "ring_line",
]


def fmt(v, digits: int = 4) -> str:
    """A report cell: '-' for None, yes/no, whole numbers with commas, else figure()."""
    if v is None:
        return "-"
    if isinstance(v, bool):
        return "yes" if v else "no"
    if isinstance(v, (int, np.integer)):
        return f"{int(v):,}"
    if isinstance(v, (float, np.floating)):  # the console's and the plots' formatter
        return figure(float(v), digits)
    return str(v)


def drive_rows(fs: dict, drive: dict | None) -> list[tuple]:
    """The whole drive: first-stage geometry, ratio, mass, inertia and loads (name, value, unit)."""
    g, m = fs["gears"], fs["meshes"]
    rows = [
        (
            "teeth pinion / wheels (3) / crank gear",
            " / ".join(str(g[k]["teeth"]) for k in ("pinion", "wheel", "crank_gear")),
            "",
        ),
        ("module", fs["module_mm"], "mm"),
        ("first-stage ratio i1 = -z_c / z_p", fs["ratio_i1"], ""),
        ("centre distance (pinion to each wheel)", fs["centre_distance_mm"], "mm"),
    ]
    for name, label in (("pinion_wheel", "pinion-wheel"), ("wheel_crank_gear", "wheel-crank gear")):
        rows += [
            (f"{label}: working pressure angle", m[name]["working_pressure_angle_deg"], "deg"),
            (f"{label}: contact ratio", m[name]["contact_ratio"], ""),
            (f"{label}: backlash", 1e3 * m[name]["backlash_mm"], "um"),
        ]
    rows.append(("first-stage backlash at the crank", fs["crank_backlash_arcmin"], "arcmin"))
    if drive:
        rows += [
            ("total ratio i = i1 (z + 1)", drive["total_ratio"], ""),
            ("mass (all parts, steel)", drive["mass_kg"], "kg"),
            ("inertia at the input", drive["input_inertia_kg_m2"], "kg m^2"),
        ]
        ld = drive.get("first_stage_loads")
        if ld:
            w = ld["per_wheel"]
            rows += [
                ("input torque at the pinion", ld["input_torque_Nmm"] / 1e3, "N*m"),
                ("crank moment M0 (eta1 = 1)", ld["crank_torque_M0_Nmm"] / 1e3, "N*m"),
                ("per wheel: tangential force, pinion mesh", w["pinion_mesh_tangential_N"], "N"),
                ("per wheel: bearing load", w["bearing_load_N"], "N"),
                ("root stress, largest (Lewis)", max(ld["root_bending_MPa"].values()), "MPa"),
                ("contact stress, largest (Hertz)", max(ld["contact_stress_MPa"].values()), "MPa"),
            ]
    return [(a, fmt(b) if not isinstance(b, str) else b, c) for a, b, c in rows]


def binding_row(b: dict | None) -> dict | None:
    """The Monte Carlo's share of binding samples with its Wilson interval, or None."""
    if not b:
        return None

    def pct(x: float) -> str:  # round-off below 1e-9 % is 0 (a Wilson end at 0 samples)
        x = 100.0 * float(x)
        return fmt(x if abs(x) > 1e-9 else 0.0, 3)

    lo, hi = b["wilson_interval"]
    return {
        "percent": pct(b["probability"]),
        "count": f"{b['binding_samples']} of {b['samples']}",
        "interval": f"{pct(lo)} - {pct(hi)}",
        "confidence": fmt(100.0 * b["confidence"], 3),
    }


def datasheet_rows(d: dict) -> dict:
    """The datasheet table: figure, min, mean, max, unit, catalogue convention."""
    rig = d["torsional_rigidity_Nm_per_arcmin"]
    lm = d["lost_motion_arcmin"]
    k = d["stiffness_Nm_per_arcmin"]
    te = d["transmission_error_arcsec"]

    def row(label, x, unit, note):
        return {
            "label": label,
            "min": fmt(x["min"]),
            "mean": fmt(x["mean"]),
            "max": fmt(x["max"]),
            "unit": unit,
            "note": note,
        }

    span = f"{fmt(rig['from_torque_Nm'])}-{fmt(rig['to_torque_Nm'])} N*m"
    whole = d.get("whole_drive")
    stage = ", second stage (crank locked)" if whole else ""
    rows = [
        row(
            f"backlash{stage}",
            d["backlash_arcmin"],
            "arcmin",
            "theta(0+) - theta(0-); catalogue: max",
        ),
        row(
            f"lost motion{stage}",
            lm,
            "arcmin",
            f"at +-{fmt(100 * lm['band'])} % T_R ({fmt(lm['torque_Nm'])} N*m); catalogue: max",
        ),
    ]
    if whole:  # the whole drive, pinion held: one value each (the largest plus the first stage)
        for label, key in (("lost motion", "lost_motion_arcmin"), ("backlash", "backlash_arcmin")):
            first = fmt(d["first_stage"][key])
            rows.insert(  # backlash first, as the page and the console give them
                0,
                {
                    "label": f"{label}, whole drive (pinion held)",
                    "min": "",
                    "mean": "",
                    "max": fmt(whole[key]["value"]),
                    "unit": "arcmin",
                    "note": f"the second stage's largest plus the first stage's {first} arcmin",
                },
            )
    if rig["with_series"] is not None:
        rows.append(
            row(
                "torsional rigidity",
                rig["with_series"],
                "N*m/arcmin",
                f"{span}, series rigidity {fmt(rig['series_rigidity_Nm_per_arcmin'])} "
                "N*m/arcmin included; catalogue: min",
            )
        )
    label = "torsional rigidity, contacts alone"
    if d.get("compliances"):  # [crankshaft] / [bearings.crank]: the model's compliances
        comp = d["compliances"]
        note = f"{span}; {'; '.join(comp['in_figure'])}; without {', '.join(comp['not_in_figure'])}"
        label = "torsional rigidity, model"
    elif d.get("model") == "drive":
        what = (
            "both rows' contacts and the cams' eccentric bearings"
            if isinstance(d.get("bearing"), dict)
            else "both rows' contacts, cams fixed"
        )
        note = f"{span}; {what}; without crank, output bearings and housing"
    else:
        note = (
            f"{span}; one row's contacts only (model = paper, at load_share): an upper bound, "
            "not the reducer's rigidity"
        )
    rows.append(row(label, rig["contact_only"], "N*m/arcmin", note))
    bp = ", ".join(fmt(b) for b in k["breakpoints_Nm"])
    for name in ("K1", "K2", "K3"):
        rows.append(row(name, k[name], "N*m/arcmin", f"slopes between 0, {bp} N*m"))
    return {
        "rated_torque": fmt(d["rated_torque_Nm"]),
        "positions": d["positions"]["count"],
        "span": d["positions"]["span"],
        "rows": rows,
        "te_forward": fmt(te["forward_peak_to_peak"]),
        "te_reverse": fmt(te["reverse_peak_to_peak"]),
        "te_torque": fmt(te["driving_torque_Nm"]),
        "pressure_rated": (
            None
            if "rated_torque_from_contact_pressure" not in d
            else {
                "torque": fmt(d["rated_torque_from_contact_pressure"]["torque_Nm"]),
                "allowable": fmt(d["rated_torque_from_contact_pressure"]["allowable_MPa"]),
            }
        ),
        "hysteresis": d["hysteresis_loss_note"],
        "hysteresis_value": fmt(d["hysteresis_loss_arcmin"]),
        "friction": (friction_rows(d) if "efficiency_forward" in d else []) + losses_rows(d),
        "ring": ring_line(d.get("ring")),
    }


def from_drive(d: dict) -> bool:
    """Whether ``datasheet.json``'s friction figures come from the two-row drive."""
    return d.get("friction", {}).get("forces", "").startswith("drive")


def friction_rows(d: dict) -> list[dict]:
    """Efficiency, starting torque, lives and rated torque from life (min, mean, max)."""

    def row(label, x, unit, note):
        return {
            "label": label,
            "min": fmt(x["min"]),
            "mean": fmt(x["mean"]),
            "max": fmt(x["max"]),
            "unit": unit,
            "note": note,
        }

    bk = d["efficiency_backdriving"]
    rows = [
        row(
            "efficiency, forward",
            d["efficiency_forward"],
            "",
            "over the torque-speed map" + (", both rows of the drive" if from_drive(d) else ""),
        ),
        row(
            "efficiency, backdriving",
            bk,
            "",
            "self-locking at some torques" if bk["self_locking"] else "output driving",
        ),
        row("hysteresis width at T_R", d["hysteresis_width_at_rated_arcmin"], "arcmin", "friction"),
        row("starting torque", d["starting_torque_Nm"], "N*m", "at the input, no load"),
    ]
    life = d.get("life_h")
    if life:
        for k, v in life.items():
            if k in ("at_torque_Nm", "at_output_speed_rpm", "definition"):
                continue
            s = "inf" if v is None else fmt(v)
            rows.append(
                {
                    "label": f"L10 {k}",
                    "min": "",
                    "mean": "",
                    "max": s,
                    "unit": "h",
                    "note": f"at {fmt(life['at_torque_Nm'])} N*m, "
                    f"{fmt(life['at_output_speed_rpm'])} rpm output",
                }
            )
        rt = d["rated_torque_from_life_Nm"]
        rows.append(
            {
                "label": "rated torque from life",
                "min": "",
                "mean": "",
                "max": fmt(rt["value"]),
                "unit": "N*m",
                "note": f"L10 {fmt(rt['rated_life_h'])} h at "
                f"{fmt(rt['rated_speed_rpm'])} rpm output",
            }
        )
    return rows


def losses_rows(d: dict) -> list[dict]:
    """``[lubrication]`` / ``[thermal]``: total efficiency, drag, L10m, temperatures."""
    li = d.get("load_independent_losses")
    if not li:
        return []
    e, st = d["efficiency_total"], d["starting_torque_total_Nm"]

    def one(label, value, unit, note, lo="", mid=""):
        return {"label": label, "min": lo, "mean": mid, "max": value, "unit": unit, "note": note}

    drag = li["torque_at_crank_Nm"]
    rows = [
        one(
            "efficiency, total",
            fmt(e["forward_max"]),
            "",
            f"with Palmgren bearing drag and seals over {fmt(min(e['temperatures_C']))}-"
            f"{fmt(max(e['temperatures_C']))} C oil ({d['lubrication']['source']})",
            lo=fmt(e["forward_min"]),
        ),
        one(
            "drag torque at the crank",
            fmt(max(drag)),
            "N*m",
            f"load-independent, {fmt(li['at_temperature_C'])} C oil, "
            f"{fmt(min(li['input_speed_rpm']))}-{fmt(max(li['input_speed_rpm']))} rpm",
            lo=fmt(min(drag)),
        ),
        one("starting torque, total", fmt(st["at_input"]), "N*m", "at the input: drag + preload"),
    ]
    for tag, m in d.get("modified_life", {}).items():
        if isinstance(m, dict) and "a_ISO" in m:
            life = "inf" if m["L10m_h"] is None else fmt(m["L10m_h"])
            rows.append(
                one(
                    f"L10m {tag}",
                    life,
                    "h",
                    f"ISO 281 a_ISO {fmt(m['a_ISO'])}, kappa {fmt(m['kappa'])}",
                )
            )
    th = d.get("thermal")
    if th:
        n = th["steady_temperature_C"]["no_load"]
        shown = [x for x in n if x is not None]
        if shown:
            rows.append(
                one(
                    "steady oil temperature, no load",
                    fmt(max(shown)),
                    "C",
                    "over the map's crank speeds (one-node network)",
                    lo=fmt(min(shown)),
                )
            )
        rated = th["thermal_rating"]["input_speed_at_rated_torque_rpm"]
        if rated is not None:
            rows.append(
                one(
                    "thermal rating at T_R",
                    fmt(rated),
                    "rpm",
                    f"crank speed at {fmt(th['thermal_rating']['max_oil_temperature_C'])} C oil",
                )
            )
    tt = d.get("thermal_test")
    if tt:
        rows.append(
            one(
                "temperature test, final",
                fmt(tt["final_temperature_C"]),
                "C",
                f"after {fmt(tt['duration_min'])} min (temperature.csv)",
            )
        )
    return rows


def assembly_rows(path: Path) -> dict:
    """The selective-assembly table: one row per roller class, the chosen one marked."""
    import json

    a = json.loads(path.read_text())
    rows = [
        {
            "class_um": fmt(r["class_um"]),
            "binds": "yes" if r["binds"] else "no",
            "backlash": fmt(r["backlash_arcmin"]["max"]),
            "lost_motion": fmt(r["lost_motion_arcmin"]["max"]),
            "rigidity": fmt(r["torsional_rigidity_Nm_per_arcmin"]),
            "te": fmt(max(r["transmission_error_arcsec"].values())),
            "pressure": fmt(r["peak_contact_pressure_at_rated_MPa"]),
            "chosen": r["class_um"] == a["chosen_class_um"],
        }
        for r in a["classes"]
    ]
    return {
        "ring": a["ring"],
        "target": fmt(a["target_backlash_arcmin"]),
        "chosen": a["chosen_class_um"],
        "reason": a["reason"],
        "rows": rows,
    }


def ring_line(ring: dict | None) -> str:
    """Which ring a datasheet describes, in one line (report and console).

    >>> ring_line({"profile": "measured", "file": "cmm.csv", "sha256": "ab" * 32})
    'the measured ring cmm.csv (sha256 abababababab...) with nominal other parts'
    """
    if not ring:
        return ""
    if ring.get("profile") == "measured":
        return (
            f"the measured ring {ring.get('file')} (sha256 {str(ring.get('sha256'))[:12]}...) "
            "with nominal other parts"
        )
    applied = ring.get("errors_applied") or []
    return "the design" + (f" with [errors] {', '.join(applied)}" if applied else " (nominal)")
