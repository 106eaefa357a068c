"""Selective assembly: which roller size class to fit to a ring (issue 20, item 4).

Precision drives are put together from a ring as made: the rollers are bought
in size classes (radius deviations, um) and the class is chosen per ring.
For each class ``c`` every roller gets the radius error ``c`` on top of the
scene's errors (the designed modification and a registered measured ring
included), and the predicted datasheet
(:func:`corr_cad.mechanics.datasheet.datasheet`) is computed.

A class **binds** when, at some position, no frame angle fits every roller
without interference: from the gaps alone (no force solve), the least
possible largest chain interference is positive (:func:`binding_interference`,
the same gaps and cam advances as
:meth:`corr_cad.mechanics.row.windup.Windup.free_ends`). It is reported in um
(``interference_um``: > 0 binds, <= 0 the room left on the tightest roller);
exact contact (the conjugate drive, 0 to round-off) does not bind.

The chosen class is the one with the smallest backlash among those that do
not bind and whose backlash (maximum over the positions, the catalogue
figure) is at most the target: the tightest free fit, which shares the load
over the most rollers. None qualifies: ``chosen_class_um`` is ``None`` and
``reason`` says which condition every class fails.
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from corr_cad.geometry.design import GearDesign
from corr_cad.geometry.deviations import ManufacturingErrors
from corr_cad.mechanics.datasheet import DatasheetSpec, datasheet
from corr_cad.mechanics.row.solver_geometry import roller_geometry
from corr_cad.mechanics.row.windup import ARCMIN_PER_RAD, crank_angles_of

__all__ = ["binding_interference", "selective_assembly", "BINDING_EPS_MM"]

#: Interference below this (mm) is exact contact, not binding (the closed
#: forms' round-off at ~150 mm is ~1e-13 mm).
BINDING_EPS_MM = 1e-9


def binding_interference(
    design: GearDesign,
    output_angles: np.ndarray,
    errors: ManufacturingErrors,
    variants: tuple[str, ...] = (),
    psi_contact_limit: float = math.pi,
    errors_b: ManufacturingErrors | None = None,
    drive: bool = False,
) -> np.ndarray:
    """Least possible chain interference at each output angle, mm (P,), from the gaps only.

    ``drive``: both rows on the one crank (``errors_b`` row B's, None: ``errors``),
    cams fixed: the crank rotation that fits one row may press the other.

    With the crank locked, turning the cam by ``tau`` changes roller ``i``'s
    chain gap (interference +) to ``g_i + a_i tau``. The frame settles where
    the largest of them is smallest: ``min_tau max_i (g_i + a_i tau)``, a
    convex piecewise-linear minimum found exactly as the largest crossing of
    a rising and a falling line (linear-programming duality), or the largest
    gap of a roller that does not move (``a_i = 0``). ``> 0``: no frame angle
    fits every roller, the drive binds (preloaded); ``<= 0``: it fits, with
    that much room on the tightest roller.
    """
    phi = crank_angles_of(np.asarray(output_angles, dtype=float), design)
    if drive:
        from corr_cad.mechanics.drive.drive import drive_geometry, row_errors
        from corr_cad.mechanics.drive.drive_numerics import joined

        geo = joined(
            *drive_geometry(design, phi, *row_errors(errors, errors_b), variants, psi_contact_limit)
        )
    else:
        geo = roller_geometry(design, phi, errors, variants, psi_contact_limit)
    g = np.where(geo.loadable, geo.gap, -np.inf)
    a = np.where(geo.loadable, geo.advance, 0.0)
    out = np.max(np.where(a == 0.0, g, -np.inf), axis=1)
    for p in range(g.shape[0]):
        up, dn = a[p] > 0, a[p] < 0
        ai, gi = a[p][up][:, None], g[p][up][:, None]
        aj, gj = a[p][dn][None, :], g[p][dn][None, :]
        if ai.size and aj.size:
            cross = (ai * gj - aj * gi) / (ai - aj)
            out[p] = max(out[p], float(cross.max()))
    return out


def _stats(v: np.ndarray) -> dict:
    return {"min": float(v.min()), "mean": float(v.mean()), "max": float(v.max())}


def selective_assembly(
    design: GearDesign,
    spec: DatasheetSpec,
    base_errors: ManufacturingErrors,
    classes_um: list[float],
    target_backlash_arcmin: float,
    *,
    load_share: float = 0.55,
    variants: tuple[str, ...] = (),
    psi_contact_limit: float = math.pi,
    progress=None,
    contact_model: str = "nonlinear",
    drive: dict | None = None,
) -> dict:
    """The predicted datasheet of every class and the class to fit (``assembly.json``).

    ``drive``: the two-row drive (:func:`~corr_cad.mechanics.datasheet.datasheet`'s
    argument); the class is fitted to both rows, and binding is judged on both
    rows on the one crank with the cams fixed.
    """
    rows = []
    for k, c in enumerate(classes_um):
        err = replace(base_errors, roller_radius_error=base_errors.roller_radius_error + c * 1e-3)
        drive_k = None
        if drive is not None:
            eb = drive.get("errors_b")
            if eb is not None:
                eb = replace(eb, roller_radius_error=eb.roller_radius_error + c * 1e-3)
            drive_k = {**drive, "errors_b": eb}
        ds = datasheet(
            design,
            spec,
            errors=err,
            load_share=load_share,
            contact_model=contact_model,
            variants=variants,
            psi_contact_limit=psi_contact_limit,
            drive=drive_k,
        )
        inter = binding_interference(
            design,
            ds.output_angles,
            err,
            variants,
            psi_contact_limit,
            errors_b=None if drive_k is None else drive_k["errors_b"],
            drive=drive_k is not None,
        )
        binds = bool(np.max(inter) > BINDING_EPS_MM)
        fig = ds.figures()
        backlash = fig["backlash_arcmin"]["max"]
        rows.append(
            {
                "class_um": float(c),
                "binds": binds,
                "interference_um": float(np.max(inter) * 1e3),
                "backlash_arcmin": _stats(ds.backlash() * ARCMIN_PER_RAD),
                "lost_motion_arcmin": _stats(ds.lost_motion() * ARCMIN_PER_RAD),
                "torsional_rigidity_Nm_per_arcmin": fig["torsional_rigidity_Nm_per_arcmin"][
                    "catalogue"
                ],
                "transmission_error_arcsec": ds.transmission_error_peak_to_peak(),
                "peak_contact_pressure_at_rated_MPa": fig.get("peak_contact_pressure_at_rated_MPa"),
                "meets_target": (not binds) and backlash <= target_backlash_arcmin,
            }
        )
        if progress is not None:
            progress(
                f"      class {c:+g} um: backlash {backlash:.4g} arcmin"
                + (" (binds)" if binds else "")
            )
    ok = [r for r in rows if r["meets_target"]]
    chosen = min(ok, key=lambda r: r["backlash_arcmin"]["max"]) if ok else None
    reason = None
    if chosen is None:
        free = [r for r in rows if not r["binds"]]
        if not free:
            reason = "every class binds (preloaded rollers); buy smaller rollers"
        else:
            best = min(free, key=lambda r: r["backlash_arcmin"]["max"])
            reason = (
                f"no class that fits without binding meets the backlash target: the tightest, "
                f"{best['class_um']:+g} um, gives {best['backlash_arcmin']['max']:.4g} arcmin "
                f"> {target_backlash_arcmin:g} arcmin; buy larger rollers"
            )
    return {
        "target_backlash_arcmin": target_backlash_arcmin,
        "chosen_class_um": None if chosen is None else chosen["class_um"],
        "reason": reason,
        "rule": "smallest backlash among the classes that do not bind and meet the target",
        "binding": "interference_um > 0: some position admits no frame angle that fits every "
        "roller (gaps only)",
        "classes": rows,
        "positions": fig["positions"],
        "rated_torque_Nm": fig["rated_torque_Nm"],
    }
