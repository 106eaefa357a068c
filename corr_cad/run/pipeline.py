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

from corr_cad._version import __version__
from corr_cad.errors import SceneError, SolverError
from corr_cad.geometry.profile import theoretical_profile, undercut_analysis, working_profile
from corr_cad.geometry.sampling import approximate
from corr_cad.mechanics.solver import solve_forces
from corr_cad.run import stages_shop as shop
from corr_cad.run.scene import Scene
from corr_cad.run.stages_geometry import (  # noqa: F401  (re-exported)
    MESH_FORMATS,
    PART_NAMES,
    _clearance,
    _interference,
    _mesh_files,
    _solids,
    _step_files,
    interference_allowance,
)

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
    executor: object = None


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
    from corr_cad.run.progress import Progress

    s = ctx.scene
    # A fine tolerance takes seconds per profile: a line with rate and time left.
    bar = Progress(2, f"      dxf profiles ({s.representation}, {s.tolerance:g} mm)", "profiles")
    w = approximate(ctx.results["working"], s.representation, s.tolerance)
    bar.update(1)
    t = approximate(ctx.results["theoretical"], s.representation, s.tolerance)
    bar.update(1)
    bar.close()
    ctx.results["working_approx"] = w
    ctx.results["theoretical_approx"] = t
    # Where each figure goes: the run fails (exit 1) naming them if the
    # measured deviation exceeds the tolerance (the files still state the
    # measured value, never the tolerance).
    where = {"file": "inner_gear.dxf"}
    ctx.manifest["accuracy"] = {
        "working_profile": {**w.as_dict(), **where, "layer": "WORKING_PROFILE"},
        "theoretical_profile": {**t.as_dict(), **where, "layer": "THEORETICAL_PROFILE"},
    }


def _dxf_files(ctx: RunContext) -> None:
    from corr_cad.export import dxf

    paths = dxf.write_all(
        ctx.scene.design, ctx.results["working_approx"], ctx.results["theoretical_approx"], ctx.out
    )
    ctx.files.extend(p.name for p in paths.values())


def _preview_png(ctx: RunContext) -> None:
    from corr_cad.export import plots

    p = plots.preview_png(
        ctx.scene.design,
        ctx.results["working"],
        ctx.results["theoretical"],
        ctx.out / "preview.png",
    )
    ctx.files.append(p.name)


def _measured(ctx: RunContext) -> None:
    from dataclasses import replace

    from corr_cad.export.measured_io import read_measured_points, write_deviation_dxf
    from corr_cad.tolerance.measured import check_fit, register, validate_points

    s = ctx.scene
    w = ctx.results["working"]
    src = str(s.measured_profile)
    pts = validate_points(read_measured_points(s.measured_profile), w, src)
    reg = register(w, pts)
    check_fit(reg, s.design.eccentricity, src)
    ctx.results["registration"], ctx.results["measured_points"] = reg, pts
    ctx.results["errors"] = replace(s.errors, profile_deviation=reg.deviation)
    ctx.manifest["measured_profile"] = {"source": s.measured_profile.name, **reg.as_dict()}
    ctx.progress(
        f"      registered: rotation {reg.rotation_deg:.4g} deg, centre "
        f"({reg.centre_mm[0]:.4g}, {reg.centre_mm[1]:.4g}) mm, rms {reg.rms_mm:.3g} mm"
    )
    if "dxf" in s.formats:
        write_deviation_dxf(
            s.design,
            w,
            reg.placed,
            reg.point_deviation,
            reg.point_t,
            s.measured_exaggeration,
            ctx.out / "measured_profile.dxf",
            s.tolerance,
        )
        ctx.files.append("measured_profile.dxf")


def _errors(ctx: RunContext):
    """The scene's errors, with a registered measured profile if there is one."""
    return ctx.results.get("errors", ctx.scene.errors)


def _psi_contact_limit(ctx: RunContext) -> float:
    """Rollers beyond the trimmed tooth tips of an allowed undercut find no flank."""
    info = ctx.results["undercut"]
    return math.radians(info.trimmed_psi_deg) if info.undercut and info.trimmed_psi_deg else math.pi


def _forces(ctx: RunContext) -> None:
    s = ctx.scene
    limit = _psi_contact_limit(ctx)
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
        errors=_errors(ctx),
        variants=s.solver.variants,
        psi_contact_limit=limit,
    )
    if not res.success:
        raise SolverError(f"force solver: {res.message}")
    ctx.results["forces"] = res


def _force_files(ctx: RunContext) -> None:
    from corr_cad.export import plots
    from corr_cad.export.files import write_columns, write_json
    from corr_cad.run.console import force_peaks

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
    write_columns(ctx.out / "forces.csv", header, cols, ("%.6f", "%d", "%.6f") + ("%.9g",) * 6)
    summary = res.summary()
    summary["roller"] = 1  # the means and peaks above are roller 1's; "peak" is the drive's
    summary["peak"] = force_peaks(res, s.design)
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
        "contacts_outside_validity": int(np.count_nonzero(~res.valid & res.loaded)),
        "output_torque_Nmm_mean": float(res.output_torque.mean()),
    }
    write_json(ctx.out / "forces_summary.json", summary)
    plots.forces_png(res, ctx.out / "forces.png", s.design, s.load.input_torque)
    # The load distribution where the gear force peaks.
    at = int(np.unravel_index(np.argmax(res.F_n), res.F_n.shape)[0])
    plots.load_distribution_png(
        s.design,
        float(ang[at]),
        res.F_j[at],
        res.F_n[at],
        res.F_s[at],
        ctx.out / "load_distribution.png",
        s.load.input_torque,
        " (peak $F_n$)",
    )
    ctx.files.extend(["forces.csv", "forces_summary.json", "forces.png", "load_distribution.png"])
    ctx.manifest["forces"] = {k: v for k, v in summary.items() if k != "solver"}


def _checks(ctx: RunContext) -> None:
    from corr_cad.tolerance.checks import ARCMIN_PER_RAD, evaluate_checks

    res = ctx.results["forces"]
    values = {
        "peak_gear_force": float(res.F_n.max()),
        "peak_pressure": float(np.maximum(np.maximum(res.p_cam, res.p_slot), res.p_gear).max()),
        "min_loaded_rollers": float(res.loaded_count.min()),
        "lost_motion_arcmin": float(res.lost_motion.max() * ARCMIN_PER_RAD),
    }
    report = evaluate_checks(values, ctx.scene.checks)
    ctx.manifest.setdefault("checks", {}).update(report)
    for name, r in report.items():
        state = "pass" if r["passed"] else "FAIL"
        nums = f"value {r['value']:.4g}, limit {r['limit']:.4g}, margin {r['margin']:.4g}"
        ctx.progress(f"      check {name}: {state} ({nums})")


def _montecarlo(ctx: RunContext) -> None:
    from corr_cad.export import plots
    from corr_cad.export.files import write_columns, write_json
    from corr_cad.run.progress import Progress
    from corr_cad.tolerance.checks import evaluate_failure_probability
    from corr_cad.tolerance.montecarlo import monte_carlo

    s = ctx.scene
    mc_cfg = s.montecarlo
    n = mc_cfg["samples"]
    bar = Progress(n, "      montecarlo", "samples")

    def tick(done: int, total: int) -> None:
        bar.update(done - bar.done)

    res = monte_carlo(
        s.design,
        s.load.input_torque,
        s.tolerances,
        n,
        mc_cfg["seed"],
        mc_cfg["positions"],
        load_share=s.solver.load_share,
        base_errors=_errors(ctx),
        executor=ctx.executor,
        progress=tick,
        psi_contact_limit=_psi_contact_limit(ctx),
    )
    bar.close()
    if not res.success:
        raise SolverError("Monte Carlo: the force solver did not converge for some samples")
    names = list(res.metrics)
    kinds = list(res.magnitudes)
    header = ["sample"] + [f"{k}_magnitude" for k in kinds] + names
    cols = [np.arange(n)] + [res.magnitudes[k] for k in kinds] + [res.metrics[m] for m in names]
    fmts = ["%d"] + ["%.9g"] * (len(cols) - 1)
    write_columns(ctx.out / "montecarlo.csv", header, cols, fmts)
    summary = res.summary(s.checks)
    summary.update({"seed": mc_cfg["seed"], "positions": mc_cfg["positions"]})
    summary["tolerances"] = {k: d.__dict__ for k, d in s.tolerances.items()}
    nominal = _nominal_metrics(ctx, mc_cfg["positions"])
    summary["nominal"] = nominal
    write_json(ctx.out / "montecarlo_summary.json", summary)
    plots.montecarlo_png(
        res.metrics,
        s.checks,
        ctx.out / "montecarlo.png",
        summary,
        nominal,
        s.design,
        s.load.input_torque,
        s.tolerances,
    )
    ctx.files.extend(["montecarlo.csv", "montecarlo_summary.json", "montecarlo.png"])
    ctx.manifest["montecarlo"] = {
        k: summary[k]
        for k in ("samples", "failure_probability", "percentiles", "nominal", "sensitivity")
    }
    gate = evaluate_failure_probability(summary["failure_probability"], s.checks)
    if gate:
        ctx.manifest.setdefault("checks", {})["montecarlo"] = gate
        for name, g in gate.items():
            state = "pass" if g["passed"] else "FAIL"
            ctx.progress(
                f"      check montecarlo {name}: {state} (failure probability "
                f"{g['probability']:.4g}, allowed {g['allowed']:.4g})"
            )


def _nominal_metrics(ctx: RunContext, positions: int) -> dict:
    """The Monte Carlo metrics of the scene's own design and errors (no tolerance drawn)."""
    from corr_cad.mechanics.solver import cycle_angles
    from corr_cad.tolerance.checks import sample_metrics

    s = ctx.scene
    res = solve_forces(
        s.design,
        s.load.input_torque,
        cycle_angles(positions),
        load_share=s.solver.load_share,
        errors=_errors(ctx),
    )
    return {k: float(v[0]) for k, v in sample_metrics(res, 1).items()}


def _allocation(ctx: RunContext) -> None:
    from corr_cad.export.files import write_csv, write_json
    from corr_cad.tolerance.allocation import allocate

    s = ctx.scene
    cfg = s.montecarlo
    kw = {
        "percentile": cfg["percentile"],
        "samples": cfg["allocation_samples"],
        "seed": cfg["seed"],
        "positions": min(cfg["positions"], 72),
        "load_share": s.solver.load_share,
        "executor": ctx.executor,
        "base_errors": _errors(ctx),
        "psi_contact_limit": _psi_contact_limit(ctx),
    }
    d, m0 = s.design, s.load.input_torque
    rows = []
    from corr_cad.run.progress import Progress

    bar = Progress(2 * len(s.tolerances), "      allocation", "searches")
    for kind in s.tolerances:
        # Jointly: the other tolerances as given; alone: the others perfect.
        joint = allocate(d, m0, s.tolerances, s.checks, kind, **kw)
        bar.update(1)
        dist = s.tolerances[kind].kind
        joint["tolerance_alone"] = allocate(d, m0, {}, s.checks, kind, distribution=dist, **kw)[
            "tolerance"
        ]
        bar.update(1)
        rows.append(joint)
    bar.close()

    def fmt(x):
        return "" if x is None else f"{x:.6g}"

    header = ["tolerance", "largest_symmetric_tolerance", "largest_if_others_perfect"]
    header += ["unit", "meaning", "fails_at", "evaluations"]
    table = (
        [r["kind"], fmt(r["tolerance"]), fmt(r["tolerance_alone"]), r["unit"], r["meaning"]]
        + [fmt(r["failing_at"]), str(r["evaluations"])]
        for r in rows
    )
    write_csv(ctx.out / "allocation.csv", header, table)
    write_json(ctx.out / "allocation.json", {"percentile": cfg["percentile"], "rows": rows})
    ctx.files.extend(["allocation.csv", "allocation.json"])
    ctx.manifest["allocation"] = rows
    for r in rows:
        t = "sigma " if r["distribution"] == "normal" else "+- "
        ctx.progress(
            f"      {r['kind']:14s} {t}{r['tolerance']:.4g} {r['unit']} with the others as given, "
            f"{t}{r['tolerance_alone']:.4g} {r['unit']} if the others were perfect"
        )


def _sweeps(ctx: RunContext) -> None:
    from corr_cad.export import plots
    from corr_cad.export.files import write_csv, write_json
    from corr_cad.tolerance.sweeps import (
        METRICS,
        PAPER_SWEEPS,
        comparison_rows,
        is_paper_design,
        run_sweeps,
        sweep_range,
    )

    s = ctx.scene
    ranges = {
        name: sweep_range(s.design, name, s.sweeps.get(name), _errors(ctx)) for name in PAPER_SWEEPS
    }
    from corr_cad.run.progress import Progress

    for name, rng in ranges.items():  # a range the user gave with no valid point is an error
        given = s.sweeps.get(name)
        if given is not None and rng["swept"] is None:
            why = rng.get("clipped_low") or rng.get("clipped_high") or "outside the design space"
            raise SceneError(
                f"[sweeps] {name} = {given!r}: no point of this range is a valid design ({why})"
            )
    total = sum(s.sweeps["points"] for r in ranges.values() if r["swept"] is not None)
    bar = Progress(total, "      sweeps", "points")
    results = run_sweeps(
        s.design,
        s.load.input_torque,
        s.sweeps["points"],
        s.sweeps["positions"],
        s.solver.load_share,
        executor=ctx.executor,
        ranges=ranges,
        progress=bar.update,
    )
    bar.close()
    header = ["value", "status", *METRICS, "loaded_rollers_min", "loaded_rollers_max"]
    header += ["range_source", "requested_min", "requested_max", "clipped_low", "clipped_high"]
    for name, pts in results.items():
        rng = ranges[name]
        limits = [rng["source"], *(f"{v:.6g}" for v in rng["requested"])]
        limits += [rng["clipped_low"] or "", rng["clipped_high"] or ""]
        write_csv(
            ctx.out / f"sweep_{name}.csv",
            header,
            (
                [f"{p['value']:.6g}", p["status"]]
                + [f"{p[k]:.6g}" if k in p else "" for k in header[2:-5]]
                + limits
                for p in pts
            ),
        )
        plots.sweep_png(
            name, pts, ctx.out / f"sweep_{name}.png", rng, s.design, s.load.input_torque
        )
        ctx.files.extend([f"sweep_{name}.csv", f"sweep_{name}.png"])
        lim = "; ".join(
            f"{side} end clipped at {v:.5g} mm ({why})"
            for side, v, why in (
                ("low", (rng["swept"] or [None])[0], rng["clipped_low"]),
                ("high", (rng["swept"] or [None, None])[-1], rng["clipped_high"]),
            )
            if why and v is not None
        )
        ctx.progress(
            f"      sweep {name} {rng['requested'][0]:g}..{rng['requested'][1]:g} mm "
            f"({rng['source']}): {sum(p['status'] == 'ok' for p in pts)}/{len(pts)} points solved"
            + (f"; {lim}" if lim else "")
            + ("; no valid value in the range" if rng["swept"] is None else "")
        )
    out = {"ranges": ranges, "points": results}
    if is_paper_design(s.design):
        rows = comparison_rows(results, ranges)
        cols = list(rows[0]) if rows else []
        write_csv(
            ctx.out / "sweeps_vs_paper.csv", cols, ([_cell(r[c]) for c in cols] for r in rows)
        )
        ctx.files.append("sweeps_vs_paper.csv")
        out["vs_paper"] = rows
    write_json(ctx.out / "sweeps.json", out)
    ctx.files.append("sweeps.json")
    ctx.manifest["sweeps"] = {
        n: {
            "range": ranges[n],
            "points": len(pts),
            "solved": sum(p["status"] == "ok" for p in pts),
        }
        for n, pts in results.items()
    }


def _cell(v) -> str:
    if v is None:
        return ""
    return f"{v:.6g}" if isinstance(v, float) else str(v)


def _report(ctx: RunContext) -> None:
    from corr_cad.export.report import write_report

    path = write_report(ctx.scene, ctx.manifest, ctx.results, list(ctx.files), ctx.out)
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
        Stage("report", (), _report, "report.html (runs last, reads what the run made)"),
    )
}

#: Which stage produces each ``[export] formats`` entry.
FORMAT_TARGETS = {
    "dxf": "dxf_files",
    "png": "preview_png",
    "forces": "force_files",
    **{f: "mesh_files" for f in ("stl", "3mf", "glb", "ply")},
    "step": "step_files",
    "interference": "interference",
    "montecarlo": "montecarlo",
    "allocation": "allocation",
    "sweeps": "sweeps",
    **{"edm": "edm_files", "cmm": "cmm_points", "inspection": "inspection"},
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
) -> list[str]:
    """Stages needed for ``formats`` (and the checks), in dependency order, each once.

    With a measured profile it is registered first: the forces, Monte Carlo
    and checks then see it as a gear-profile deviation.
    """
    order: list[str] = []

    def visit(name: str) -> None:
        if name in order:
            return
        for dep in STAGES[name].requires:
            visit(dep)
        order.append(name)

    if measured:
        visit("measured_profile")
    for f in sorted(formats, key=lambda f: FORMAT_TARGETS[f] in _LATE):
        if f == "interference":
            for name in INTERFERENCE_STAGES[interference_method]:
                visit(name)
        else:
            visit(FORMAT_TARGETS[f])
    if checks:
        visit("checks")
    if "report" in order:  # the report reads everything the others made
        order.remove("report")
        order.append("report")
    return order


#: Distributions whose build can change an output's bytes: the numerical core
#: (numpy, scipy, numba, llvmlite), the exporters and what they write with
#: (Pillow encodes the PNGs, lxml and networkx the 3MF, jinja2 the report),
#: and Open CASCADE under either of its wheel names.
VERSIONED_PACKAGES = (
    "numpy",
    "scipy",
    "numba",
    "llvmlite",
    "ezdxf",
    "shapely",
    "trimesh",
    "manifold3d",
    "matplotlib",
    "pillow",
    "lxml",
    "networkx",
    "jinja2",
    "cadquery-ocp-novtk",
    "cadquery-ocp",
)


def _versions() -> dict:
    """Python, corr_cad and every package in ``VERSIONED_PACKAGES`` (None: absent).

    The determinism promise is stated against this record: the same scene and
    the same versions (on the same kind of processor) give the same bytes.
    """
    out = {"corr_cad": __version__, "python": platform.python_version()}
    for pkg in VERSIONED_PACKAGES:
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


def _run_stages(ctx: RunContext, stages: list[str], concurrent: bool) -> list[dict]:
    """Run ``stages`` in order (some in a pool worker if ``concurrent``); their timings."""
    from corr_cad.run.concurrent import kill_pool, run_stage_in_worker, worker_stages

    pending = {}
    if concurrent and ctx.executor is not None:
        for name in worker_stages(stages):
            pending[name] = ctx.executor.submit(run_stage_in_worker, ctx.scene, str(ctx.out), name)
    timings: dict[str, dict] = {}
    joined: set[str] = set()

    def join() -> None:  # manifest.json is key-sorted: the sections' order does not matter
        for name, fut in pending.items():
            if name not in joined:
                sections, files, seconds = fut.result()
                joined.add(name)
                ctx.manifest.update(sections)
                ctx.files.extend(files)
                timings[name] = {"name": name, "seconds": round(seconds, 6), "worker": True}

    try:
        for i, name in enumerate(stages, 1):
            if name in pending:
                ctx.progress(f"[{i}/{len(stages)}] {name}: {STAGES[name].doc} (in a worker)")
                continue
            if name == "report":  # it reads what every other stage made
                join()
            ctx.progress(f"[{i}/{len(stages)}] {name}: {STAGES[name].doc}")
            t0 = time.perf_counter()
            STAGES[name].run(ctx)
            timings[name] = {"name": name, "seconds": round(time.perf_counter() - t0, 6)}
        join()
    except BaseException:
        if any(not f.done() for f in pending.values()):
            # Before the caller removes the staging folder: no worker may write
            # into it afterwards.
            kill_pool(ctx.executor)
        raise
    return [timings[name] for name in stages]


def run_scene(
    scene: Scene,
    out: Path,
    progress: Callable[[str], None] | None = None,
    executor=None,
    concurrent_stages: bool = False,
) -> dict:
    """Run the stages ``scene`` needs, writing into ``out`` (a staging folder).

    Returns the manifest (also written as ``manifest.json``). The CLI wraps
    this in a staging folder that it swaps in when everything is written.
    With ``concurrent_stages`` (``executor`` must then be a process pool),
    the STEP export runs in a pool worker beside the other stages
    (:mod:`corr_cad.run.concurrent`); the files and the manifest are
    the same as in a serial run, but for the ``stages`` timings.

    >>> import tempfile, pathlib
    >>> from corr_cad import GearDesign, run_scene
    >>> from corr_cad.run.scene import Scene
    >>> out = pathlib.Path(tempfile.mkdtemp())
    >>> m = run_scene(Scene(name="demo", design=GearDesign(), formats=("dxf",)), out)
    >>> sorted(m["files"])
    ['disk_cam.dxf', 'inner_gear.dxf', 'roller.dxf', 'teeth_frame.dxf']
    >>> m["accuracy"]["working_profile"]["max_deviation_mm"] <= 0.001
    True
    """
    from corr_cad.export.files import sha256_of, write_json
    from corr_cad.run.outputs import GENERATOR

    ctx = RunContext(
        scene=scene, out=Path(out), progress=progress or (lambda m: None), executor=executor
    )
    stages = plan(
        scene.formats,
        checks=bool(scene.checks.active()),
        measured=scene.measured_profile is not None,
        interference_method=scene.interference_method,
    )
    from corr_cad.run.resources import estimate

    est = estimate(scene)
    if est.memory_bytes or est.seconds:
        mem = max(est.memory_bytes.values(), default=0.0)
        work = ", ".join(f"{k} ~{v:.2g} s" for k, v in est.seconds.items())
        ctx.progress(
            f"estimate: peak memory ~{mem / 2**20:.0f} MB (budget 2048 MB)"
            + (f"; solver work {work}" if work else "")
        )
    timings = _run_stages(ctx, stages, concurrent_stages)
    files = {
        name: {"sha256": sha256_of(ctx.out / name), "bytes": (ctx.out / name).stat().st_size}
        for name in sorted(ctx.files)
    }
    manifest = {
        "generator": GENERATOR,
        "complete": True,  # the commit (outputs.StagingDir) writes false while moving files
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
