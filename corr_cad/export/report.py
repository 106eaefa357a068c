"""report.html: one self-contained page a designer can mail.

Rendered with Jinja2 from ``corr_cad/templates/report.html.j2`` (shipped in
the package). No network: CSS is inline and every plot is embedded as a
base64 PNG data URI. The report stage runs last and reads what the run has
assembled so far (the manifest data, the solver's results and the files in
the staging folder). No time stamps: the same scene gives the same bytes.
"""

from __future__ import annotations

import base64
import math
from pathlib import Path

import numpy as np

from corr_cad.export.files import writing
from corr_cad.export.report_tables import (
    assembly_rows,
    binding_row,
    datasheet_rows,
    drive_rows,
    ring_line,
)
from corr_cad.export.report_tables import fmt as _fmt

__all__ = ["METRIC_LABELS", "ring_line", "report_context", "render_report", "write_report"]

_CHECK_UNITS = {
    "max_contact_pressure": "MPa",
    "max_gear_force": "N",
    "min_loaded_rollers": "",
    "max_lost_motion_arcmin": "arcmin",
    "max_backlash_arcmin": "arcmin",
    "min_torsional_rigidity_Nm_per_arcmin": "N*m/arcmin",
    "max_transmission_error_arcsec": "arcsec",
    "min_efficiency": "",
    "min_life_h": "h",
    "max_first_stage_bending_MPa": "MPa",
    "max_first_stage_contact_MPa": "MPa",
}
#: Every column of ``montecarlo_summary.json``'s percentiles: the force
#: metrics, and the datasheet metrics when the Monte Carlo carries them
#: (``corr_cad.tolerance.mc_datasheet``). A metric without a row here is
#: shown under its own name (``tests/test_report.py`` checks that none is).
METRIC_LABELS = {
    "peak_gear_force": ("peak gear force F_n", "N"),
    "peak_pressure": ("peak contact pressure", "MPa"),
    "min_loaded_rollers": ("fewest loaded rollers", ""),
    "backlash_arcmin": ("output backlash", "arcmin"),
    "lost_motion_arcmin": ("lost motion (datasheet band)", "arcmin"),
    "torsional_rigidity_Nm_per_arcmin": ("torsional rigidity (catalogue: min)", "N*m/arcmin"),
    "transmission_error_arcsec": ("transmission error, peak to peak", "arcsec"),
    "binding_pressure_MPa": ("binding preload pressure", "MPa"),
}
_PLOT_CAPTIONS = {
    "preview.png": "The stage at crank angle 0 (shaded: material) and a tooth close-up",
    "first_stage.png": "The first gear stage at crank angle 0 and wheel 1's two meshes",
    "forces.png": "Forces over the cycle: envelope over all rollers, roller 1, contact pressure",
    "load_distribution.png": "Forces on every roller where the gear force peaks",
    "interference.png": "Interference check against the tessellation allowance",
    "pareto.png": "Design search: the candidates and the front, the scene's own design starred",
    "montecarlo.png": "Monte Carlo: distributions, limits, failure probability, sensitivity",
    "hysteresis.png": "Hysteresis curve: output torque against windup, input locked",
    "transmission_error.png": "Transmission error over one output revolution, both directions",
    "compliance.png": "Compliance budget: the windup at T_R split by component",
}


def _force_peaks(res) -> list[dict]:
    """Largest value of each force and pressure over all rollers and positions."""
    ang = np.degrees(np.asarray(res.crank_angles))
    rows = []
    for key, label, unit in (
        ("F_j", "cam force F_j", "N"),
        ("F_n", "gear force F_n", "N"),
        ("F_s", "slot force |F_s|", "N"),
        ("p_cam", "contact pressure, cam", "MPa"),
        ("p_gear", "contact pressure, gear", "MPa"),
        ("p_slot", "contact pressure, slot", "MPa"),
    ):
        a = np.abs(np.asarray(getattr(res, key)))
        k, j = np.unravel_index(np.argmax(a), a.shape)
        rows.append(
            {
                "label": label,
                "value": float(a[k, j]),
                "unit": unit,
                "roller": int(j) + 1,
                "crank_angle_deg": float(ang[k]),
            }
        )
    return rows


def _accuracy_of(name: str, manifest: dict) -> str:
    """What is known about how closely a file matches the exact geometry."""
    acc = manifest.get("accuracy", {})
    solids = manifest.get("solids", {})
    stem, _, ext = name.rpartition(".")
    if ext == "dxf" and stem == "inner_gear" and "working_profile" in acc:
        w, t = acc["working_profile"], acc.get("theoretical_profile", {})
        text = (
            f"working profile {w['representation']}: measured max deviation "
            f"{_fmt(w['max_deviation_mm'], 3)} mm (tolerance {_fmt(w['tolerance_mm'], 3)} mm)"
        )
        if t:
            text += f"; theoretical profile {_fmt(t['max_deviation_mm'], 3)} mm"
        return text
    if ext == "dxf" and stem in ("disk_cam", "roller", "teeth_frame"):
        return "exact circles, lines and arcs"
    if ext == "dxf" and stem == "measured_profile" and "measured_profile" in manifest:
        m = manifest["measured_profile"]
        return f"registered measurement, rms {_fmt(m.get('rms_mm'), 3)} mm"
    if ext in ("stl", "3mf", "glb", "ply") and stem in solids:
        s = solids[stem]
        return (
            f"chord tolerance {_fmt(s['chord_tolerance_mm'], 3)} mm; volume error "
            f"{_fmt(s['volume_error_mm3'], 3)} mm^3 (bound {_fmt(s['volume_error_bound_mm3'], 3)})"
        )
    if ext in ("stl", "3mf", "glb", "ply") and stem.startswith("assembly_"):
        return "parts as above, placed at the crank angle"
    if ext == "step" and name in manifest.get("step", {}):
        s = manifest["step"][name]
        if "instances" in s:  # the assembly: named instances of the part products
            return (
                f"read back: {s['instances']} named instances, placement error "
                f"{_fmt(s.get('max_placement_error_mm'), 3)} mm"
            )
        if "solids" in s:  # FreeCAD's variant of the assembly: one compound
            return (
                f"the assembly as one compound for FreeCAD: {s['solids']} solids, "
                f"volume relative error {_fmt(s['volume_relative_error'], 3)}"
            )
        text = f"read back: volume error {_fmt(s['volume_error_mm3'], 3)} mm^3"
        if s.get("profile_spline_deviation_mm") is not None:
            text += f", profile spline {_fmt(s['profile_spline_deviation_mm'], 3)} mm"
        return text
    if ext == "png":
        return "plot (embedded below)"
    return "computed data (no geometry approximation)"


def report_context(scene, manifest: dict, forces, files: list[str], out: Path) -> dict:
    """Everything the template shows, as plain values (numbers formatted).

    ``forces`` is the run's force solution (a ``ForceResult``), or None when
    the scene solved none.
    """
    d = scene.design
    design_rows = [
        ("tooth count z", d.tooth_count, ""),
        ("rollers z + 1", d.roller_count, ""),
        ("cam radius Rj", d.cam_radius, "mm"),
        ("roller radius r", d.roller_radius, "mm"),
        ("roller length l", d.roller_length, "mm"),
        ("eccentricity e", d.eccentricity, "mm"),
        ("ring outer radius", d.ring_outer_radius, "mm"),
        ("face width", d.face_width, "mm"),
        ("cam bore radius", d.cam_bore_radius, "mm"),
        ("frame plate radii", f"{d.frame_inner_radius:.4g} .. {d.frame_outer_radius:.4g}", "mm"),
        ("frame plate thickness", d.frame_thickness, "mm"),
        ("ratio (frame output)", d.roller_count, ": 1"),
    ]
    material_rows = [
        ("Young's modulus E", d.material.young_modulus, "MPa"),
        ("Poisson's ratio", d.material.poisson_ratio, ""),
    ]
    ctx: dict = {
        "title": f"corr-cad report: {scene.name}",
        "scene": scene.name,
        "version": manifest.get("version") or _version(),
        "formats": ", ".join(scene.formats),
        "design": [(a, _fmt(b), c) for a, b, c in design_rows],
        "material": [(a, _fmt(b), c) for a, b, c in material_rows],
        "load": None,
    }
    if scene.load is not None:
        ctx["load"] = {
            "input_torque": _fmt(scene.load.input_torque),
            "load_share": _fmt(scene.solver.load_share),
        }
        f = manifest.get("forces") or {}
        if f.get("model") == "drive":  # the drive model states its model, law and bearing
            b = f.get("bearing")
            sh = f.get("row_a_share") or {}
            ctx["load"].update(
                model="drive (both rows, both cams)",
                contact_law=f.get("contact_law"),
                bearing=(
                    f"{b['needles']} needles {_fmt(b['needle_diameter_mm'])} x "
                    f"{_fmt(b['needle_length_mm'])} mm, Pd {_fmt(b['diametral_clearance_mm'])} mm"
                    if isinstance(b, dict)
                    else b
                ),
                row_a_share=" / ".join(_fmt(sh.get(k)) for k in ("min", "mean", "max")),
            )
    if scene.first_stage is not None:
        ctx["drive"] = drive_rows(scene.first_stage.as_dict(), manifest.get("drive"))
    u = manifest.get("undercut")
    if u:
        adm = u["admissible_roller_radius_mm"]
        margin = adm - d.roller_radius
        ctx["undercut"] = {
            "undercut": u["undercut"],
            "admissible": _fmt(adm),
            "margin": _fmt(margin),
            "margin_pct": _fmt(100.0 * margin / adm if math.isfinite(adm) else None, 3),
            "tip_radius": _fmt(u["min_working_radius_mm"]),
            "trimmed": u.get("trimmed_psi_deg"),
        }
    checks = dict(manifest.get("checks") or {})
    gate = checks.pop("montecarlo", {})  # the Monte Carlo gate: probabilities per limit
    if checks or gate:
        rows = [
            {
                "name": k,
                "limit": _fmt(r["limit"]),
                "value": _fmt(r["value"]),
                "margin": _fmt(r["margin"]),
                "unit": _CHECK_UNITS.get(k, ""),
                "passed": r["passed"],
                "passes_with": " or ".join(
                    f"{m['parameter']} {m['sense']} {m['value']:.6g} {m['unit']}"
                    for m in r.get("passes_with") or []
                )
                or ("none found" if "passes_with" in r else ""),
            }
            for k, r in checks.items()
        ]
        rows += [
            {
                "name": f"montecarlo {k} (failure probability)",
                "limit": _fmt(g["allowed"]),
                "value": _fmt(g["probability"]),
                "margin": _fmt(g["allowed"] - g["probability"]),
                "unit": "",
                "passed": g["passed"],
                "passes_with": "",
            }
            for k, g in gate.items()
        ]
        ctx["checks"] = rows
        ctx["checks_passed"] = all(r["passed"] for r in rows)
    res = forces
    if res is not None:
        f = manifest.get("forces", {})
        ctx["forces"] = {
            "peaks": [
                {**p, "value": _fmt(p["value"]), "crank_angle_deg": _fmt(p["crank_angle_deg"])}
                for p in _force_peaks(res)
            ],
            "positions": int(res.F_j.shape[0]),
            "roller1": [
                ("mean F_j (loaded part)", _fmt(f.get("F_j_mean")), "N"),
                ("mean F_n (loaded part)", _fmt(f.get("F_n_mean")), "N"),
                ("peak F_n", _fmt(f.get("F_n_peak")), "N"),
                ("F_s peak to peak", _fmt(f.get("F_s_peak_to_peak")), "N"),
            ],
            "loaded": f"{f.get('loaded_rollers_min')} - {f.get('loaded_rollers_max')}",
            "output_torque": _fmt(float(np.mean(res.output_torque))),
            "outside_validity": int(np.count_nonzero(~res.valid & (res.F_j > 0))),
            "row": f.get("heavier_row"),
        }
    sheet = manifest.get("datasheet")
    if sheet:
        ctx["datasheet"] = datasheet_rows(sheet)
    mc = manifest.get("montecarlo")
    if mc:
        fail = mc.get("failure_probability", {})
        nominal = mc.get("nominal", {})
        ctx["montecarlo"] = {
            "samples": mc["samples"],
            "rows": [
                {
                    "label": METRIC_LABELS.get(m, (m.replace("_", " "), ""))[0],
                    "unit": METRIC_LABELS.get(m, ("", ""))[1],
                    "nominal": _fmt(nominal.get(m)),
                    **{q: _fmt(pct.get(q)) for q in ("p5", "p50", "p95", "p99")},
                }
                for m, pct in mc["percentiles"].items()
            ],
            "fail": [(k, _fmt(100.0 * v, 3)) for k, v in fail.items()],
            "binding": binding_row(mc.get("binding_probability")),
            "sensitivity": [
                (s["tolerance"], _fmt(s["score"], 3)) for s in mc.get("sensitivity", [])
            ],
            "tolerances": [
                (
                    k,
                    "sigma" if t.kind == "normal" else "uniform +-",
                    _fmt(t.scale),
                    "deg" if k in ("cam_phase", "slot_angle") else "mm",
                )
                for k, t in scene.tolerances.items()
            ],
        }
    alloc = manifest.get("allocation")
    if alloc:
        ctx["allocation"] = {
            "percentile": _fmt(scene.montecarlo.get("percentile")),
            "rows": [
                {
                    "kind": r["kind"],
                    "meaning": r.get("meaning", "uniform half-width"),
                    "joint": _fmt(r["tolerance"]),
                    "alone": _fmt(r.get("tolerance_alone")),
                    "unit": r["unit"],
                }
                for r in alloc
            ],
        }
    inter = manifest.get("interference")
    if inter:
        ctx["interference"] = {
            "ok": inter["ok"],
            "positions": inter["positions"],
            "violations": inter["violations"],
            "rows": [
                (
                    p,
                    _fmt(inter["max_volume_mm3"][p], 3),
                    _fmt(inter["allowance"][p]["volume_mm3"], 3),
                    _fmt(inter["max_gap_mm"][p], 3),
                    _fmt(inter["allowance"][p]["gap_mm"], 3),
                )
                for p in inter["max_volume_mm3"]
            ],
        }
    sweeps = manifest.get("sweeps")
    if sweeps:
        rows = []
        for n, s in sweeps.items():
            rng = s["range"]
            swept = rng["swept"]
            clip = "; ".join(
                f"{side} end at {_fmt(swept[i])} mm: {rng[f'clipped_{side}']}"
                for side, i in (("low", 0), ("high", 1))
                if swept and rng[f"clipped_{side}"]
            )
            rows.append(
                {
                    "name": n.replace("_", " "),
                    "requested": f"{_fmt(rng['requested'][0])} .. {_fmt(rng['requested'][1])}",
                    "source": rng["source"],
                    "solved": f"{s['solved']} / {s['points']}",
                    "clipped": clip or ("no valid value" if swept is None else "-"),
                }
            )
        ctx["sweeps"] = rows
    insp = manifest.get("inspection")
    if insp:
        ctx["inspection"] = _flat(insp)
    meas = manifest.get("measured_profile")
    if meas:
        ctx["measured"] = _flat(meas)
    mod = manifest.get("modification")
    if mod:
        ctx["modification"] = _flat(mod)
    if manifest.get("assembly"):
        ctx["assembly"] = assembly_rows(Path(out) / "assembly.json")
    if manifest.get("sizing"):
        from corr_cad.export.sizing_io import report_table

        ctx["sizing"] = report_table(manifest["sizing"], Path(out) / "pareto.csv")
    ctx["files"] = [{"name": n, "accuracy": _accuracy_of(n, manifest)} for n in sorted(files)]
    ctx["plots"] = [
        {
            "name": n,
            "caption": _PLOT_CAPTIONS.get(n)
            or (
                f"Sweep of the {n[6:-4].replace('_', ' ')}"
                if n.startswith("sweep_")
                else n.removesuffix(".png").replace("_", " ")
            ),
            "data": base64.b64encode((Path(out) / n).read_bytes()).decode("ascii"),
        }
        for n in sorted(files)
        if n.endswith(".png")
    ]
    return ctx


def _flat(d: dict, prefix: str = "") -> list[tuple[str, str]]:
    """Scalars of a nested dict as (dotted key, formatted value) rows."""
    rows = []
    for k, v in d.items():
        key = f"{prefix}{k}"
        if isinstance(v, dict):
            rows.extend(_flat(v, key + "."))
        elif isinstance(v, (list, tuple)):
            if len(v) <= 6 and all(not isinstance(x, (dict, list)) for x in v):
                rows.append((key, ", ".join(_fmt(x) for x in v)))
        else:
            rows.append((key, _fmt(v)))
    return rows


def _version() -> str:
    from corr_cad._version import __version__

    return __version__


def render_report(context: dict) -> str:
    """The HTML text, rendered from the template shipped in the package."""
    from corr_cad.export.html import render_template

    return render_template("report.html.j2", context)


def write_report(scene, manifest: dict, forces, files: list[str], out: Path) -> Path:
    """Write ``report.html`` into ``out``; returns its path."""
    html = render_report(report_context(scene, manifest, forces, files, out))
    path = Path(out) / "report.html"
    with writing(path) as tmp:
        tmp.write_text(html, encoding="utf-8")
    return path
