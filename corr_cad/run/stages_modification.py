"""Pipeline pieces of the profile modification (issue 20): the manifest record and
``modification.png``. The modified profile itself reaches every stage through
:func:`corr_cad.run.context.modified_curve` and
:func:`corr_cad.run.context.scene_errors`.
"""

from __future__ import annotations

import math

import numpy as np

from corr_cad.run.context import RunContext

__all__ = ["modification_manifest", "modification_png", "PLOT_POINTS"]

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
