"""Pipeline pieces of the profile modification (issue 20): the manifest record and
``modification.png``. The modified profile itself reaches every stage through
:func:`corr_cad.run.context.modified_curve` and
:func:`corr_cad.run.context.scene_errors`.
"""

from __future__ import annotations

import math

import numpy as np

from corr_cad.run.context import RunContext

__all__ = [
    "modification_manifest",
    "modification_png",
    "modification_design",
    "modified_toml",
    "PLOT_POINTS",
]

#: Roll angles of the plot and the manifest's summary, over one tooth space.
PLOT_POINTS = 721


def _curves(ctx: RunContext) -> tuple[np.ndarray, dict]:
    from corr_cad.geometry.modification import family_clearances

    psi = np.linspace(-math.pi, math.pi, PLOT_POINTS)
    return psi, family_clearances(ctx.scene.design, ctx.scene.modification, psi)


def modification_manifest(ctx: RunContext) -> dict:
    """What ``manifest.json`` records of ``[modification]``."""
    psi, curves = _curves(ctx)
    tot = curves["total"]
    at = {f"{a:g}": float(np.interp(math.radians(a), psi, tot)) for a in (0.0, 45.0, 90.0, 135.0)}
    return {
        **ctx.scene.modification.as_dict(),
        "families": list(ctx.scene.modification.families()),
        "flank_clearance_mm": {
            "definition": "exact distance from the nominal roller centre to the modified working "
            "profile, less r, along the tooth space (psi 0 tooth space, 180 tooth tip)",
            "min": float(tot.min()),
            "max": float(tot.max()),
            "at_psi_deg": at,
        },
        "outputs": "every output follows the modified profile; the conjugate profile is on "
        "layer CONJUGATE_PROFILE of inner_gear.dxf",
    }


def modification_png(ctx: RunContext) -> None:
    from corr_cad.export.modification_plots import modification_png as plot

    psi, curves = _curves(ctx)
    p = plot(np.degrees(psi), curves, ctx.out / "modification.png", ctx.scene.design)
    ctx.files.append(p.name)


def modified_toml(
    scene, equidistant_mm: float, shift_mm: float, normal_table: str | None = None
) -> str:
    """The user's scene (its parsed values) with the chosen ``[modification]`` written in.

    Paths become absolute (the file lives in the output folder); the design
    search and the ``modification`` format are left out, so the file runs
    the shop files of the chosen design.
    """
    import json

    from corr_cad.run.scene_text import _toml_value

    def value(section: str, key: str, v) -> str:
        if section == "tolerances" and isinstance(v, dict):
            return f"{{ {v['kind']} = {v['scale']!r} }}"
        if isinstance(v, str):
            if key == "measured_profile" and scene.measured_profile is not None:
                v = str(scene.measured_profile.resolve())
            return json.dumps(v)
        return _toml_value(v)

    lines = [
        f"# {scene.name} with the modification corr-cad designed ([modification.design]);",
        "# run it for the shop files: corr-cad run modified.toml",
    ]
    for section, vals in scene.source.items():
        if section in ("modification", "modification.design") or not vals:
            continue
        if section == "export":
            vals = {**vals, "formats": [f for f in vals["formats"] if f != "modification"]}
            vals["formats"] = vals["formats"] or ["dxf", "png"]
        lines.append(f"\n[{section}]")
        lines += [f"{k} = {value(section, k, v)}" for k, v in vals.items()]
    lines += [
        "\n[modification]",
        f"equidistant_mm = {equidistant_mm!r}",
        f"shift_mm = {shift_mm!r}",
    ]
    if normal_table is not None:  # beside modified.toml in the output folder
        lines += [f"normal_table = {json.dumps(normal_table)}"]
    return "\n".join(lines) + "\n"


def modification_design(ctx: RunContext) -> None:
    """Format ``modification``: search ``[modification.design]``; modification.json,
    modification_tradeoff.png and modified.toml; exit 1 when the targets are unmet."""
    from corr_cad.export.files import write_json, writing
    from corr_cad.export.modification_plots import tradeoff_png
    from corr_cad.run.context import psi_contact_limit, raw_errors
    from corr_cad.run.progress import Progress
    from corr_cad.run.stages_datasheet import datasheet_spec, rated_torque_Nmm
    from corr_cad.tolerance.modification_design import design_modification

    s = ctx.scene
    md = s.modification_design
    steps = md["steps"]
    n = {"equidistant": steps, "equidistant+shift": steps**2, "free": steps**4}[md["family"]]
    bar = Progress(n, "      modification design", "candidates")

    def tick(done: int, total: int) -> None:
        bar.update(done - bar.done)

    res = design_modification(
        s.design,
        s.tolerances,
        family=md["family"],
        objective=md["objective"],
        target_backlash_arcmin=md["target_backlash_arcmin"],
        max_binding_probability=md["max_binding_probability"],
        crank_moment=rated_torque_Nmm(s) / s.design.roller_count,
        equidistant_mm=(*md["equidistant_range_mm"], steps),
        shift_mm=(*md["shift_range_mm"], steps),
        backlash_percentile=md["backlash_percentile"],
        samples=md["samples"],
        seed=md["seed"],
        positions=md["positions"],
        force_candidates=md["force_candidates"],
        base_errors=raw_errors(ctx),
        load_share=s.solver.load_share,
        psi_contact_limit=psi_contact_limit(ctx),
        executor=ctx.executor,
        progress=tick,
        datasheet_spec=datasheet_spec(s) if md["objective"] == "transmission_error" else None,
    )
    bar.close()
    write_json(ctx.out / "modification.json", res)
    tradeoff_png(res, ctx.out / "modification_tradeoff.png", s.design)
    c = res["chosen"]
    table = None
    if "normal_mm" in c:  # the free family: its curve as a normal table beside modified.toml
        table = "modified_normal.csv"
        pairs = zip(c["normal_psi_deg"], c["normal_mm"], strict=True)
        rows = "\n".join(f"{p!r},{v!r}" for p, v in pairs)
        with writing(ctx.out / table) as tmp:
            tmp.write_text("psi_deg,normal_mm\n" + rows + "\n")
        ctx.files.append(table)
    with writing(ctx.out / "modified.toml") as tmp:
        tmp.write_text(modified_toml(s, c["equidistant_mm"], c["shift_mm"], table))
    ctx.files.extend(["modification.json", "modification_tradeoff.png", "modified.toml"])
    key = f"p{int(md['backlash_percentile'])}"
    rec = {
        "met": res["met"],
        "equidistant_mm": c["equidistant_mm"],
        "shift_mm": c["shift_mm"],
        **({"normal_mm": c["normal_mm"]} if "normal_mm" in c else {}),
        f"backlash_{key}_arcmin": c["backlash_arcmin"][key]["value"],
        "binding_probability": c["binding_probability"]["value"],
    }
    if not res["met"]:
        rec["failed"] = [f"modification design: targets unmet: {res['failed']}"]
    ctx.manifest["modification_design"] = rec
    curve = f", normal {c['normal_mm']} mm at psi 0/60/120/180" if "normal_mm" in c else ""
    ctx.progress(
        f"      modification: equidistant {c['equidistant_mm']:.4g} mm, shift "
        f"{c['shift_mm']:.4g} mm{curve}; "
        f"backlash {key} {rec[f'backlash_{key}_arcmin']:.4g} arcmin, "
        f"binding probability {rec['binding_probability']:.3g}"
        + ("" if res["met"] else f"; TARGETS UNMET: {res['failed']}")
    )
