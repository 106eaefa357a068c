"""Run heavy, independent stages in a pool worker while the main process runs the rest.

The STEP export (Open CASCADE: its import alone takes about a second, then
writing and reading back every file) needs nothing from the meshes, plots or
forces, and they need nothing from it. With a process pool of two or more
workers (``--executor process``, the default, on a machine with two cores
or more), ``run_scene`` submits it to the pool first and runs the other
stages meanwhile; the worker writes into the same staging folder, so the
commit (``outputs.StagingDir``) sees one set of files, as in a serial run.

What stays as in a serial run:

* the bytes of every file (the worker runs the same stage function on the
  same scene; nothing in it depends on the process);
* ``manifest.json`` (written key-sorted), byte for byte but for the
  ``seconds`` of each stage: the worker returns the manifest sections its
  stage wrote; ``stages`` lists every stage in plan order with its time and
  nothing else (where it ran is shown on the progress line only);
* errors: an error in the worker is raised in the main process, where the
  CLI reports it as it would have;
* interruption: if the main process fails or is interrupted (SIGINT,
  SIGTERM) while a worker stage runs, the pool's processes are killed and
  waited for *before* the staging folder is removed (so no worker writes
  into it afterwards); SIGKILL of the main process kills the workers through
  ``pools._worker_init`` (``PR_SET_PDEATHSIG``).

``--executor serial``, ``--workers 1`` and Dask run every stage in the main
process.
"""

from __future__ import annotations

import time
from pathlib import Path

from corr_cad.run.stages.context import RunContext
from corr_cad.run.stages.stages import STAGES

__all__ = [
    "WORKER_STAGES",
    "worker_stages",
    "run_stage_in_worker",
    "kill_pool",
    "make_ahead",
]

#: Stages that may run in a pool worker: heavy, and independent of every other
#: target stage (they need only the cheap profile stages, which the worker
#: repeats).
WORKER_STAGES = ("step_files",)


def _closure(name: str) -> list[str]:
    """``name`` and what it needs, in dependency order."""
    order: list[str] = []

    def visit(n: str) -> None:
        if n in order:
            return
        for dep in STAGES[n].requires:
            visit(dep)
        order.append(n)

    visit(name)
    return order


def worker_stages(stages: list[str]) -> tuple[str, ...]:
    """Which of the planned ``stages`` are worth a worker: a worker stage with other work beside it.

    >>> worker_stages(["undercut", "profiles", "step_files"])
    ()
    >>> worker_stages(["undercut", "profiles", "preview_png", "step_files"])
    ('step_files',)
    """
    picked = tuple(s for s in stages if s in WORKER_STAGES)
    needed = {d for s in picked for d in _closure(s)}
    return picked if any(s not in needed for s in stages) else ()


def run_stage_in_worker(scene, out: str, name: str) -> tuple[dict, list[str], float]:
    """Run stage ``name`` (after what it needs) into the folder ``out``; in a pool worker.

    Returns the manifest sections the stage itself wrote, the files it wrote
    and its time in seconds.
    """
    ctx = RunContext(scene=scene, out=Path(out))
    *deps, _ = _closure(name)
    for dep in deps:
        STAGES[dep].run(ctx)
    before = set(ctx.manifest)
    t0 = time.perf_counter()
    STAGES[name].run(ctx)
    seconds = time.perf_counter() - t0
    sections = {k: v for k, v in ctx.manifest.items() if k not in before}
    return sections, list(ctx.files), seconds


def make_ahead(scene) -> None:
    """Before the pool forks its workers: what a worker stage needs and the main
    process makes anyway, made once here so that the workers inherit it.

    The first stage's gear outlines (:func:`~corr_cad.geometry.gear_outline.approximate_gear`,
    kept per process): the STEP stage's exact volumes and the main process's
    DXF, solids and drive stages read the same ones, at the scene's tolerance.
    """
    fs = scene.first_stage
    if fs is None or "step" not in scene.formats or scene.chord_tolerance != scene.tolerance:
        return
    from corr_cad.geometry.gear_outline import approximate_gear

    for part in ("pinion", "wheel", "crank_gear"):
        approximate_gear(getattr(fs, part), scene.tolerance)


def kill_pool(pool) -> None:
    """Kill a process pool's workers now and wait for them (no more writes from them)."""
    procs = list((getattr(pool, "_processes", None) or {}).values())
    pool.shutdown(wait=False, cancel_futures=True)
    for p in procs:
        p.kill()
    for p in procs:
        p.join(5)
