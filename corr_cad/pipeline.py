"""The run pipeline: a small explicit stage graph.

Each stage names the stages it needs. A scene's ``[export] formats`` pick
the target stages; only they and what they need run, in dependency order.
A DXF-only scene never touches the force solver; a forces-only scene never
approximates the profile for DXF.
"""

from __future__ import annotations

import math
import platform
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from importlib import metadata
from pathlib import Path

import numpy as np

from . import __version__
from .errors import SolverError
from .profile import theoretical_profile, undercut_analysis, working_profile
from .sampling import approximate
from .scene import Scene
from .solver import solve_forces

__all__ = ["STAGES", "FORMAT_TARGETS", "plan", "run_scene", "RunContext"]


@dataclass
class RunContext:
    """What the stages share: the scene, the staging folder and results."""

    scene: Scene
    out: Path
    results: dict = field(default_factory=dict)
    files: list[str] = field(default_factory=list)
    manifest: dict = field(default_factory=dict)
    progress: Callable[[str], None] = lambda msg: None


@dataclass(frozen=True)
class Stage:
    name: str
    requires: tuple[str, ...]
    run: Callable[[RunContext], None]
    doc: str


def _undercut(ctx: RunContext) -> None:
    info = undercut_analysis(ctx.scene.design)
    ctx.results["undercut"] = info
    ctx.manifest["undercut"] = info.as_dict()


def _profiles(ctx: RunContext) -> None:
    d = ctx.scene.design
    ctx.results["working"] = working_profile(d, ctx.results["undercut"])
    ctx.results["theoretical"] = theoretical_profile(d)
    ctx.manifest["profile"] = {
        "working_area_mm2": ctx.results["working"].area(),
        "theoretical_area_mm2": ctx.results["theoretical"].area(),
        "tooth_tip_trimmed": ctx.results["working"].has_corners,
    }


def _dxf_geometry(ctx: RunContext) -> None:
    s = ctx.scene
    w = approximate(ctx.results["working"], s.representation, s.tolerance)
    t = approximate(ctx.results["theoretical"], s.representation, s.tolerance)
    ctx.results["working_approx"] = w
    ctx.results["theoretical_approx"] = t
    ctx.manifest["accuracy"] = {"working_profile": w.as_dict(), "theoretical_profile": t.as_dict()}


def _dxf_files(ctx: RunContext) -> None:
    from .export import dxf

    paths = dxf.write_all(
        ctx.scene.design, ctx.results["working_approx"], ctx.results["theoretical_approx"], ctx.out
    )
    ctx.files.extend(p.name for p in paths.values())


def _preview_png(ctx: RunContext) -> None:
    from .export import plots

    p = plots.preview_png(
        ctx.scene.design,
        ctx.results["working"],
        ctx.results["theoretical"],
        ctx.out / "preview.png",
    )
    ctx.files.append(p.name)


def _forces(ctx: RunContext) -> None:
    s = ctx.scene
    info = ctx.results["undercut"]
    limit = (
        math.radians(info.trimmed_psi_deg) if info.undercut and info.trimmed_psi_deg else math.pi
    )
    angles = (
        np.radians(np.asarray(s.solver.crank_angles_deg, dtype=float))
        if s.solver.crank_angles_deg is not None
        else None
    )
    res = solve_forces(
        s.design,
        s.load.input_torque,
        angles,
        positions=s.solver.positions,
        load_share=s.solver.load_share,
        errors=s.errors,
        variants=s.solver.variants,
        psi_contact_limit=limit,
    )
    if not res.success:
        raise SolverError(f"force solver: {res.message}")
    ctx.results["forces"] = res


def _force_files(ctx: RunContext) -> None:
    from .export import plots
    from .outputs import write_csv, write_json

    res = ctx.results["forces"]
    s = ctx.scene
    P, R = res.F_j.shape
    ang = np.degrees(res.crank_angles)
    psi = np.degrees(np.mod(res.psi, 2 * np.pi))
    cols = [
        np.repeat(ang, R),
        np.tile(np.arange(1, R + 1), P),
        psi.ravel(),
        res.F_j.ravel(),
        res.F_s.ravel(),
        res.F_n.ravel(),
        res.p_cam.ravel(),
        res.p_slot.ravel(),
        res.p_gear.ravel(),
    ]
    fmt = ("{:.6f}", "{:d}", "{:.6f}") + ("{:.9g}",) * 6
    rows = (
        [f.format(v) for f, v in zip(fmt, row, strict=True)]
        for row in zip(*(c.tolist() for c in cols), strict=True)
    )
    header = [
        "crank_angle_deg",
        "roller",
        "psi_deg",
        "F_j",
        "F_s",
        "F_n",
        "p_cam",
        "p_slot",
        "p_gear",
    ]
    write_csv(ctx.out / "forces.csv", header, rows)
    summary = res.summary()
    summary["solver"] = {
        "success": res.success,
        "message": res.message,
        "iterations": res.iterations,
        "moment_residual": res.moment_residual,
        "positions": P,
        "positions_solved": res.positions_solved,
        "full_cycle": res.full_cycle,
        "input_torque_Nmm": s.load.input_torque,
        "cam_moment_Nmm": res.cam_moment,
        "load_share": s.solver.load_share,
        "variants": list(s.solver.variants),
        "contacts_outside_validity": int(np.count_nonzero(~res.valid & (res.F_j > 0))),
        "output_torque_Nmm_mean": float(res.output_torque.mean()),
    }
    write_json(ctx.out / "forces_summary.json", summary)
    order = np.argsort(ang)
    plots.forces_png(
        ang[order], res.F_j[order, 0], res.F_s[order, 0], res.F_n[order, 0], ctx.out / "forces.png"
    )
    plots.load_distribution_png(
        s.design, float(ang[0]), res.F_n[0], ctx.out / "load_distribution.png"
    )
    ctx.files.extend(["forces.csv", "forces_summary.json", "forces.png", "load_distribution.png"])
    ctx.manifest["forces"] = {k: v for k, v in summary.items() if k != "solver"}


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
        Stage("forces", ("undercut",), _forces, "mesh-force solver"),
        Stage("force_files", ("forces",), _force_files, "forces.csv, summary JSON and plots"),
    )
}

#: Which stage produces each ``[export] formats`` entry.
FORMAT_TARGETS = {"dxf": "dxf_files", "png": "preview_png", "forces": "force_files"}


def plan(formats: tuple[str, ...]) -> list[str]:
    """Stages needed for ``formats``, in dependency order (each once)."""
    order: list[str] = []

    def visit(name: str) -> None:
        if name in order:
            return
        for dep in STAGES[name].requires:
            visit(dep)
        order.append(name)

    for f in formats:
        visit(FORMAT_TARGETS[f])
    return order


def _versions() -> dict:
    out = {"corr_cad": __version__, "python": platform.python_version()}
    for pkg in ("numpy", "scipy", "ezdxf", "shapely", "trimesh", "manifold3d", "matplotlib"):
        try:
            out[pkg] = metadata.version(pkg)
        except metadata.PackageNotFoundError:
            out[pkg] = None
    return out


def _clean(obj):
    """JSON-safe copy: non-finite floats become None, numpy scalars Python ones."""
    if isinstance(obj, dict):
        return {str(k): _clean(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_clean(v) for v in obj]
    if isinstance(obj, np.generic):
        obj = obj.item()
    if isinstance(obj, float) and not math.isfinite(obj):
        return None
    return obj


def run_scene(scene: Scene, out: Path, progress: Callable[[str], None] | None = None) -> dict:
    """Run the stages ``scene`` needs, writing into ``out`` (a staging folder).

    Returns the manifest (also written as ``manifest.json``).
    """
    from .outputs import sha256_of, write_json

    ctx = RunContext(scene=scene, out=Path(out), progress=progress or (lambda m: None))
    stages = plan(scene.formats)
    timings = []
    for i, name in enumerate(stages, 1):
        ctx.progress(f"[{i}/{len(stages)}] {name}: {STAGES[name].doc}")
        t0 = time.perf_counter()
        STAGES[name].run(ctx)
        timings.append({"name": name, "seconds": round(time.perf_counter() - t0, 6)})
    files = {
        name: {"sha256": sha256_of(ctx.out / name), "bytes": (ctx.out / name).stat().st_size}
        for name in sorted(ctx.files)
    }
    manifest = {
        "scene": scene.name,
        "inputs": scene.source,
        "design": scene.design.as_dict(),
        "formats": list(scene.formats),
        "versions": _versions(),
        "units": {
            "length": "mm",
            "force": "N",
            "torque": "N*mm",
            "pressure": "MPa",
            "angle": "deg",
        },
        **ctx.manifest,
        "files": files,
        "stages": timings,
    }
    manifest = _clean(manifest)
    write_json(ctx.out / "manifest.json", manifest)
    return manifest
