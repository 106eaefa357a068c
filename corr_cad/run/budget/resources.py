"""Memory, time and output estimates of a whole run, checked against a budget before any work.

Every size a scene can set has a static upper bound in the scene schema; on
top of that :func:`estimate` adds up what each planned stage needs
(:mod:`corr_cad.run.budget.costs`, one estimator per stage) and :func:`check_scene`
refuses a run that would pass its budget, with one line naming the key, a
value that fits and the override:

* memory: the main process's peak (the interpreter, the libraries the
  stages import, what earlier stages keep, the largest stage) plus the pool
  workers of this machine; default 3 GB (``--max-memory`` or
  ``[budget] memory_gb``), never more than the machine's memory;
* output: the bytes of every file the run writes; default 1 GB
  (``--max-output``, ``[budget] output_gb``);
* time: a warning (the run still starts) beyond 60 s (``--warn-time``,
  ``[budget] time_warning_s``).

The two structural limits (a DXF profile of more than
``MAX_PROFILE_VERTICES`` vertices, the approximator's own budget, and a mesh
of more than ``MAX_MESH_TRIANGLES`` triangles) are :mod:`corr_cad.run.scene.limits`,
checked at load time.
"""

from __future__ import annotations

import functools
import math
import os
from dataclasses import dataclass, replace

from corr_cad.bounds import show
from corr_cad.errors import SceneError
from corr_cad.run.budget.costs import ESTIMATORS, LIBRARY_BYTES, WORKER_BYTES, Cost, Env
from corr_cad.run.budget.costs_bodies import reduce_once
from corr_cad.run.scene.limits import (  # noqa: F401  (re-exported: the limits are part of this interface)
    MAX_MESH_TRIANGLES,
    MAX_PROFILE_VERTICES,
    SceneSize,
    check_structure,
    mesh_triangles,
    polyline_segments,
    profile_vertices,
    round_up,
    scene_size,
)
from corr_cad.run.scene.scene_schema import SCHEMA

__all__ = [
    "DEFAULT_MEMORY_GB",
    "DEFAULT_OUTPUT_GB",
    "DEFAULT_TIME_WARNING_S",
    "MAX_PROFILE_VERTICES",
    "MAX_MESH_TRIANGLES",
    "Budget",
    "Estimate",
    "budget_for",
    "polyline_segments",
    "estimate",
    "check_scene",
    "check_disk",
    "time_warning",
    "default_workers",
    "machine_memory",
]

DEFAULT_MEMORY_GB = 3.0
DEFAULT_OUTPUT_GB = 1.0
DEFAULT_TIME_WARNING_S = 60.0
GB = 1024.0**3
#: Interpreter, numpy, scipy and corr_cad (83 MB measured), and the design's
#: own tables (~50 kB a tooth: 134 MB at z = 1000).
BASE_BYTES = 100 * 1024**2
BASE_BYTES_PER_TOOTH = 60e3
#: Starting Python and importing numpy, scipy and corr_cad, s.
STARTUP_S = 2.5


def default_workers() -> int:
    """Processes a default pool starts (the usable cores)."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # pragma: no cover - not Linux
        return max(1, os.cpu_count() or 1)


def machine_memory() -> float:
    """Bytes of physical memory of this machine (inf if unknown)."""
    try:
        return float(os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES"))
    except (ValueError, OSError, AttributeError):  # pragma: no cover
        return math.inf


@dataclass(frozen=True)
class Budget:
    """The limits a run is checked against, and what set each (for the messages)."""

    memory_bytes: float = DEFAULT_MEMORY_GB * GB
    output_bytes: float = DEFAULT_OUTPUT_GB * GB
    warn_seconds: float = DEFAULT_TIME_WARNING_S
    memory_from: str = "default"
    output_from: str = "default"
    warn_from: str = "default"


def budget_for(
    scene, memory_gb: float | None = None, output_gb: float | None = None, warn_s=None
) -> Budget:
    """The scene's ``[budget]`` with the command line's overrides (``--max-memory`` ...)."""
    b = getattr(scene, "budget", None) or {}

    def pick(flag, flag_name, key, default):
        if flag is not None:
            return float(flag), flag_name
        if b.get(key) is not None:
            return float(b[key]), f"[budget] {key}"
        return default, "default"

    mem, mem_from = pick(memory_gb, "--max-memory", "memory_gb", DEFAULT_MEMORY_GB)
    out, out_from = pick(output_gb, "--max-output", "output_gb", DEFAULT_OUTPUT_GB)
    warn, warn_from = pick(warn_s, "--warn-time", "time_warning_s", DEFAULT_TIME_WARNING_S)
    if mem * GB > machine_memory():
        raise SceneError(
            f"{mem_from} {mem:g}: more than this machine's {machine_memory() / GB:.3g} GB of "
            f"memory; at most {math.floor(machine_memory() / GB * 10) / 10:g}"
        )
    return Budget(mem * GB, out * GB, warn, mem_from, out_from, warn_from)


@dataclass(frozen=True)
class Estimate:
    """What a scene's run is expected to need."""

    #: Stage name -> its cost, in plan order.
    stages: dict[str, Cost]
    #: Peak bytes of the run: the main process plus the pool workers.
    memory: float
    main_memory: float
    worker_memory: float
    #: The stage at whose peak ``memory`` is reached.
    peak_stage: str
    seconds: float
    #: File (or pattern) -> bytes, and their sum.
    output: dict[str, float]
    output_bytes: float
    profile_vertices: float
    mesh_triangles: float
    workers: int

    def as_dict(self) -> dict:
        return {
            "memory_bytes": self.memory,
            "main_memory_bytes": self.main_memory,
            "worker_memory_bytes": self.worker_memory,
            "peak_stage": self.peak_stage,
            "seconds": self.seconds,
            "output_bytes": self.output_bytes,
            "stages": {
                n: {"memory_bytes": c.memory, "seconds": c.seconds, "output_bytes": _sum(c)}
                for n, c in self.stages.items()
            },
        }

    def line(self, budget: Budget) -> str:
        """``estimate: peak memory ~..., files ~..., time ~...`` for the run's first lines."""
        slow = sorted(self.stages.items(), key=lambda kv: -kv[1].seconds)[:3]
        parts = ", ".join(f"{n} {_duration(c.seconds)}" for n, c in slow if c.seconds >= 1.0)
        from corr_cad.run.progress import load_factor

        factor, load, cpus = load_factor(self.workers)
        busy = ""
        if factor >= 1.25:  # the machine is busy: the time it will take now, said as such
            busy = (
                f" on a quiet machine, ~{_duration(self.seconds * factor)} at the present load "
                f"(load average {load:.1f} on {cpus} CPUs)"
            )
        return (
            f"estimate: peak memory ~{_mb(self.memory)} (budget {_mb(budget.memory_bytes)}), "
            f"files ~{_mb(self.output_bytes)} (budget {_mb(budget.output_bytes)}), "
            f"time ~{_duration(self.seconds)}" + (f" ({parts})" if parts else "") + busy
        )


def _sum(c: Cost) -> float:
    return float(sum(c.output.values()))


def _mb(x: float) -> str:
    return f"{x / 1024**2:.0f} MB" if x < 10 * GB else f"{x / GB:.3g} GB"


def _duration(s: float) -> str:
    from corr_cad.run.progress import duration

    return duration(s)


def _env(scene, workers: int, executor: str, sizes: SceneSize) -> Env:
    # The meshes and the STEP ring: sizes holds their counts exactly where the
    # plan has solids, step_files or the mesh interference (0 elsewhere).
    size, is_dxf, lines, kept = _measured_file(scene.measured_profile)
    size_b, is_dxf_b, lines_b, kept_b = _measured_file(getattr(scene, "measured_profile_b", None))
    local = workers if executor == "process" else 0
    return Env(
        workers=1 if executor == "serial" else workers,
        local_workers=local,
        remote=executor == "dask",
        triangles=sizes.mesh_triangles,
        part_triangles=sizes.part_triangles,
        vertices=sizes.profile_vertices,
        spline_points=sizes.spline_points,
        measured_bytes=size,
        measured_dxf=is_dxf,
        measured_lines=lines,
        measured_kept=kept,
        measured_b_bytes=size_b,
        measured_b_dxf=is_dxf_b,
        measured_b_lines=lines_b,
        measured_b_kept=kept_b,
    )


def _measured_file(path) -> tuple[int, bool, int, int]:
    """A measured profile's size in bytes (0: none, or unreadable: the stage reports it),
    whether it is a DXF, and a CSV's lines and kept points (0, 0 otherwise)."""
    if path is None:
        return 0, False, 0, 0
    try:
        st = os.stat(path)
    except OSError:
        return 0, False, 0, 0
    name = str(path).lower()
    is_dxf = name.endswith(".dxf")
    lines = kept = 0
    if st.st_size and not (is_dxf or name.endswith((".stl", ".ply"))):
        lines, kept = _csv_points(str(path), st.st_size, st.st_mtime_ns)
    return st.st_size, is_dxf, lines, kept


@functools.lru_cache(maxsize=8)
def _csv_points(path: str, size: int, mtime_ns: int) -> tuple[int, int]:
    """A measured CSV's lines and kept points, counted once per file version (the
    refusal's search estimates a scene many times)."""
    from corr_cad.export.measured_io import csv_points_kept

    return csv_points_kept(path)


def _unknown(scene, env) -> Cost:
    """A stage with no estimator of its own (tests/test_bounds.py asks every stage for one)."""
    return Cost(memory=200 * 1024**2, seconds=5.0, output={"other files": 50 * 1024**2})


def _stages(scene) -> list[str]:
    from corr_cad.run.stages.stages import plan

    return plan(
        scene.formats,
        checks=bool(scene.checks.active()),
        measured=scene.measured_profile is not None or scene.measured_profile_b is not None,
        interference_method=scene.interference_method,
        datasheet_checks=bool(scene.checks.datasheet_active()),
        first_stage=scene.first_stage is not None,
    )


#: A plot worker (:mod:`corr_cad.run.stages.plot_workers`): its own pages at their peak
#: (its copied pages, matplotlib's objects, a canvas; the libraries counted as the run's):
#: 65 MB drawing ``montecarlo.png``, 78 MB the datasheet's two (unique set size), a margin.
PLOT_WORKER_BYTES = 90 * 1024.0**2


def _samples_here(scene, aside: set) -> bool:
    """Does ``corr-cad run`` solve the Monte Carlo's samples in the main process (no pool
    started: few samples, :func:`~corr_cad.run.budget.costs_montecarlo.pool_pays`, and no
    other stage that needs the pool)?"""
    from corr_cad.run.budget.costs_montecarlo import pool_pays

    others = {"allocation", "sweeps", "sizing"} & set(scene.formats)
    return not pool_pays(scene) and not others and not aside


def estimate(scene, workers: int | None = None, executor: str = "process") -> Estimate:
    """Memory, time, output, vertex and triangle estimates of ``scene``'s run.

    ``executor``: ``process`` (a pool of ``workers`` on this machine, the
    default), ``serial`` or ``dask`` (the samples solved elsewhere).
    """
    from corr_cad.run.stages.concurrent import worker_stages
    from corr_cad.run.stages.plot_workers import plot_plan

    workers = workers or default_workers()
    stages = _stages(scene)
    sizes = scene_size(scene)  # computed once per scene, with the structural check
    env = _env(scene, workers, executor, sizes)
    costs = {name: ESTIMATORS.get(name, _unknown)(scene, env) for name in stages}
    reduce_once(scene, costs)
    aside = set()
    if executor == "process" and workers >= 2:
        aside = set(worker_stages(stages))
    if executor == "process" and "montecarlo" in costs and _samples_here(scene, aside):
        costs["montecarlo"] = ESTIMATORS["montecarlo"](
            scene, replace(env, workers=1, local_workers=0)
        )
    libs = {lib for n, c in costs.items() if n not in aside for lib in c.libraries}
    base = BASE_BYTES + BASE_BYTES_PER_TOOTH * scene.design.tooth_count
    base += sum(LIBRARY_BYTES[lib] for lib in libs)
    kept, main, peak_stage = 0.0, base, stages[0] if stages else ""
    for name, c in costs.items():
        if name in aside:
            continue
        if base + kept + c.memory > main:
            main, peak_stage = base + kept + c.memory, name
        kept += c.keeps
    workers_mem = max((c.workers for c in costs.values()), default=0.0)
    plotters = plot_plan(stages, workers if executor == "process" else 0)[0]
    workers_mem += plotters * PLOT_WORKER_BYTES
    for name in aside:  # a pool worker repeats the profile stages, then runs this one
        c = costs[name]
        own = sum(LIBRARY_BYTES[lib] for lib in c.libraries)
        workers_mem += WORKER_BYTES + own + c.memory + costs["profiles"].keeps
    output: dict[str, float] = {}
    for c in costs.values():
        for k, v in c.output.items():
            output[k] = output.get(k, 0.0) + v
    seconds = STARTUP_S + sum(c.seconds for c in costs.values())
    tri = env.triangles if {"solids", "step_files"} & set(stages) else 0.0
    return Estimate(
        stages=costs,
        memory=main + workers_mem,
        main_memory=main,
        worker_memory=workers_mem,
        peak_stage=peak_stage,
        seconds=seconds,
        output=output,
        output_bytes=float(sum(output.values())),
        profile_vertices=sizes.profile_vertices if "dxf" in scene.formats else 0.0,
        mesh_triangles=tri,
        workers=env.workers,
    )


# --- the keys a refusal can name, and how to change them ------------------------------
def _set(section: str, key: str):
    def setter(s, v):
        return replace(s, **{section: {**getattr(s, section), key: v}})

    return setter


def _get(section: str, key: str):
    def getter(s):
        return getattr(s, section)[key]

    return getter


#: Scene key -> (get, set, integer, larger is cheaper, largest allowed).
KNOBS = {
    "[solver] positions": (
        lambda s: s.solver.positions,
        lambda s, v: replace(s, solver=replace(s.solver, positions=v)),
        True,
        False,
        None,
    ),
    "[solver] crank_angles_deg": (
        lambda s: len(s.solver.crank_angles_deg),
        lambda s, v: replace(
            s, solver=replace(s.solver, crank_angles_deg=s.solver.crank_angles_deg[:v])
        ),
        True,
        False,
        None,
    ),
    "[export] interference_positions": (
        lambda s: s.positions_for("mesh" if s.interference_method == "mesh" else "exact"),
        lambda s, v: replace(s, interference_positions=v),
        True,
        False,
        None,
    ),
    "[export] assembly_angles_deg": (
        lambda s: len(s.assembly_angles_deg),
        lambda s, v: replace(s, assembly_angles_deg=s.assembly_angles_deg[:v]),
        True,
        False,
        None,
    ),
    "[export] chord_tolerance": (
        lambda s: s.chord_tolerance,
        lambda s, v: replace(s, chord_tolerance=v),
        False,
        True,
        10.0,
    ),
    "[export] tolerance": (
        lambda s: s.tolerance,
        lambda s, v: replace(s, tolerance=v),
        False,
        True,
        10.0,
    ),
    "[assembly] roller_classes_um": (
        lambda s: len(s.assembly["roller_classes_um"]),
        lambda s, v: replace(
            s,
            assembly={**s.assembly, "roller_classes_um": s.assembly["roller_classes_um"][:v]},
        ),
        True,
        False,
        None,
    ),
    "[inspection] point_spacing": (
        lambda s: s.inspection["point_spacing"],
        _set("inspection", "point_spacing"),
        False,
        True,
        100.0,
    ),
    **{
        f"[{sec}] {key}": (
            _get(sec, key),
            _set(sec, key),
            True,
            False,
            None,
        )
        for sec, key in (
            ("montecarlo", "samples"),
            ("montecarlo", "positions"),
            ("montecarlo", "allocation_samples"),
            ("sweeps", "points"),
            ("sweeps", "positions"),
            ("datasheet", "positions_per_mesh"),
            ("datasheet", "transmission_error_positions_per_turn"),
            ("sizing", "evaluations"),
        )
    },
    **{
        f"[modification.design] {key}": (
            _get("modification_design", key),
            _set("modification_design", key),
            True,
            False,
            None,
        )
        for key in ("steps", "samples", "positions")
    },
}


def _fitting_value(scene, key: str, fits) -> float | None:
    """The value of ``key`` nearest the scene's with which ``fits(scene')`` holds, or None."""
    get, put, integer, up, high = KNOBS[key]
    now = get(scene)
    if integer:
        if now <= 1 or not fits(put(scene, 1)):
            return None
        lo, hi = 1, now  # fits at lo, not at hi
        while hi - lo > 1:
            mid = (lo + hi) // 2
            lo, hi = (mid, hi) if fits(put(scene, mid)) else (lo, mid)
        return lo
    if not up or not fits(put(scene, high)):
        return None
    lo, hi = now, high  # not at lo, fits at hi
    for _ in range(40):
        mid = math.sqrt(lo * hi)
        lo, hi = (lo, mid) if fits(put(scene, mid)) else (mid, hi)
    value = round_up(hi)
    while value < high and not fits(put(scene, value)):
        value = round_up(value * 1.05)
    return min(value, high)


def _blame(scene, est: Estimate, stages: list[str], fits) -> tuple[str, str]:
    """The key to name and what to say of it: ``(key = value, 'N would fit')``."""
    set_keys = {f"[{sec}] {k}" for sec, vals in scene.source.items() for k in vals}
    candidates: list[str] = []
    for name in stages:
        for key in est.stages[name].knobs:
            if key in KNOBS and key not in candidates:
                candidates.append(key)
    # Keys the scene set first, then the defaults, each in the stages' order.
    candidates.sort(key=lambda k: k not in set_keys)
    for key in candidates:
        ok = _fitting_value(scene, key, fits)
        if ok is not None:
            get = KNOBS[key][0]
            return f"{key} = {_show(get(scene), key)}", f"{_show(ok, key)} would fit"
    # No value of a key fits: name what the costliest stage is sized by (the
    # measured profile's file, say), not a key of some other stage.
    first = [k for k in est.stages[stages[0]].knobs if k not in KNOBS] if stages else []
    key = first[0] if first else candidates[0] if candidates else ""
    if key in KNOBS:
        return f"{key} = {_show(KNOBS[key][0](scene), key)}", "no single value of it fits"
    if key == "[errors] measured_profile" and scene.measured_profile is not None:
        p = scene.measured_profile
        size = p.stat().st_size if p.is_file() else 0
        return (
            f"{key} = {show(p.name, 60)} ({_size(size)})",
            "a file of fewer points fits (a CSV x,y is read in blocks)",
        )
    return key or "the scene", "reduce its sizes"


def _show(v, key: str) -> str:
    if key in ("[solver] crank_angles_deg", "[export] assembly_angles_deg"):
        return f"{v} angles" if isinstance(v, int) else str(v)
    if key == "[assembly] roller_classes_um":
        return f"{v} classes"
    return f"{v:g}" if isinstance(v, float) else str(v)


def _raise(need: float, flag: str) -> str:
    """A budget that the need fits, as the flag and the scene key that set it."""
    key = {"--max-memory": "memory_gb", "--max-output": "output_gb"}[flag]
    gb = round_up(need / GB * 1.1)
    high = SCHEMA["budget"][key].high
    if flag == "--max-memory":
        high = min(high, machine_memory() / GB)
    if gb > high:
        return f"it would take {gb:g} GB, more than the {high:.3g} GB allowed here"
    return f"{flag} {gb:g} (or [budget] {key} = {gb:g})"


def _gb(x: float) -> str:
    """A budget, in the GB it is given in."""
    return f"{x / GB:.3g} GB"


def _size(x: float) -> str:
    """A need: MB below 1 GB, else GB."""
    return f"{x / 1024**2:.3g} MB" if x < GB else f"{x / GB:.3g} GB"


def check_scene(
    scene, workers: int | None = None, budget: Budget | None = None, executor: str = "process"
) -> Estimate:
    """Refuse a scene whose run would pass its budget or a structural limit; its estimate.

    One :class:`SceneError` line: the key, its value, the need and the budget,
    a value that fits, and how to raise the budget.
    """
    budget = budget or budget_for(scene)
    check_structure(scene)
    est = estimate(scene, workers, executor)
    stages = list(est.stages)

    def order(first: str) -> list[str]:
        return [first] + [n for n in stages if n != first]

    if est.memory > budget.memory_bytes:

        def fits(s) -> bool:
            return estimate(s, workers, executor).memory <= budget.memory_bytes

        what, fit = _blame(scene, est, order(est.peak_stage), fits)
        raise SceneError(
            f"{what}: the run would need about {_size(est.memory)} of memory (at "
            f"{est.peak_stage}); the budget is {_gb(budget.memory_bytes)} "
            f"({budget.memory_from}); {fit}, or raise it: {_raise(est.memory, '--max-memory')}"
        )
    if est.output_bytes > budget.output_bytes:

        def fits_out(s) -> bool:
            return estimate(s, workers, executor).output_bytes <= budget.output_bytes

        big = max(est.stages, key=lambda n: _sum(est.stages[n]))
        files = max(est.output, key=est.output.get)
        what, fit = _blame(scene, est, order(big), fits_out)
        raise SceneError(
            f"{what}: the run would write about {_size(est.output_bytes)} of files ({files} "
            f"{_size(est.output[files])}); the output budget is {_gb(budget.output_bytes)} "
            f"({budget.output_from}); {fit}, or raise it: "
            f"{_raise(est.output_bytes, '--max-output')}"
        )
    return est


def check_disk(est: Estimate, out) -> None:
    """Refuse a run whose files would not fit on the disk of the output folder ``out``."""
    import shutil
    from pathlib import Path

    where = Path(out).absolute()
    while not where.exists() and where != where.parent:
        where = where.parent
    try:
        free = shutil.disk_usage(where).free
    except OSError:
        return  # the output folder's own checks report it
    if est.output_bytes > free:
        raise SceneError(
            f"the run would write about {_size(est.output_bytes)} of files; {where} has "
            f"{_size(free)} free; free some space or choose another --out"
        )


def time_warning(scene, est: Estimate, budget: Budget, executor: str = "process") -> str | None:
    """One line if the run is expected to take longer than the warning threshold."""
    if est.seconds <= budget.warn_seconds:
        return None
    slow = max(est.stages, key=lambda n: est.stages[n].seconds)
    limit = budget.warn_seconds

    def fits(s) -> bool:
        return estimate(s, est.workers, executor).seconds <= limit

    what, fit = _blame(scene, est, [slow] + [n for n in est.stages if n != slow], fits)
    fit = fit.replace("would fit", f"would take {_duration(limit)}")
    return (
        f"the run would take about {_duration(est.seconds)} ({slow} "
        f"{_duration(est.stages[slow].seconds)}, {est.workers} worker"
        f"{'s' if est.workers != 1 else ''}), more than the {_duration(limit)} warning "
        f"threshold ({budget.warn_from}); {what}: {fit}; --warn-time S or "
        "[budget] time_warning_s moves the threshold"
    )
