"""The stage graph: every stage, what it needs, and which stages a scene's formats run.

Each stage names the stages it needs. A scene's ``[export] formats`` pick
the target stages; only they and what they need run, in dependency order
(:func:`plan`). A DXF-only scene never touches the force solver; a
forces-only scene never approximates the profile for DXF. The stage bodies
live by concept in ``stages_profile``, ``stages_forces``,
``stages_tolerance``, ``stages_geometry`` and ``stages_shop``.
"""

from __future__ import annotations

from corr_cad.run.stages import stages_shop as shop
from corr_cad.run.stages.context import RunContext, Stage
from corr_cad.run.stages.stages_datasheet import _datasheet, _datasheet_files
from corr_cad.run.stages.stages_forces import _checks, _force_files, _forces
from corr_cad.run.stages.stages_geometry import (
    _clearance,
    _interference,
    _mesh_files,
    _solids,
    _step_files,
)
from corr_cad.run.stages.stages_modification import modification_design
from corr_cad.run.stages.stages_profile import (
    _dxf_files,
    _dxf_geometry,
    _measured,
    _preview_png,
    _profiles,
    _undercut,
)
from corr_cad.run.stages.stages_tolerance import _allocation, _montecarlo, _sweeps

__all__ = ["STAGES", "FORMAT_TARGETS", "INTERFERENCE_STAGES", "plan"]


def _drive(ctx: RunContext) -> None:
    from corr_cad.run.stages.stages_first_stage import drive

    drive(ctx)


def _sizing(ctx: RunContext) -> None:
    from corr_cad.run.stages.stages_sizing import sizing

    sizing(ctx)


def _report(ctx: RunContext) -> None:
    from corr_cad.export.report import write_report

    forces = ctx.results.forces
    if ctx.results.drive is not None:  # the drive: the heavier row, as the console shows it
        from corr_cad.run.stages.stages_drive import heavier_row

        forces = ctx.results.drive.rows[heavier_row(ctx.results.drive)]
    path = write_report(ctx.scene, ctx.manifest, forces, list(ctx.files), ctx.out)
    ctx.files.append(path.name)


STAGES: dict[str, Stage] = {
    st.name: st
    for st in (
        Stage("undercut", (), _undercut, "closed-form undercut test"),
        Stage("profiles", ("undercut",), _profiles, "exact working and theoretical profiles"),
        Stage(
            "dxf_geometry", ("profiles",), _dxf_geometry, "approximation to the tolerance, measured"
        ),
        Stage("dxf_files", ("dxf_geometry",), _dxf_files, "the four part DXF files"),
        Stage("preview_png", ("profiles",), _preview_png, "preview.png"),
        Stage("measured_profile", ("profiles",), _measured, "measured profile, registered"),
        Stage("forces", ("undercut",), _forces, "mesh-force solver"),
        Stage("force_files", ("forces",), _force_files, "forces.csv, summary JSON and plots"),
        Stage("datasheet", ("undercut",), _datasheet, "windup curve and transmission error"),
        Stage(
            "datasheet_files",
            ("datasheet",),
            _datasheet_files,
            "datasheet.json, windup and transmission error CSV, hysteresis plot",
        ),
        Stage("solids", ("profiles",), _solids, "watertight solids (manifold3d), volumes checked"),
        Stage("mesh_files", ("solids",), _mesh_files, "part and assembly meshes"),
        Stage("step_files", ("profiles",), _step_files, "STEP AP214 parts and assembly, read back"),
        Stage("clearance", ("undercut",), _clearance, "exact clearance of every roller"),
        Stage("interference", ("solids",), _interference, "mesh interference sweep (booleans)"),
        Stage("checks", ("forces",), _checks, "design checks against [checks] limits"),
        Stage("montecarlo", ("undercut",), _montecarlo, "Monte Carlo over [tolerances]"),
        Stage("allocation", ("undercut",), _allocation, "tolerance allocation against [checks]"),
        Stage("sweeps", (), _sweeps, "parametric sweeps around the design"),
        Stage("edm_files", ("profiles",), shop.edm_files, "wire-EDM path, DXF and G-code"),
        Stage("cmm_points", ("profiles",), shop.cmm_points, "CMM nominal points"),
        Stage("inspection", ("measured_profile",), shop.inspection, "per-tooth inspection"),
        Stage(
            "modification_design",
            ("undercut",),
            modification_design,
            "profile modification designed to targets under [tolerances]",
        ),
        Stage(
            "drive",
            ("profiles",),
            _drive,
            "the whole drive: ratio, mass, inertia, first-stage loads",
        ),
        Stage("sizing", (), _sizing, "design search: candidates, front, design scenes"),
        Stage("report", (), _report, "report.html (runs last, reads what the run made)"),
    )
}

#: Which stage produces each ``[export] formats`` entry.
FORMAT_TARGETS = {
    "dxf": "dxf_files",
    "png": "preview_png",
    "forces": "force_files",
    "datasheet": "datasheet_files",
    **{f: "mesh_files" for f in ("stl", "3mf", "glb", "ply")},
    "step": "step_files",
    "interference": "interference",
    "montecarlo": "montecarlo",
    "allocation": "allocation",
    "sweeps": "sweeps",
    **{"edm": "edm_files", "cmm": "cmm_points", "inspection": "inspection"},
    "modification": "modification_design",
    "sizing": "sizing",
    "report": "report",
}

#: Targets that use other targets' results when they run (the EDM lead-in uses forces).
_LATE = ("edm_files", "inspection")


#: ``[export] interference_method`` -> the stages of the ``interference`` format.
INTERFERENCE_STAGES = {
    "exact": ("clearance",),
    "mesh": ("interference",),
    "both": ("clearance", "interference"),
}


def plan(
    formats: tuple[str, ...],
    checks: bool = False,
    measured: bool = False,
    interference_method: str = "exact",
    datasheet_checks: bool = False,
    first_stage: bool = False,
) -> list[str]:
    """Stages needed for ``formats`` (and the checks), in dependency order, each once.

    With a measured profile it is registered first: the forces, Monte Carlo
    and checks then see it as a gear-profile deviation. ``datasheet_checks``:
    a check limits a datasheet figure, so the datasheet runs before the checks.
    """
    order: list[str] = []

    def visit(name: str) -> None:
        if name in order:
            return
        for dep in STAGES[name].requires:
            visit(dep)
        order.append(name)

    if first_stage:  # [first_stage]: the drive's figures, before the datasheet reads them
        visit("drive")
    if measured:
        visit("measured_profile")
    for f in sorted(formats, key=lambda f: FORMAT_TARGETS[f] in _LATE):
        if f == "interference":
            for name in INTERFERENCE_STAGES[interference_method]:
                visit(name)
        else:
            visit(FORMAT_TARGETS[f])
    if checks:
        if datasheet_checks:
            visit("datasheet")
        visit("checks")
    if "report" in order:  # the report reads everything the others made
        order.remove("report")
        order.append("report")
    return order
