"""The whole drive's datasheet figures under ``[first_stage]``: the first stage's share
(backlash, mesh windup, efficiency) and the whole drive's backlash, lost motion,
rigidity and efficiency, which ``[checks]`` read."""

from __future__ import annotations

import math

from corr_cad.mechanics.row.windup import ARCMIN_PER_RAD
from corr_cad.run.stages.context import RunContext

__all__ = ["whole_drive"]


def whole_drive(ctx: RunContext) -> dict:
    """With ``[first_stage]``: the whole drive's figures and the first stage's share."""
    s, d = ctx.scene, ctx.manifest.get("drive")
    if s.first_stage is None or d is None:
        return {}
    from corr_cad.run.stages.stages_first_stage import first_stage_shares

    crank = math.degrees(s.first_stage.crank_backlash_rad) * 60.0
    floating = {  # the cams on their needle bearings (drive_mass_inertia)
        k: d[k] for k in ("input_inertia_cams_fixed_kg_m2", "inertia_convention") if k in d
    }
    return {
        "total_ratio": d["total_ratio"],
        "input_inertia_kg_m2": d["input_inertia_kg_m2"],
        **floating,
        "mass_kg": d["mass_kg"],
        "first_stage": {
            "backlash_at_crank_arcmin": crank,
            "backlash_arcmin": crank / s.design.roller_count,
            "lost_motion_arcmin": first_stage_shares(ctx)["lost_motion_arcmin"],
            "transmission_error_arcsec": 0.0,
            "definition": "the first stage's backlash (pinion held) reflected to the output, "
            "backlash_1 / (z + 1); its lost motion that plus its meshes' windup at +-band T_R "
            "(ISO 6336-1 mesh stiffness); exact involutes are conjugate: no transmission error "
            "of their own; whole_drive adds them to the second stage's figures above",
            **_first_stage_mesh(ctx),
        },
        "whole_drive": _whole_drive_checks(ctx),
    }


def _first_stage_mesh(ctx: RunContext) -> dict:
    """The first stage's efficiency (with ``[friction]``) and mesh rigidity."""
    from corr_cad.run.stages.stages_first_stage import first_stage_mesh_of

    d = first_stage_mesh_of(ctx).as_dict()
    if ctx.results.friction is None:
        for k in ("efficiency", "mu_mesh", "gear_loss_factor_H_V", "efficiency_method"):
            d.pop(k)
    return d


def _whole_drive_checks(ctx: RunContext) -> dict:
    """The whole drive's backlash, lost motion, rigidity (and efficiency): the figures
    ``[checks]`` read under ``[first_stage]``, with their parts."""
    from corr_cad.run.stages.stages_first_stage import first_stage_shares, whole_drive_values

    ds = ctx.results.datasheet
    values = {**ds.check_values(), "backlash_arcmin": float(ds.backlash().max() * ARCMIN_PER_RAD)}
    if ctx.results.friction is not None:
        values.update(ctx.results.friction.check_values())
    values.pop("transmission_error_arcsec", None)
    values.pop("life_h", None)
    return whole_drive_values(values, first_stage_shares(ctx))
