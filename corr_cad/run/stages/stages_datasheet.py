"""Pipeline stages of the datasheet: the figures (``datasheet``) and their files.

Registered in :data:`corr_cad.run.stages.stages.STAGES`. The ``datasheet`` stage
computes the windup curve and the transmission error
(:func:`corr_cad.mechanics.datasheet.datasheet`); ``datasheet_files`` writes
``datasheet.json``, ``windup.csv``, ``transmission_error.csv``,
``hysteresis.png`` and ``transmission_error.png``. The checks on datasheet
figures read the first, without the files.
"""

from __future__ import annotations

from dataclasses import fields

import numpy as np

from corr_cad.geometry.deviations import ManufacturingErrors
from corr_cad.mechanics.datasheet import DatasheetSpec, datasheet
from corr_cad.mechanics.row.windup import ARCMIN_PER_RAD, NMM_PER_NM
from corr_cad.run.stages.context import (
    RunContext,
    elastic_bodies,
    modified_curve,
    psi_contact_limit,
    scene_errors,
    scene_errors_b,
)
from corr_cad.run.stages.stages_whole_drive import whole_drive

__all__ = [
    "datasheet_spec",
    "rated_torque_Nmm",
    "datasheet_errors",
    "ring_description",
    "ring_label",
]


def rated_torque_Nmm(scene) -> float:
    """T_R in N*mm: ``[datasheet] rated_torque_Nm``, or ``(z + 1) [load] input_torque``.

    The crank moment ``M0`` is N*mm; without friction the output torque is
    ``(z + 1) M0`` (virtual work, ratio ``z + 1``).
    """
    given = scene.datasheet.get("rated_torque_Nm")
    if given is not None:
        return float(given) * NMM_PER_NM
    return scene.design.roller_count * abs(float(scene.load.input_torque))


def datasheet_spec(scene) -> DatasheetSpec:
    """The :class:`DatasheetSpec` of a scene's ``[datasheet]`` (its defaults where not set)."""
    ds = scene.datasheet
    return DatasheetSpec(
        rated_torque=rated_torque_Nmm(scene),
        lost_motion_band=ds.get("lost_motion_band", 0.03),
        rigidity_range=tuple(ds.get("rigidity_range", (0.5, 1.0))),
        transmission_error_torque_band=ds.get("transmission_error_torque_band", 0.03),
        positions_per_mesh=ds.get("positions_per_mesh", 16),
        transmission_error_positions_per_turn=ds.get("transmission_error_positions_per_turn", 360),
        allowable_contact_pressure=ds.get("allowable_contact_pressure_MPa"),
        series_rigidity_Nm_per_arcmin=ds.get("series_rigidity_Nm_per_arcmin"),
    )


def datasheet_errors(ctx: RunContext) -> ManufacturingErrors:
    """The errors the datasheet describes.

    With ``[errors] measured_profile`` it is the datasheet of the measured
    ring with nominal other parts: the registered profile deviation alone
    (the scene's other ``[errors]`` still reach the forces and the Monte
    Carlo, not the datasheet). Without one, the scene's errors.
    """
    reg = ctx.results.registration
    if reg is None:
        return scene_errors(ctx)
    measured = ManufacturingErrors(profile_deviation=reg.deviation)
    if modified_curve(ctx) is None:
        return measured
    # The deviation is registered against the modified nominal: add the designed clearance.
    from corr_cad.geometry.modification import with_modification

    scene_errors(ctx)
    return with_modification(measured, ctx.results.modification_gap)


def _set_errors(errors: ManufacturingErrors) -> list[str]:
    """Names of the error fields that differ from the nominal: a zero is no error (the
    drive's ``slot_clearance`` is 0.0 where the scene sets none, the nominal ``None``)."""
    nominal = ManufacturingErrors()

    def zero(v) -> bool:
        return (isinstance(v, tuple) and not any(v)) or (isinstance(v, (int, float)) and v == 0)

    return [
        f.name
        for f in fields(errors)
        if getattr(errors, f.name) is not None
        and getattr(errors, f.name) != getattr(nominal, f.name)
        and not zero(getattr(errors, f.name))
    ]


def ring_description(ctx: RunContext) -> dict:
    """Which ring (and which other parts) the datasheet describes: ``datasheet.json["ring"]``;
    with ``[errors.row_b] measured_profile`` also ring B's (``"ring_b"``)."""
    out = _ring_a(ctx)
    reg = ctx.results.registration_b
    if reg is not None:
        m = ctx.manifest.get("measured_profile_b", {})
        out["ring_b"] = {
            "profile": "measured",
            "file": m.get("source"),
            "sha256": m.get("sha256"),
            "registration": reg.as_dict(),
            "other_parts": "nominal",
        }
    return out


def _ring_a(ctx: RunContext) -> dict:
    reg = ctx.results.registration
    if reg is None:
        errs = _set_errors(ctx.scene.errors)
        out = {
            "profile": "nominal" if "profile_deviation" not in errs else "nominal with deviation",
            "errors_applied": errs,
            "other_parts": "as [errors] gives them" if errs else "nominal",
        }
        label = ring_label(ctx.scene)
        if label.startswith("modified"):  # the designed clearance is in the windup
            out["profile"] = out["profile"].replace("nominal", "modified", 1)
            out["modification"] = label.removeprefix("modified ring, ")
        return out
    m = ctx.manifest.get("measured_profile", {})
    ignored = [k for k in _set_errors(ctx.scene.errors) if k != "profile_deviation"]
    return {
        "profile": "measured",
        "file": m.get("source"),
        "sha256": m.get("sha256"),
        "registration": reg.as_dict(),
        "other_parts": "nominal",
        "errors_not_applied": ignored,
    }


def _datasheet(ctx: RunContext) -> None:
    s = ctx.scene
    ctx.results.datasheet = datasheet(
        s.design,
        datasheet_spec(s),
        errors=datasheet_errors(ctx),
        load_share=s.solver.load_share,
        contact_model=s.solver.contact_model,
        variants=s.solver.variants,
        psi_contact_limit=psi_contact_limit(ctx),
        drive=drive_settings(ctx),
    )
    budget = ctx.results.datasheet.compliance_budget
    if budget is not None and s.life:
        from corr_cad.mechanics.compliance_budget import with_life_hours

        with_life_hours(budget, s.life["rated_speed_rpm"], s.design.roller_count)
    if s.friction:
        ctx.results.friction = _friction_figures(ctx)
    if s.losses.get("lubrication"):  # load-independent losses, temperature, a_ISO
        from corr_cad.run.stages.stages_losses import losses_figures

        mounted = s.friction["cam_mounting"] == "bearing"
        life = friction_spec(s)[1] if mounted else None
        ctx.results.losses = losses_figures(ctx, ctx.results.friction, life)


#: ``datasheet.json`` ``friction["forces"]`` under ``model = "drive"``.
DRIVE_SOURCE = (
    "drive: both rows solved together, each at its own crank angles; each cam's bearing "
    "rated on the drive's bearing_load of that cam (forces.csv), each row's raceways on "
    "its own forces; the hysteresis on the drive's locked-input bench"
)


def friction_spec(scene):
    """The :class:`Friction` and :class:`LifeSpec` of ``[friction]`` and ``[life]``.

    The needle bearing sits in the cam's bore: pitch diameter ``2 cam_bore_radius
    - needle_diameter``; the catalogue formula's ``d`` defaults to the raceway under
    the needles, ``2 cam_bore_radius - 2 needle_diameter``. The needles are
    ``[bearings.eccentric]``'s where the drive floats the cams on it, else
    ``[life]``'s (the scene refuses both given with different values).
    """
    from corr_cad.mechanics.losses.friction import Friction

    fr, d = scene.friction, scene.design
    life = _life_spec(scene, scene.bearing)
    bore = 2.0 * d.cam_bore_radius
    friction = Friction(
        mu_cam=fr["mu_cam"],
        mu_slot=fr["mu_slot"],
        mu_ring=fr["mu_ring"],
        mu_bearing=fr["mu_bearing"],
        mounting=fr["cam_mounting"],
        bearing_diameter=fr["bearing_bore_mm"]
        if fr["bearing_bore_mm"] is not None
        else bore - 2.0 * life.needle_diameter,
    )
    return friction, life


def _life_spec(scene, bearing):
    """``[life]``'s rated point with a bearing's needles (``[life]``'s own without one)."""
    from corr_cad.mechanics.life import LifeSpec

    lf = scene.life
    if bearing is not None:
        z, dw, lw = bearing.needles, bearing.needle_diameter, bearing.needle_length
    else:
        z, dw, lw = lf["needles"], lf["needle_diameter"], lf["needle_length"]
    return LifeSpec(
        rated_life_h=lf["rated_life_h"],
        rated_speed_rpm=lf["rated_speed_rpm"],
        dynamic_load_rating=lf["dynamic_load_rating_N"],
        needles=z,
        needle_diameter=dw,
        needle_length=lw,
        pitch_diameter=2.0 * scene.design.cam_bore_radius - dw,
    )


def _friction_figures(ctx: RunContext):
    from corr_cad.errors import SceneError
    from corr_cad.mechanics.losses.efficiency import (
        LifeNotBracketed,
        friction_figures,
        rows_from_drive,
    )
    from corr_cad.mechanics.losses.hysteresis import hysteresis_figures
    from corr_cad.mechanics.row.windup import Windup, mesh_period_rad, result_period_rad

    s = ctx.scene
    ds = ctx.results.datasheet
    friction, life = friction_spec(s)
    errors = datasheet_errors(ctx)
    # The datasheet's span (mesh period, tooth pitch or revolution) at [friction]'s density.
    period = result_period_rad(s.design, errors, s.solver.variants)
    if s.solver.drive:
        period = max(
            period, result_period_rad(s.design, datasheet_errors_b(ctx), s.solver.variants)
        )
    n = int(round(period / mesh_period_rad(s.design))) * s.friction["positions_per_mesh"]
    x = period * np.arange(n) / n

    def row_at(xs: np.ndarray) -> Windup:
        return Windup(
            s.design,
            xs,
            errors=errors,
            load_share=s.solver.load_share,
            variants=s.solver.variants,
            psi_contact_limit=psi_contact_limit(ctx),
        )

    def bench_at(xs: np.ndarray):
        """The locked-input bench at the output angles ``xs``: the paper's row or the drive."""
        if not s.solver.drive:
            return row_at(xs)
        from corr_cad.mechanics.drive.drive_windup import DriveWindup

        return DriveWindup(
            s.design,
            xs,
            errors=errors,
            contact_model=s.solver.contact_model,
            variants=s.solver.variants,
            psi_contact_limit=psi_contact_limit(ctx),
            **drive_settings(ctx),
        )

    w = row_at(x)
    drive = {}
    if s.solver.drive:
        dw = bench_at(x)
        b = s.bearing_b if s.bearing_b is not None else s.bearing
        drive = {
            "rows_at": lambda T: rows_from_drive(s.design, dw.forces(T)),
            "life_b": _life_spec(s, b) if s.life else None,
        }
    try:
        ff = friction_figures(
            s.design,
            w,
            ds.spec.rated_torque,
            friction,
            s.friction["efficiency_torques"],
            s.friction["efficiency_speeds_rpm"],
            life,
            **drive,
        )
    except LifeNotBracketed as exc:  # the target life the scene set, named with its keys
        lf, c = s.life, s.life["dynamic_load_rating_N"]
        rating = "" if c is None else f" with dynamic_load_rating_N = {c:g}"
        raise SceneError(
            f"[life] rated_life_h = {lf['rated_life_h']:g} at rated_speed_rpm = "
            f"{lf['rated_speed_rpm']:g}{rating}: {exc}; e.g. rated_life_h = 6000, "
            "rated_speed_rpm = 15"
            + ("" if c is None else ", dynamic_load_rating_N = 65000 (or leave it out)")
        ) from None
    bench = w
    if s.solver.drive:
        bench = dw
        ff.source = DRIVE_SOURCE
    ff.hysteresis = hysteresis_figures(s.design, bench, ds.spec.rated_torque, friction)
    # The loop at the widest position alone (each position's solve is its own).
    j = int(np.argmax(ff.hysteresis["width_at_rated"]))
    ff.hysteresis["loop"] = _loop(s.design, bench_at(x[j : j + 1]), ds, friction)
    fr = s.friction
    if fr["housing_area_m2"] is not None:
        ff.thermal = (
            fr["housing_area_m2"],
            fr["heat_transfer_W_per_m2K"],
            fr["max_temperature_rise_K"],
        )
    return ff


def _loop(design, bench, ds, friction) -> dict:
    """The hysteresis loop on a one-position bench (the widest loop at +-T_R), rad and N*mm."""
    from corr_cad.mechanics.losses.hysteresis import hysteresis_loop
    from corr_cad.mechanics.row.windup import series_rigidity_Nmm_per_rad

    T = np.asarray(ds.torques, dtype=float)
    branches = hysteresis_loop(design, bench, T, ds.spec.rated_torque, friction)
    k = series_rigidity_Nmm_per_rad(ds.spec.series_rigidity_Nm_per_arcmin)
    theta = np.array([bench.contact_theta(float(t))[0] for t in T]) + T / k
    return {
        "torques": T,
        "output_angle": float(bench.output_angles[0]),
        "frictionless": theta,
        "rising": theta - branches["rising"][:, 0],
        "falling": theta + branches["falling"][:, 0],
    }


def drive_settings(ctx: RunContext) -> dict | None:
    """The datasheet's ``drive`` argument under ``model = "drive"`` (None: the paper's row)."""
    s = ctx.scene
    if not s.solver.drive:
        return None
    out = {
        "errors_b": datasheet_errors_b(ctx),
        "bearing": s.bearing,
        "bearing_b": s.bearing_b,
        **elastic_bodies(ctx),
    }
    if getattr(s, "crank", None) is not None:  # [crankshaft] / [bearings.crank]
        out["crank"] = s.crank
    return out


def datasheet_errors_b(ctx: RunContext) -> ManufacturingErrors | None:
    """Row B's errors in the datasheet: with ``[errors.row_b] measured_profile`` the measured
    ring B with row B's other parts nominal (as :func:`datasheet_errors` for row A)."""
    reg = ctx.results.registration_b
    if reg is None:
        return scene_errors_b(ctx)
    measured = ManufacturingErrors(profile_deviation=reg.deviation)
    if modified_curve(ctx) is None:
        return measured
    from corr_cad.geometry.modification import with_modification

    scene_errors_b(ctx)  # makes the designed clearance once
    return with_modification(measured, ctx.results.modification_gap)


def add_as_built(ctx: RunContext) -> None:
    """After the Monte Carlo: the as-built figures into ``datasheet.json`` and its page
    (when the datasheet ran first; otherwise the datasheet stage takes them itself)."""
    import json

    from corr_cad.export.datasheet_sheet import as_built
    from corr_cad.export.files import write_json

    extra = as_built(ctx.manifest.get("montecarlo"))
    path = ctx.out / "datasheet.json"
    if not extra or "datasheet.json" not in ctx.files or not path.exists():
        return
    sheet = {**json.loads(path.read_text(encoding="utf-8")), **extra}
    write_json(path, sheet)
    ctx.manifest["datasheet"].update(extra)
    _datasheet_html(ctx, sheet)


def _meta(ctx: RunContext) -> dict:
    s = ctx.scene
    given = s.datasheet.get("rated_torque_Nm") is not None
    return {
        **whole_drive(ctx),
        "ring": ring_description(ctx),
        "rated_torque_source": (
            "[datasheet] rated_torque_Nm" if given else "(z + 1) * [load] input_torque"
        ),
        **_model_meta(s, ctx.results.bodies),
        "variants": list(s.solver.variants),
        "units": {"torque": "N*m", "windup": "arcmin", "transmission_error": "arcsec"},
        "conventions": {
            "windup": "output rotation under output torque T, input (crank) locked, ring "
            "fixed, from the zero-load kinematic position of the nominal design; "
            "positive with T",
            "output_angle": "frame angle over one output revolution, ring fixed; 0 is crank "
            "angle 0",
            "forward": "the input drives the output in the + direction against the load, "
            "i.e. output torque -T_TE",
            "catalogue_figure": "the maximum over the positions for backlash, lost motion and "
            "transmission error; the minimum for rigidities",
        },
    }


def _model_meta(s, tables=None) -> dict:
    """The model, contact law and bearing as ``datasheet.json`` states them.

    The paper's model with its contact law keeps the two keys it always had.
    """
    if not s.solver.drive and s.solver.contact_law == "paper":
        return {"load_share": s.solver.load_share, "contact_model": "nonlinear"}
    from corr_cad.run.stages.stages_drive import model_description

    out = model_description(s, tables)
    if not s.solver.drive:
        out["load_share"] = s.solver.load_share
        out.pop("bearing", None)
    return out


def _datasheet_files(ctx: RunContext) -> None:
    from corr_cad.export.datasheet_sheet import as_built
    from corr_cad.run.stages.plot_workers import wait

    ds = ctx.results.datasheet
    meta = _meta(ctx)
    whole = {"whole_drive": meta["whole_drive"]} if "whole_drive" in meta else {}
    meta.update(as_built(ctx.manifest.get("montecarlo")))  # the Monte Carlo ran first
    ff = ctx.results.friction
    loop = None
    if ff is not None and ff.hysteresis is not None:
        loop = ff.hysteresis["loop"]
    drawings = _datasheet_drawings(ctx, whole)
    try:  # while the figures are drawn: the other files
        figs = _datasheet_tables(ctx, meta, whole, loop)
    finally:
        wait(drawings)  # datasheet.html embeds them
    _datasheet_html(ctx, {**meta, **ds.figures(), **figs})
    if ctx.scene.assembly:
        _assembly(ctx)


def _datasheet_drawings(ctx: RunContext, whole: dict) -> list:
    """The datasheet's PNGs, handed to the plot workers where the CLI started them
    (:mod:`corr_cad.run.stages.plot_workers`), else drawn here, now."""
    from corr_cad.run.stages.plot_workers import draw

    ds, s, out = ctx.results.datasheet, ctx.scene, ctx.out
    ring = ring_description(ctx)
    note = (
        f"measured ring {ring['file']}, other parts nominal"
        if ring["profile"] == "measured"
        else ""
    )
    ff = ctx.results.friction
    width = loop = None
    if ff is not None and ff.hysteresis is not None:
        width = float(np.max(ff.hysteresis["width_at_rated"]) * ARCMIN_PER_RAD)
        loop = ff.hysteresis["loop"]
    te_note = note
    if ring["profile"] == "nominal" and not ring.get("errors_applied"):
        te_note = (
            "the exact nominal geometry, no manufacturing error: a perfect drive's "
            "transmission error, not an as-built one's"
        )
    plots, pool = "corr_cad.export.datasheet_plots", ctx.plotter
    elastic = s.solver.bodies == "elastic"
    hysteresis = (ds, out / "hysteresis.png", s.design, note, width, loop)
    drawings = [
        draw(pool, plots, "hysteresis_png", *hysteresis, whole.get("whole_drive"), elastic),
        draw(
            pool,
            plots,
            "transmission_error_png",
            ds,
            out / "transmission_error.png",
            s.design,
            te_note,
        ),
    ]
    if ds.compliance_budget is not None:  # with [crankshaft] / [bearings.crank]
        budget = (ds.compliance_budget, out / "compliance.png", s.design)
        drawings.append(draw(pool, "corr_cad.export.compliance_plot", "compliance_png", *budget))
    if ff is not None:
        efficiency = (ff, out / "efficiency.png", note)
        drawings.append(draw(pool, "corr_cad.export.friction_io", "efficiency_png", *efficiency))
    return drawings


def _datasheet_tables(ctx: RunContext, meta: dict, whole: dict, loop) -> dict:
    """The datasheet's files but its PNGs and page, and the manifest's section; returns
    the friction and losses figures."""
    from corr_cad.export.datasheet_io import write_datasheet_files

    ds, s = ctx.results.datasheet, ctx.scene
    names = write_datasheet_files(ds, ctx.out, meta)
    ctx.files.extend([*names, "hysteresis.png", "transmission_error.png", "datasheet.html"])
    if ds.compliance_budget is not None:
        ctx.files.append("compliance.png")
    ctx.manifest["datasheet"] = {**ds.figures(), "ring": ring_description(ctx)}
    if whole:  # the console's block gives the whole drive's play beside the second stage's
        ctx.manifest["datasheet"].update(first_stage=meta["first_stage"], **whole)
    if "as_built" in meta:
        ctx.manifest["datasheet"]["as_built"] = meta["as_built"]
    ff = ctx.results.friction
    figs = ff.figures() if ff is not None else {}
    if ctx.results.losses is not None:
        from corr_cad.run.stages.stages_losses import public_figures, write_losses_files

        figs.update(public_figures(ctx.results.losses))
        ctx.files.extend(write_losses_files(ctx.results.losses, ctx.out, s.name))
    if ff is not None:
        from corr_cad.export.files import write_json
        from corr_cad.export.friction_io import write_friction_files

        write_json(ctx.out / "datasheet.json", {**meta, **ds.figures(), **figs})
        ctx.files.extend(write_friction_files(ff, ctx.out))
        if loop is not None:
            from corr_cad.export.friction_io import write_hysteresis_csv

            ctx.files.append(write_hysteresis_csv(loop, ctx.out))
        ctx.files.append("efficiency.png")
        ctx.manifest["datasheet"].update(figs)
    if s.solver.drive or s.solver.contact_law != "paper":
        ctx.manifest["datasheet"].update(_model_meta(s, ctx.results.bodies))
    return figs


def _datasheet_html(ctx: RunContext, sheet: dict) -> None:
    """``datasheet.html`` from the dictionary ``datasheet.json`` holds, beside the PNGs."""
    from corr_cad._version import __version__
    from corr_cad.export.datasheet_html import catalogue_number, write_datasheet_html

    mod = ctx.scene.modification
    text = ""
    if mod is not None and not mod.is_zero:
        parts = [
            f"{name} {catalogue_number(v)} mm"
            for name, v in (("equidistant", mod.equidistant_mm), ("shift", mod.shift_mm))
            if v
        ]
        if mod.normal_table is not None:
            parts.append("normal table")
        text = ", ".join(parts) + " (+ = clearance)"
    write_datasheet_html(sheet, ctx.scene.design, ctx.out, ctx.scene.name, text, __version__)


def ring_label(scene) -> str:
    """Which ring the selective assembly fits: measured, modified (its amounts) or nominal."""
    if scene.measured_profile is not None:
        return "measured ring"
    mod = scene.modification
    if mod is not None and not mod.is_zero:
        from corr_cad.geometry.modification import amounts_text

        return f"modified ring, {amounts_text(mod)}"
    return "nominal ring"


def _assembly(ctx: RunContext) -> None:
    """``[assembly]``: the roller class to fit, with each class's datasheet (assembly.json)."""
    from corr_cad.export.files import write_json
    from corr_cad.tolerance.assembly import selective_assembly

    s = ctx.scene
    ring = ring_label(s)
    ctx.progress(
        f"      selective assembly ({ring}): {len(s.assembly['roller_classes_um'])} classes"
    )
    res = selective_assembly(
        s.design,
        datasheet_spec(s),
        datasheet_errors(ctx),
        s.assembly["roller_classes_um"],
        s.assembly["target_backlash_arcmin"],
        load_share=s.solver.load_share,
        variants=s.solver.variants,
        psi_contact_limit=psi_contact_limit(ctx),
        progress=ctx.progress,
        contact_model=s.solver.contact_model,
        drive=drive_settings(ctx),
    )
    res = {"ring": ring, **res}
    write_json(ctx.out / "assembly.json", res)
    from corr_cad.run.stages.plot_workers import draw

    plots = "corr_cad.export.datasheet_plots"  # by a plot worker where the CLI started one
    draw(ctx.plotter, plots, "assembly_png", res, ctx.out / "assembly.png", s.design).result()
    ctx.files.extend(["assembly.json", "assembly.png"])
    ctx.manifest["assembly"] = {
        k: res[k] for k in ("ring", "target_backlash_arcmin", "chosen_class_um", "reason")
    }
    chosen = [r for r in res["classes"] if r["class_um"] == res["chosen_class_um"]]
    if chosen:
        ctx.manifest["assembly"]["chosen_backlash_arcmin"] = chosen[0]["backlash_arcmin"]["max"]
    if res["chosen_class_um"] is None:
        ctx.manifest["assembly"]["failed"] = [f"selective assembly failed: {res['reason']}"]
