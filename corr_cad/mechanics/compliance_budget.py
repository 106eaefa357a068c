"""The compliance budget of the drive: its windup at the rated torque split by component.

Each component's windup is its elements' work, force times their own deformation at
the solved state, over the output torque (:func:`corr_cad.mechanics.drive.drive_crank.budget_terms`,
virtual work): the parts add up to the drive's windup ``theta(T_R)`` exactly, whatever
the contact law, and each is positive. For a linear element it is the series split
``T c_i``; for the nonlinear ones (the contacts, the needles and support bearings with
their clearances) it is the secant split at ``T_R``: the windup each element's own
deflection causes, measured, as ``theta`` is, from the kinematic zero of the nominal
parts (so a clearance counts where it is taken up). The same split of the rigidity
range (``theta(T_2) - theta(T_1)``, the catalogue rigidity's) is each component's
difference of the two: it adds up too.

Components (windup in arcmin, mean over the datasheet's positions, and the share of the
total): the three contacts of each roller (cam, ring, slot), the cams' needle bearings,
the crankshaft's bending, shear and torsion, its support bearings, the initial gaps of
the errors (minus the forces' work on them: 0 for nominal parts), the ring body, the
frame and the cams (``F . C_body F`` of each body's influence matrix where the bodies
are elastic; else rigid: 0, and said so), the first stage (its
compliance is not modelled) and the ``[datasheet] series_rigidity_Nm_per_arcmin``
(``T / k`` where given).
"""

from __future__ import annotations

import numpy as np

from corr_cad.mechanics.drive.drive_crank import _State, budget_terms
from corr_cad.mechanics.row.windup import ARCMIN_PER_RAD, NMM_PER_NM, series_rigidity_Nmm_per_rad

__all__ = [
    "MODEL_COMPONENTS",
    "ABSENT_COMPONENTS",
    "BODY_COMPONENTS",
    "components_of",
    "compliance_budget",
    "support_loads",
    "with_life_hours",
]

#: The components the drive's solve holds, in the budget's order.
MODEL_COMPONENTS = (
    "contact_cam",
    "contact_ring",
    "contact_slot",
    "needle_bearings",
    "crankshaft_bending",
    "crankshaft_shear",
    "crankshaft_torsion",
    "support_bearings",
    "initial_gaps",
)
#: Components not in the solve (rigid), with the reason the budget states.
ABSENT_COMPONENTS = {
    "ring_body": 'rigid ([solver] bodies = "rigid")',
    "frame": 'rigid ([solver] bodies = "rigid")',
    "first_stage": "not modelled: the first stage's compliance (its backlash is in first_stage)",
}

DEFINITION = (
    "each component's work, force times its own deformation at the solved state, over the "
    "output torque (virtual work): the components add up to the windup theta(T_R) from the "
    "kinematic zero; for nonlinear elements the secant split at T_R (a clearance counts "
    "where it is taken up); mean over the positions"
)


#: The elastic bodies' components (``[solver] bodies = "elastic"``), after the model's.
BODY_COMPONENTS = ("ring_body", "frame", "cam_body")


def components_of(windup) -> tuple[tuple[str, ...], dict[str, str]]:
    """The components a drive windup's solve holds, and those it does not (with the
    reason): the elastic bodies' in the solve where ``windup`` was given them."""
    tables = windup._options.get("bodies")
    if tables is None:
        return MODEL_COMPONENTS, ABSENT_COMPONENTS
    bodies = BODY_COMPONENTS if tables.cam is not None else BODY_COMPONENTS[:2]
    absent = {k: v for k, v in ABSENT_COMPONENTS.items() if k not in bodies}
    if tables.cam is None:
        absent = {"cam_body": "rigid (no cam table)", **absent}
    return (*MODEL_COMPONENTS, *bodies), absent


def _terms(windup, T: float) -> dict[str, np.ndarray]:
    """Each component's windup (P,) rad at output torque ``T`` (N*mm), and ``"total"``."""
    theta, _, pieces = windup._solve(T)
    target = windup.cam_moment(T)
    P = len(theta)
    out = {k: np.zeros(P) for k in components_of(windup)[0]}
    for sl, solver, sol in pieces:
        for k, v in budget_terms(solver, target, sol).items():
            out[k][sl] = v / T
    out["total"] = theta
    return out


def support_loads(windup, T: float) -> np.ndarray:
    """Each support bearing's radial load (2, P), N, at output torque ``T``."""
    _, _, pieces = windup._solve(T)
    out = []
    for _, solver, sol in pieces:
        st = getattr(solver, "_crank_geometry", None) or _State(solver)
        Pl, M = st.loads_and_moments(sol[1])
        R = solver.crank.response(Pl, M)["R"]
        out.append(np.linalg.norm(R, axis=2).T)
    return np.concatenate(out, axis=1)


def compliance_budget(
    windup,
    rated_torque: float,
    rigidity_range: tuple[float, float] = (0.5, 1.0),
    series_rigidity_Nm_per_arcmin: float | None = None,
) -> dict:
    """``datasheet.json``'s ``compliance_budget`` of a drive windup at ``T_R`` (N*mm)."""
    T = float(rated_torque)
    k = series_rigidity_Nmm_per_rad(series_rigidity_Nm_per_arcmin)
    t1, t2 = (r * T for r in rigidity_range)
    model, absent = components_of(windup)
    at = {}
    for name, t in (("rated", T), ("low", t1), ("high", t2)):
        if t == 0.0:
            at[name] = {kk: np.zeros(len(windup.output_angles)) for kk in (*model, "total")}
        else:
            at[name] = _terms(windup, t)
    total = float(np.mean(at["rated"]["total"])) + T / k
    parts = {}
    branch_total = float(np.mean(at["high"]["total"] - at["low"]["total"])) + (t2 - t1) / k
    residual = np.abs(sum(at["rated"][c] for c in model) - at["rated"]["total"])
    for c in model:
        v = float(np.mean(at["rated"][c]))
        b = float(np.mean(at["high"][c] - at["low"][c]))
        parts[c] = {
            "windup_arcmin": v * ARCMIN_PER_RAD,
            "share": v / total,
            "rigidity_range_arcmin": b * ARCMIN_PER_RAD,
            "rigidity_range_share": b / branch_total,
            "in_model": True,
        }
    if series_rigidity_Nm_per_arcmin is not None:
        parts["series_rigidity"] = {
            "windup_arcmin": T / k * ARCMIN_PER_RAD,
            "share": T / k / total,
            "rigidity_range_arcmin": (t2 - t1) / k * ARCMIN_PER_RAD,
            "rigidity_range_share": (t2 - t1) / k / branch_total,
            "in_model": True,
            "note": "[datasheet] series_rigidity_Nm_per_arcmin, T / k",
        }
    for c, why in absent.items():
        parts[c] = {
            "windup_arcmin": 0.0,
            "share": 0.0,
            "rigidity_range_arcmin": 0.0,
            "rigidity_range_share": 0.0,
            "in_model": False,
            "note": why,
        }
    out = {
        "torque_Nm": T / NMM_PER_NM,
        "windup_arcmin": total * ARCMIN_PER_RAD,
        "rigidity_range_Nm": [t1 / NMM_PER_NM, t2 / NMM_PER_NM],
        "rigidity_range_windup_arcmin": branch_total * ARCMIN_PER_RAD,
        "components": parts,
        "sum_relative_residual": float(
            np.max(residual / np.maximum(np.abs(at["rated"]["total"]), 1e-300))
        ),
        "definition": DEFINITION,
    }
    crank = windup._options.get("crank")
    if crank is not None:
        out["support_bearings"] = _support_report(windup, T, crank)
    return out


def with_life_hours(budget: dict, output_speed_rpm: float, ratio: int) -> None:
    """Each support bearing's ``L10_h`` at ``[life] rated_speed_rpm`` of the output (the
    crank turns ``z + 1`` times per output turn), into ``budget`` in place."""
    for row in budget.get("support_bearings", []):
        if "L10_million_crank_revolutions" in row and output_speed_rpm > 0:
            mrev = row["L10_million_crank_revolutions"]
            row["L10_h"] = mrev * 1e6 / (60.0 * ratio * float(output_speed_rpm))
            row["output_speed_rpm"] = float(output_speed_rpm)


def _support_report(windup, T: float, crank) -> list[dict]:
    """Each support bearing's radial load at ``+-T_R`` and its ISO 281 life."""
    loads = np.concatenate([support_loads(windup, T), support_loads(windup, -T)], axis=1)
    out = []
    for i, b in enumerate(crank.supports):
        f = loads[i]
        p = float(np.mean(f ** (10.0 / 3.0)) ** 0.3)
        row = {
            "position_mm": float(crank.shaft.support_positions[i]),
            "radial_load_at_rated_N": {
                "min": float(f.min()),
                "mean": float(f.mean()),
                "max": float(f.max()),
            },
            "equivalent_load_N": p,
        }
        if b is not None:
            life = b.life_mrev(p)
            row["dynamic_load_rating_N"] = float(b.rating)
            row["L10_million_crank_revolutions"] = life
            row["life_definition"] = (
                "ISO 281 L10 = (C_r / P)^(10/3), P the cubic (10/3) mean of the radial load "
                "over the positions at +-T_R; the crank turns z + 1 times per output turn"
            )
        out.append(row)
    return out
