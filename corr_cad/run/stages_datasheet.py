"""Pipeline stages of the datasheet: the figures (``datasheet``) and their files.

Registered in :data:`corr_cad.run.stages.STAGES`. The ``datasheet`` stage
computes the windup curve and the transmission error
(:func:`corr_cad.mechanics.datasheet.datasheet`); ``datasheet_files`` writes
``datasheet.json``, ``windup.csv``, ``transmission_error.csv``,
``hysteresis.png`` and ``transmission_error.png``. The checks on datasheet
figures read the first, without the files.
"""

from __future__ import annotations

import math
from dataclasses import fields

from corr_cad.geometry.deviations import ManufacturingErrors
from corr_cad.mechanics.datasheet import DatasheetSpec, datasheet
from corr_cad.mechanics.windup import NMM_PER_NM
from corr_cad.run.context import RunContext, modified_curve, psi_contact_limit, scene_errors

__all__ = ["datasheet_spec", "rated_torque_Nmm", "datasheet_errors", "ring_description"]


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
    """Names of the error fields that differ from the nominal."""
    nominal = ManufacturingErrors()
    return [
        f.name
        for f in fields(errors)
        if getattr(errors, f.name) is not None
        and getattr(errors, f.name) != getattr(nominal, f.name)
        and not (isinstance(getattr(errors, f.name), tuple) and not any(getattr(errors, f.name)))
    ]


def ring_description(ctx: RunContext) -> dict:
    """Which ring (and which other parts) the datasheet describes: ``datasheet.json["ring"]``."""
    reg = ctx.results.registration
    if reg is None:
        errs = _set_errors(ctx.scene.errors)
        return {
            "profile": "nominal" if "profile_deviation" not in errs else "nominal with deviation",
            "errors_applied": errs,
            "other_parts": "as [errors] gives them" if errs else "nominal",
        }
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
        variants=s.solver.variants,
        psi_contact_limit=psi_contact_limit(ctx),
    )


def _whole_drive(ctx: RunContext) -> dict:
    """With ``[first_stage]``: the whole drive's figures and the first stage's share."""
    s, d = ctx.scene, ctx.manifest.get("drive")
    if s.first_stage is None or d is None:
        return {}
    crank = math.degrees(s.first_stage.crank_backlash_rad) * 60.0
    return {
        "total_ratio": d["total_ratio"],
        "input_inertia_kg_m2": d["input_inertia_kg_m2"],
        "mass_kg": d["mass_kg"],
        "first_stage": {
            "backlash_at_crank_arcmin": crank,
            "lost_motion_arcmin": crank / s.design.roller_count,
            "transmission_error_arcsec": 0.0,
            "definition": "the first stage's backlash (pinion held) reflected to the output, "
            "backlash_1 / (z + 1); exact involutes are conjugate: no transmission error of "
            "their own; both add to the second stage's figures above",
        },
    }


def _meta(ctx: RunContext) -> dict:
    s = ctx.scene
    given = s.datasheet.get("rated_torque_Nm") is not None
    return {
        **_whole_drive(ctx),
        "ring": ring_description(ctx),
        "rated_torque_source": (
            "[datasheet] rated_torque_Nm" if given else "(z + 1) * [load] input_torque"
        ),
        "load_share": s.solver.load_share,
        "contact_model": "nonlinear",
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


def _datasheet_files(ctx: RunContext) -> None:
    from corr_cad.export.datasheet_io import write_datasheet_files
    from corr_cad.export.datasheet_plots import hysteresis_png, transmission_error_png

    ds = ctx.results.datasheet
    s = ctx.scene
    names = write_datasheet_files(ds, ctx.out, _meta(ctx))
    ring = ring_description(ctx)
    note = (
        f"measured ring {ring['file']}, other parts nominal"
        if ring["profile"] == "measured"
        else ""
    )
    hysteresis_png(ds, ctx.out / "hysteresis.png", s.design, note)
    transmission_error_png(ds, ctx.out / "transmission_error.png", s.design, note)
    ctx.files.extend([*names, "hysteresis.png", "transmission_error.png"])
    ctx.manifest["datasheet"] = {**ds.figures(), "ring": ring_description(ctx)}
    if s.assembly:
        _assembly(ctx)


def _assembly(ctx: RunContext) -> None:
    """``[assembly]``: the roller class to fit, with each class's datasheet (assembly.json)."""
    from corr_cad.export.files import write_json
    from corr_cad.tolerance.assembly import selective_assembly

    s = ctx.scene
    ring = "measured ring" if s.measured_profile is not None else "nominal ring"
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
    )
    res = {"ring": ring, **res}
    write_json(ctx.out / "assembly.json", res)
    ctx.files.append("assembly.json")
    ctx.manifest["assembly"] = {
        k: res[k] for k in ("ring", "target_backlash_arcmin", "chosen_class_um", "reason")
    }
    if res["chosen_class_um"] is None:
        ctx.manifest["assembly"]["failed"] = [f"selective assembly failed: {res['reason']}"]
