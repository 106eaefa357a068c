"""The run pipeline: plan the stages a scene needs, run them, write the manifest.

The stage graph is :mod:`corr_cad.run.stages.stages`; the stage bodies live there
by concept. :func:`run_scene` runs the planned stages in order (the STEP
export in a pool worker when asked, :mod:`corr_cad.run.stages.concurrent`) and
writes ``manifest.json``.
"""

from __future__ import annotations

import math
import platform
import time
from collections.abc import Callable
from dataclasses import dataclass
from importlib import metadata
from pathlib import Path

import numpy as np

from corr_cad._version import __version__
from corr_cad.run import interrupts
from corr_cad.run.scene.scene import Scene
from corr_cad.run.stages.context import RunContext
from corr_cad.run.stages.stages import FORMAT_TARGETS, STAGES, plan
from corr_cad.run.stages.stages_geometry import (  # noqa: F401  (re-exported)
    MESH_FORMATS,
    PART_NAMES,
    interference_allowance,
)

__all__ = [
    "STAGES",
    "FORMAT_TARGETS",
    "plan",
    "scene_plan",
    "run_scene",
    "RunContext",
    "StageFailure",
]


@dataclass(frozen=True)
class StageFailure:
    """Where an unexpected exception left :func:`run_scene` (for the CLI's one line).

    Set as the attribute ``corr_cad_failure`` of an exception that is no
    :class:`~corr_cad.errors.CorrCadError` and no ``OSError`` (a bug, not a
    refusal): ``stage`` the stage that raised (``"manifest"`` after the
    last stage), ``finished`` the stages done before it, ``files`` how many
    files they had staged. The exception keeps its type and message.
    """

    stage: str
    finished: tuple[str, ...]
    files: int


def _note_failure(exc: BaseException, stage: str, finished, files: int) -> None:
    """Record where an unexpected exception came from (the first place only)."""
    from concurrent.futures import BrokenExecutor

    from corr_cad.errors import CorrCadError

    if not isinstance(exc, Exception) or isinstance(exc, (CorrCadError, OSError, BrokenExecutor)):
        return
    if getattr(exc, "corr_cad_failure", None) is None:
        try:
            exc.corr_cad_failure = StageFailure(stage, tuple(finished), files)
        except (AttributeError, TypeError):  # an exception type without a __dict__
            pass


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
    from corr_cad.run.progress import close_all, heartbeat
    from corr_cad.run.stages.concurrent import kill_pool, run_stage_in_worker, worker_stages
    from corr_cad.run.stages.context import expected_seconds

    pending = {}
    if concurrent and ctx.executor is not None:
        for name in worker_stages(stages):
            pending[name] = ctx.executor.submit(run_stage_in_worker, ctx.scene, str(ctx.out), name)
    timings: dict[str, dict] = {}
    joined: set[str] = set()
    current = [stages[0] if stages else "manifest"]

    def join() -> None:  # manifest.json is key-sorted: the sections' order does not matter
        for name, fut in pending.items():
            if name not in joined:
                current[0] = name
                with heartbeat(f"      {name} (in a worker)", None):
                    sections, files, seconds = fut.result()
                joined.add(name)
                ctx.manifest.update(sections)
                ctx.files.extend(files)
                # Where a stage ran is not recorded: manifest.json is the same
                # bytes for every executor but for the seconds (the progress
                # line says "(in a worker)").
                timings[name] = {"name": name, "seconds": round(seconds, 6)}

    try:
        for i, name in enumerate(stages, 1):
            interrupts.check()  # an interrupt swallowed in the last stage stops the run here
            if name in pending:
                ctx.progress(f"[{i}/{len(stages)}] {name}: {STAGES[name].doc} (in a worker)")
                continue
            if name == "report":  # it reads what every other stage made
                join()
            current[0] = name
            ctx.progress(f"[{i}/{len(stages)}] {name}: {STAGES[name].doc}")
            t0 = time.perf_counter()
            try:
                with heartbeat(f"      {name}", expected_seconds(ctx, name)):
                    STAGES[name].run(ctx)
            finally:
                close_all()  # no counter of a stage that raised goes on printing
            timings[name] = {"name": name, "seconds": round(time.perf_counter() - t0, 6)}
        join()
    except BaseException as exc:
        _note_failure(exc, current[0], [n for n in stages if n in timings], len(ctx.files))
        if any(not f.done() for f in pending.values()):
            # Before the caller removes the staging folder: no worker may write
            # into it afterwards.
            kill_pool(ctx.executor)
        if ctx.plotter is not None:  # nor a plot worker (a drawing of the failed stage)
            kill_pool(ctx.plotter)
        raise
    return [timings[name] for name in stages]


def scene_plan(scene: Scene) -> list[str]:
    """The stages a run of ``scene`` runs, in order (:func:`~corr_cad.run.stages.stages.plan`)."""
    return plan(
        scene.formats,
        checks=bool(scene.checks.active()),
        measured=scene.measured_profile is not None or scene.measured_profile_b is not None,
        interference_method=scene.interference_method,
        datasheet_checks=bool(scene.checks.datasheet_active()),
        first_stage=scene.first_stage is not None,
    )


def _executor_kind(executor) -> str:
    if executor is None:
        return "serial"
    return "dask" if hasattr(executor, "scheduler_info") else "process"


def run_scene(
    scene: Scene,
    out: Path,
    progress: Callable[[str], None] | None = None,
    executor=None,
    concurrent_stages: bool = False,
    budget=None,
    estimate=None,
    plotter=None,
) -> dict:
    """Run the stages ``scene`` needs, writing into ``out`` (a staging folder).

    Returns the manifest (also written as ``manifest.json``). The CLI wraps
    this in a staging folder that it swaps in when everything is written.
    With ``concurrent_stages`` (``executor`` must then be a process pool),
    the STEP export runs in a pool worker beside the other stages
    (:mod:`corr_cad.run.stages.concurrent`); the files and the manifest are
    the same as in a serial run, but for the ``stages`` timings.
    ``budget`` (:class:`~corr_cad.run.budget.resources.Budget`, default the scene's
    ``[budget]``) and its ``estimate``: without an estimate the scene is
    checked against the budget first (:func:`~corr_cad.run.budget.resources.check_scene`).
    ``plotter``: plot workers (:func:`~corr_cad.run.stages.plot_workers.plot_pool`) that
    draw some stages' PNGs; the same bytes as drawn here.

    >>> import tempfile, pathlib
    >>> from corr_cad import GearDesign, run_scene
    >>> from corr_cad.run.scene.scene import Scene
    >>> out = pathlib.Path(tempfile.mkdtemp())
    >>> m = run_scene(Scene(name="demo", design=GearDesign(), formats=("dxf",)), out)
    >>> sorted(m["files"])
    ['disk_cam.dxf', 'inner_gear.dxf', 'roller.dxf', 'teeth_frame.dxf']
    >>> m["accuracy"]["working_profile"]["max_deviation_mm"] <= 0.001
    True
    """
    ctx = RunContext(
        scene=scene,
        out=Path(out),
        progress=progress or (lambda m: None),
        executor=executor,
        plotter=plotter,
    )
    stages = scene_plan(scene)
    from corr_cad.run.budget.resources import budget_for, check_scene

    budget = budget or budget_for(scene)
    if estimate is None:  # called from Python: the same budget check as the CLI's
        estimate = check_scene(scene, budget=budget, executor=_executor_kind(executor))
    ctx.progress(estimate.line(budget))
    ctx.estimate = estimate
    ctx.budget = budget
    timings = _run_stages(ctx, stages, concurrent_stages)
    try:
        return _write_manifest(ctx, scene, timings)
    except BaseException as exc:
        _note_failure(exc, "manifest", stages, len(ctx.files))
        raise


def _write_manifest(ctx: RunContext, scene: Scene, timings: list[dict]) -> dict:
    """``manifest.json`` of a run whose stages all succeeded; returns its content."""
    from corr_cad.export.files import sha256_of, write_json
    from corr_cad.run.folder.outputs import GENERATOR

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
        **({"formats_left_out": dict(scene.formats_left_out)} if scene.formats_left_out else {}),
        "versions": _versions(),
        "units": {
            "length": "mm",
            "force": "N",
            "torque": "N*mm",
            "pressure": "MPa",
            "angle": "deg",
        },
        **({"first_stage": scene.first_stage.as_dict()} if scene.first_stage else {}),
        **ctx.manifest,
        "files": files,
        "stages": timings,
    }
    manifest = _clean(manifest)
    write_json(ctx.out / "manifest.json", manifest)
    return manifest
