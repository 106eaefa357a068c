"""Pipeline stages of the datasheet: the figures (``datasheet``) and their files.

Registered in :data:`corr_cad.run.stages.STAGES`. The ``datasheet`` stage
computes the windup curve and the transmission error
(:func:`corr_cad.mechanics.datasheet.datasheet`); ``datasheet_files`` writes
``datasheet.json``, ``windup.csv``, ``transmission_error.csv``,
``hysteresis.png`` and ``transmission_error.png``. The checks on datasheet
figures read the first, without the files.
"""

from __future__ import annotations

from corr_cad.mechanics.datasheet import DatasheetSpec, datasheet
from corr_cad.mechanics.windup import NMM_PER_NM
from corr_cad.run.context import RunContext, psi_contact_limit, scene_errors

__all__ = ["datasheet_spec", "rated_torque_Nmm"]


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


def _datasheet(ctx: RunContext) -> None:
    s = ctx.scene
    ctx.results.datasheet = datasheet(
        s.design,
        datasheet_spec(s),
        errors=scene_errors(ctx),
        load_share=s.solver.load_share,
        variants=s.solver.variants,
        psi_contact_limit=psi_contact_limit(ctx),
    )


def _meta(ctx: RunContext) -> dict:
    s = ctx.scene
    given = s.datasheet.get("rated_torque_Nm") is not None
    return {
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
    hysteresis_png(ds, ctx.out / "hysteresis.png", s.design)
    transmission_error_png(ds, ctx.out / "transmission_error.png", s.design)
    ctx.files.extend([*names, "hysteresis.png", "transmission_error.png"])
    ctx.manifest["datasheet"] = ds.figures()
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
        scene_errors(ctx),
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
