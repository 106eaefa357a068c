"""The compiled kernels: which are not yet in numba's disk cache, and compiling them ahead.

numba compiles a kernel at its first call and keeps the machine code on disk
(``cache=True``: ``__pycache__`` beside the module, or ``NUMBA_CACHE_DIR``); a
later process loads it in milliseconds. The first run after an install (or
after an upgrade, which changes the sources) pays the compile: about 12 s of CPU
for the kernels every drive run uses, 6 s more for the elastic bodies'.
:func:`missing` reads the cache's index files (no numba import: a run that needs
no kernel pays nothing for the check); :func:`warm_up` runs each group of kernels
once on a tiny problem through the code paths the stages use, so that every
signature a run needs is compiled and cached (``corr-cad warm-up``; a run whose
scene uses a group that is missing does the same before its stages, with a line
that says so). Groups that share no kernel compile in parallel processes where
the machine has the cores (:data:`CHAINS`).
"""

from __future__ import annotations

import os
import re
import time
from collections.abc import Callable
from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, wait
from pathlib import Path

from corr_cad.run.progress import heartbeat, load_factor

__all__ = [
    "GROUPS",
    "command",
    "compile_ahead",
    "compile_seconds",
    "missing",
    "scene_groups",
    "source",
    "warm_up",
]

_MECHANICS = Path(__file__).resolve().parents[1] / "mechanics"

#: Kernel groups: (name, modules, about how many seconds of CPU they take to compile on
#: one quiet core, in this order, from an empty cache: ``corr-cad bench --study drive``'s
#: "compile" rows; what uses them). A module is named by its file's stem, as numba names
#: its cache files, wherever it sits under ``corr_cad/mechanics/`` (:func:`source`).
GROUPS = (
    ("Monte Carlo kernel", ("mc_kernel",), 4, "the paper's row, large Monte Carlos"),
    ("datasheet windup kernel", ("mc_windup_kernel",), 1, "datasheet metrics in a Monte Carlo"),
    ("free-play kernel", ("free_play",), 1, "the drive's backlash with a bearing clearance"),
    (
        "drive kernels",
        ("drive_laws", "drive_kernel", "drive_centre", "drive_rigid"),
        7,
        "the drive's Monte Carlo, allocation, design",
    ),
    (
        "bodies kernels",
        ("coupling_kernel", "coupling_newton"),
        6,
        'the elastic ring, frame and cams ([solver] bodies = "elastic")',
    ),
)

#: Groups whose runs share no kernel but a few small ones (the contact laws), in the order
#: each chain compiles them: the datasheet's windup calls the Monte Carlo kernel's row
#: solve, the drive's Monte Carlo the free-play kernel. Chains compile in parallel.
CHAINS = (
    ("Monte Carlo kernel", "datasheet windup kernel"),
    ("free-play kernel", "drive kernels"),
    ("bodies kernels",),
)

_JIT = re.compile(r"^@_jit\s*\ndef (\w+)", re.M)
#: Kernels no stage calls (a test's alone): never compiled by a run, never missed.
_UNUSED = {"drive_kernel": ("_invert",), "coupling_kernel": ("_ring_at", "_frame_at")}


def source(module: str) -> Path:
    """The source file of the kernel module ``module`` (a file's stem, unique under
    ``corr_cad/mechanics/``)."""
    found = sorted(_MECHANICS.rglob(f"{module}.py"))
    if len(found) != 1:
        raise LookupError(f"kernel module {module!r}: {len(found)} files under {_MECHANICS}")
    return found[0]


def _cache_dirs(source: Path) -> list[Path]:
    """Where numba keeps the cache of ``source``: under ``NUMBA_CACHE_DIR``; else beside
    it, or (an install it cannot write to) under the user's cache folder."""
    env = os.environ.get("NUMBA_CACHE_DIR")
    roots = [Path(env)] if env else []
    if not env:
        xdg = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
        roots.append(Path(xdg) / "numba")
    dirs = [d for r in roots if r.is_dir() for d in (r, *r.rglob("*")) if d.is_dir()]
    return dirs if env else [source.parent / "__pycache__", *dirs]


def missing(groups=GROUPS) -> list[str]:
    """The names of the ``groups`` with a kernel whose cache index is absent or older than
    its source (numba then compiles it at its first call)."""
    out = []
    for name, modules, _, _ in groups:
        for module in modules:
            path = source(module)
            stamp = path.stat().st_mtime
            dirs = _cache_dirs(path)
            kernels = set(_JIT.findall(path.read_text())) - set(_UNUSED.get(module, ()))
            if not all(
                any(p.stat().st_mtime >= stamp for d in dirs for p in d.glob(f"{module}.{k}-*.nbi"))
                for k in kernels
            ):
                out.append(name)
                break
    return out


def compile_seconds(names: list[str]) -> int:
    """About how long compiling the groups ``names`` takes on one quiet core."""
    return sum(s for name, _, s, _ in GROUPS if name in names)


def _paper_kernels(datasheet: bool) -> None:
    from corr_cad.geometry.design import GearDesign
    from corr_cad.mechanics.datasheet import DatasheetSpec
    from corr_cad.tolerance.mc_datasheet import DatasheetMC
    from corr_cad.tolerance.montecarlo import Distribution, monte_carlo

    design = GearDesign()
    tol = {"roller_radius": Distribution("normal", 0.001)}
    sheet = DatasheetMC(DatasheetSpec(rated_torque=26 * 1.1e5)) if datasheet else None
    monte_carlo(design, 1.1e5, tol, 2, 1, 8, kernel=True, datasheet=sheet)


def _drive_kernels() -> None:
    import numpy as np

    from corr_cad.geometry.design import GearDesign
    from corr_cad.mechanics.crank.bearing import EccentricBearing
    from corr_cad.mechanics.datasheet import DatasheetSpec
    from corr_cad.mechanics.drive.drive_kernel import CompiledDriveSolver
    from corr_cad.mechanics.row.solver_geometry import cycle_angles
    from corr_cad.tolerance.mc_datasheet import DatasheetMC
    from corr_cad.tolerance.montecarlo import Distribution, monte_carlo

    design = GearDesign()
    tol = {"roller_radius": Distribution("normal", 0.001)}
    sheet = DatasheetMC(DatasheetSpec(rated_torque=26 * 1.1e5), positions_per_mesh=1)
    for law in ("nonlinear", "palmgren"):
        for clearance in (0.0, 0.005):
            bearing = EccentricBearing(40, 6.0, 12.0, diametral_clearance=clearance)
            drive = {"bearing": bearing, "contact_model": law}
            monte_carlo(design, 1.1e5, tol, 1, 1, 4, drive=drive, datasheet=sheet)
        # A preloaded row's cam centre (the samples above may hold none).
        solver = CompiledDriveSolver(design, cycle_angles(2), bearing=bearing, contact_model=law)
        solver._row_centre(0, np.arange(1), np.zeros((1, 2)))


def _free_play() -> None:
    from corr_cad.geometry.design import GearDesign
    from corr_cad.mechanics.crank.bearing import EccentricBearing
    from corr_cad.mechanics.drive.drive import DriveSolver
    from corr_cad.mechanics.row.solver_geometry import cycle_angles

    bearing = EccentricBearing(40, 6.0, 12.0, diametral_clearance=0.005)
    DriveSolver(GearDesign(), cycle_angles(4), bearing=bearing).free_interval(solve=False)


def _bodies_kernels() -> None:
    """The elastic bodies' influence matrices and Newton, cams fixed and on needles, under
    both contact laws, on small made-up tables (the kernels' types are the real tables':
    no finite-element reduction needed)."""
    import numpy as np

    from corr_cad.geometry.design import GearDesign
    from corr_cad.mechanics.crank.bearing import EccentricBearing
    from corr_cad.mechanics.drive.coupling import BodyTables
    from corr_cad.mechanics.drive.drive import DriveSolver
    from corr_cad.mechanics.row.solver_geometry import cycle_angles

    design = GearDesign()
    R, z = design.roller_count, design.tooth_count  # the tables: any size, read modulo
    tables = BodyTables(
        ring=np.full((2, 2 * z), 1e-6),
        frame=np.full((3, R, 2, 3), 1e-6),
        frame_radii=np.array([120.0, 140.0, 160.0]),
        nodes=(0, 0, 0),
        mesh_size=1.0,
        cam=np.full(8, 1e-6),
    )
    needles = EccentricBearing(40, 6.0, 12.0, diametral_clearance=0.005)
    for law in ("nonlinear", "palmgren"):
        for bearing in (None, needles):
            solver = DriveSolver(
                design, cycle_angles(2), bearing=bearing, contact_model=law, bodies=tables
            )
            F = solver.solve(1.1e5)[1]  # the solve alone: the backlash is the free-play group's
    solver.bodies.work(F)  # whole matrices: each body's share (the compliance budget)


_RUNS = {
    "Monte Carlo kernel": lambda: _paper_kernels(False),
    "datasheet windup kernel": lambda: _paper_kernels(True),
    "free-play kernel": _free_play,
    "drive kernels": _drive_kernels,
    "bodies kernels": _bodies_kernels,
}


def scene_groups(scene) -> list[str]:
    """The kernel groups a run of ``scene`` calls (a superset: what may run)."""
    formats = set(scene.formats)
    sampled = bool({"montecarlo", "allocation", "modification"} & formats)
    if scene.solver.drive:
        elastic = ["bodies kernels"] if scene.solver.bodies == "elastic" else []
        return ["free-play kernel"] + (["drive kernels"] if sampled else []) + elastic
    if not sampled:
        return []
    from corr_cad.run.scene.scene_montecarlo import wants_datasheet_metrics
    from corr_cad.tolerance.montecarlo import KERNEL_MIN_WORK

    mc = scene.montecarlo
    if wants_datasheet_metrics(scene):
        return ["Monte Carlo kernel", "datasheet windup kernel"]
    if (
        formats & {"allocation", "modification"}
        or mc["samples"] * mc["positions"] >= KERNEL_MIN_WORK
    ):
        return ["Monte Carlo kernel"]
    return []  # a small Monte Carlo of the paper's row runs the numpy solver


def _chain(names: list[str]) -> list[tuple[str, float]]:
    """Run the groups ``names`` in order in this (worker) process: ``[(name, CPU s)]``."""
    out = []
    for name in names:
        c0 = time.process_time()
        _RUNS[name]()
        out.append((name, time.process_time() - c0))
    return out


def _parallel(chains: list[list[str]], workers: int, say: Callable[[str], None], out: dict) -> None:
    """The ``chains`` of groups compiled in ``workers`` fresh processes, the longest first
    (numba's disk cache is shared; each process writes its kernels' files whole), a line
    as each chain is done."""
    import multiprocessing

    chains = sorted(chains, key=compile_seconds, reverse=True)
    busy = [0] * workers  # each chain goes to the worker free first
    for chain in chains:
        busy[busy.index(min(busy))] += compile_seconds(chain)
    about = max(busy)
    t0 = time.perf_counter()
    ctx = multiprocessing.get_context("spawn")  # no numba state forked from this process
    with (
        ProcessPoolExecutor(workers, mp_context=ctx) as pool,
        heartbeat("      kernels", about * load_factor(workers)[0]),
    ):
        pending = {pool.submit(_chain, c) for c in chains}
        while pending:
            done, pending = wait(pending, return_when=FIRST_COMPLETED)
            for future in done:
                result = future.result()
                out.update((name, (True, cpu)) for name, cpu in result)
                say(
                    f"      compiled: {', '.join(n for n, _ in result)} "
                    f"({sum(c for _, c in result):.1f} s of CPU; "
                    f"{time.perf_counter() - t0:.0f} s after the start)"
                )


def warm_up(
    groups: list[str] | None = None,
    say: Callable[[str], None] = print,
    workers: int | None = None,
) -> dict[str, tuple[bool, float]]:
    """Compile (or load) the kernel ``groups`` (all by default) and say so, one line each
    and a progress line every 5 s while one compiles (its time left from the estimate at
    the machine's load): ``{group: (compiled, seconds)}`` (CPU seconds of a compiled
    group, wall seconds of a loaded one). Groups of different :data:`CHAINS` compile in up
    to ``workers`` processes (default: the cores the one-minute load average leaves idle)
    where more than one chain lacks its cache."""
    names = [g[0] for g in GROUPS] if groups is None else groups
    lacking = set(missing())
    todo = [n for n in names if n in lacking]
    chains = [[n for n in chain if n in todo] for chain in CHAINS]
    chains = [c for c in chains if c]
    if workers is None:  # the cores the machine's load leaves idle
        _, load, cpus = load_factor(1)
        workers = max(1, int(cpus - load + 0.5))
    workers = min(workers, len(chains))
    out: dict[str, tuple[bool, float]] = {}
    for i, name in enumerate(names, 1):
        about = compile_seconds([name])
        if name in todo and workers > 1:
            what = f"compiling in {workers} processes, about {about} s of CPU"
        elif name in todo:
            what = f"compiling, about {about} s on one core"
        else:
            what = "loading from cache"
        say(f"kernels {i}/{len(names)}: {name} ({what})")
        if name in todo and workers > 1:
            continue  # compiled below, with the other chains
        t0, c0 = time.perf_counter(), time.process_time()
        expected = about * load_factor(1)[0] if name in todo else None
        with heartbeat(f"      kernels {i}/{len(names)}", expected):  # a line every 5 s
            _RUNS[name]()
        seconds = time.process_time() - c0 if name in todo else time.perf_counter() - t0
        out[name] = (name in todo, seconds)
    if workers > 1:
        _parallel(chains, workers, say, out)
    return {n: out[n] for n in names}


def command(workers: int | None = None) -> int:
    """``corr-cad warm-up``: every kernel group compiled or loaded, one line each."""
    t0 = time.perf_counter()
    done = warm_up(say=lambda m: print(m, flush=True), workers=workers)
    compiled = [n for n, (c, _) in done.items() if c]
    cpu = sum(t for c, t in done.values() if c)
    print(
        f"kernels ready in {time.perf_counter() - t0:.0f} s"
        f"{f' ({cpu:.0f} s of CPU compiling)' if compiled else ''}: {len(compiled)} of "
        f"{len(done)} groups compiled"
        f"{' (' + ', '.join(compiled) + ')' if compiled else ''}, the rest loaded from cache",
        flush=True,
    )
    return 0


def compile_ahead(scene, say: Callable[[str], None]) -> None:
    """Compile the kernel groups the scene uses that numba's cache lacks, in this process
    before any pool worker starts (the workers then load them), and say so."""
    wanted = scene_groups(scene)
    todo = [g for g in missing() if g in wanted] if wanted else []
    if not todo:
        return
    say(
        f"compiling the numerical kernels once after install ({', '.join(todo)}): about "
        f"{compile_seconds(todo)} s of CPU; 'corr-cad warm-up' does it ahead"
    )
    warm_up(todo, say=lambda m: say(f"      {m}"))
