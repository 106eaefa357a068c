"""What the stages share: the scene, the staging folder, typed results and the manifest.

:class:`Results` holds every stage's output as a typed field (``None`` until
the stage that makes it has run); :class:`Stage` is one node of the stage
graph in :mod:`corr_cad.run.stages.stages`.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    import numpy as np

    from corr_cad.geometry.clearance import Clearance
    from corr_cad.geometry.deviations import ManufacturingErrors
    from corr_cad.geometry.profile import ProfileCurve, UndercutInfo
    from corr_cad.geometry.sampling import ProfileApproximation
    from corr_cad.mechanics.datasheet import Datasheet
    from corr_cad.mechanics.row.solver import ForceResult
    from corr_cad.run.scene.scene import Scene
    from corr_cad.tolerance.measured import Registration

__all__ = [
    "Results",
    "RunContext",
    "Stage",
    "scene_errors",
    "raw_errors",
    "modified_curve",
    "psi_contact_limit",
    "elastic_bodies",
    "chain_kwargs",
    "expected_seconds",
]


@dataclass
class Results:
    """Stage outputs, one typed field each; ``None`` until its stage has run."""

    #: ``undercut``: the closed-form undercut test.
    undercut: UndercutInfo | None = None
    #: ``profiles``: the exact working (trimmed) and theoretical profiles.
    working: ProfileCurve | None = None
    theoretical: ProfileCurve | None = None
    #: ``dxf_geometry``: both profiles approximated to ``[export] tolerance``.
    working_approx: ProfileApproximation | None = None
    theoretical_approx: ProfileApproximation | None = None
    #: ``dxf_geometry`` with ``[first_stage]``: each gear's measured polyline outline.
    gear_outlines: dict[str, Any] | None = None
    #: ``solids`` with ``[first_stage]``: its parts' solids, by part name.
    first_stage_solids: dict[str, Any] | None = None
    #: ``measured_profile``: the registration, the raw points, and the scene's
    #: errors with the measured profile as a gear-profile deviation.
    registration: Registration | None = None
    measured_points: np.ndarray | None = None
    errors: ManufacturingErrors | None = None
    #: ``measured_profile`` with ``[errors.row_b] measured_profile``: ring B's registration.
    registration_b: Registration | None = None
    measured_points_b: np.ndarray | None = None
    #: ``forces``: the mesh-force solution over the cycle.
    forces: ForceResult | None = None
    #: ``forces`` under ``[solver] model = "drive"``: both rows (``forces`` is row A's).
    drive: Any = None
    #: ``[solver] bodies = "elastic"``: the ring's and frame's influence tables.
    bodies: Any = None
    #: ``solids``: part outlines, manifold solids and their meshes, by part name.
    outlines: dict[str, Any] | None = None
    solids: dict[str, Any] | None = None
    meshes: dict[str, Any] | None = None
    #: ``interference``: the mesh-boolean sweep's summary.
    interference: dict[str, Any] | None = None
    #: ``clearance``: the exact clearance over the cycle, per position the
    #: smallest and largest over the rollers (:meth:`Clearance.envelope`).
    clearance: Clearance | None = None
    #: ``datasheet``: the windup curve, the transmission error and their figures.
    datasheet: Datasheet | None = None
    #: ``[friction]`` / ``[life]``: the efficiency map and the lives.
    friction: Any = None
    #: ``[lubrication]`` / ``[thermal]``: load-independent losses, temperature, a_ISO.
    losses: Any = None
    #: ``[modification]``: the unmodified (conjugate) working profile, its
    #: approximation, and the modified exact profile and its gap (made on
    #: first use by :func:`modified_curve`, :func:`scene_errors`).
    conjugate: ProfileCurve | None = None
    conjugate_approx: ProfileApproximation | None = None
    modified: ProfileCurve | None = None
    modification_gap: Any = None


@dataclass
class RunContext:
    """What the stages share: the scene, the staging folder and results."""

    scene: Scene
    out: Path
    results: Results = field(default_factory=Results)
    files: list[str] = field(default_factory=list)
    manifest: dict = field(default_factory=dict)
    progress: Callable[[str], None] = lambda msg: None
    executor: object = None
    #: The run's :class:`~corr_cad.run.budget.resources.Estimate` (expected stage times).
    estimate: object = None
    #: The run's :class:`~corr_cad.run.budget.resources.Budget` (None: the default).
    budget: object = None
    #: The plot workers (:mod:`corr_cad.run.stages.plot_workers`; None: draw here).
    plotter: object = None


@dataclass(frozen=True)
class Stage:
    name: str
    requires: tuple[str, ...]
    run: Callable[[RunContext], None]
    doc: str


def raw_errors(ctx: RunContext) -> ManufacturingErrors:
    """The scene's errors, with a registered measured profile, without the designed clearance."""
    return ctx.results.errors if ctx.results.errors is not None else ctx.scene.errors


def modified_curve(ctx: RunContext) -> ProfileCurve | None:
    """The modified working profile of ``[modification]`` (None without one), made once."""
    mod = getattr(ctx.scene, "modification", None)
    if mod is None:
        return None
    if ctx.results.modified is None:
        from corr_cad.geometry.modification import modified_profile

        ctx.results.modified = modified_profile(ctx.scene.design, mod)
    return ctx.results.modified


def scene_errors(ctx: RunContext) -> ManufacturingErrors:
    """The scene's errors, with a registered measured profile if there is one.

    With a ``[modification]`` the designed clearance is added as an initial
    gap at the gear contact, from the exact geometry
    (:func:`corr_cad.geometry.modification.modification_gap`).
    """
    base = raw_errors(ctx)
    curve = modified_curve(ctx)
    if curve is None:
        return base
    from corr_cad.geometry.modification import modification_gap, with_modification

    if ctx.results.modification_gap is None:
        ctx.results.modification_gap = modification_gap(ctx.scene.design, curve)
    return with_modification(base, ctx.results.modification_gap)


def scene_errors_b(ctx: RunContext) -> ManufacturingErrors | None:
    """Row B's ``[errors.row_b]`` with the designed clearance of ``[modification]`` (None
    without the section: ``[errors]`` describes both rows)."""
    eb = getattr(ctx.scene, "errors_b", None)
    if eb is None:
        return None
    if ctx.results.registration_b is not None:
        eb = replace(eb, profile_deviation=ctx.results.registration_b.deviation)
    curve = modified_curve(ctx)
    if curve is None:
        return eb
    from corr_cad.geometry.modification import modification_gap, with_modification

    if ctx.results.modification_gap is None:
        ctx.results.modification_gap = modification_gap(ctx.scene.design, curve)
    return with_modification(eb, ctx.results.modification_gap)


def drive_kwargs(ctx: RunContext) -> dict:
    """The drive model's keyword arguments (errors of both rows, bearings, contact law)."""
    s = ctx.scene
    out = {
        "errors": scene_errors(ctx),
        "errors_b": scene_errors_b(ctx),
        "bearing": s.bearing,
        "bearing_b": s.bearing_b,
        "contact_model": s.solver.contact_model,
        "variants": s.solver.variants,
        "psi_contact_limit": psi_contact_limit(ctx),
        **elastic_bodies(ctx),
    }
    if getattr(s, "crank", None) is not None:  # [crankshaft] / [bearings.crank]
        out["crank"] = s.crank
    return out


def chain_kwargs(ctx: RunContext, per_design: bool = False) -> dict:
    """The load path beyond the contacts as the nominal drive solves it: ``crank`` with
    ``[crankshaft]`` / ``[bearings.crank]``, ``bodies`` (the influence tables, made once
    per run) under ``[solver] bodies = "elastic"``; neither key where it is absent.
    ``per_design``: with ``bodies_for``, the tables of another design (a sweep's)."""
    out = {**elastic_bodies(ctx)}
    if getattr(ctx.scene, "crank", None) is not None:
        out["crank"] = ctx.scene.crank
    if per_design and "bodies" in out:
        import functools

        from corr_cad.run.stages.stages_bodies import design_tables

        out["bodies_for"] = functools.partial(design_tables, chord=ctx.scene.chord_tolerance)
    return out


def elastic_bodies(ctx: RunContext) -> dict:
    """``{"bodies": tables}`` under ``[solver] bodies = "elastic"``, else nothing."""
    if ctx.scene.solver.bodies != "elastic":
        return {}
    from corr_cad.run.stages.stages_bodies import body_tables

    return {"bodies": body_tables(ctx)}


def psi_contact_limit(ctx: RunContext) -> float:
    """Rollers beyond the trimmed tooth tips of an allowed undercut find no flank."""
    info = ctx.results.undercut
    return math.radians(info.trimmed_psi_deg) if info.undercut and info.trimmed_psi_deg else math.pi


def expected_seconds(ctx: RunContext, stage: str) -> float | None:
    """The resource estimate's time for ``stage`` at the machine's present load
    (:func:`~corr_cad.run.progress.load_factor`; None without an estimate)."""
    from corr_cad.run.progress import load_factor

    est = ctx.estimate
    cost = est.stages.get(stage) if est is not None else None
    return cost.seconds * load_factor(est.workers)[0] if cost is not None else None
