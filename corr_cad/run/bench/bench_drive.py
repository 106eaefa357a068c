"""Benchmark of the two-row drive (``[solver] model = "drive"``), timed.

``corr-cad bench --study drive``. The targets (the drive model's issue): on
the prototype, 3,600 positions of the drive with bearings in 0.3 s or less;
the datasheet stage in 1.5 s or less; the Monte Carlo with the datasheet
metrics at 300 samples/s or more on 2 cores at the default grid. Measured,
never asserted; ``cpu_s``: the median CPU seconds of this process per timed call
(``time.process_time``), what the shared machine's load cannot inflate. The Monte
Carlo rows measure the force metrics alone and with the datasheet metrics
(``datasheet_positions_per_mesh`` 4: 104 grid positions a sample under a roller
tolerance), in this process and on 2 pool workers, and with the cams fixed; the
fixed cost is the Monte Carlo stage of ``corr-cad run`` with one sample (its
manifest's seconds: imports, the pool, the nominal pass and the plot; kernels cached); the
``datasheet_files`` rows are that stage of ``corr-cad run`` with the datasheet alone (writing
its files and drawing its PNGs, matplotlib's import included); the ``compile`` rows the CPU
seconds of compiling each group of ``corr-cad warm-up`` from an empty numba cache. Each law
on 40 needles 6 x 12 mm without and with a 5 um diametral clearance; every row
records the one-minute load average at its end (``load_avg``): a row measured on
a busy machine says so.
"""

from __future__ import annotations

import os
import statistics
import time
from pathlib import Path

from corr_cad.geometry.design import GearDesign
from corr_cad.run.bench.bench_common import M0, _table, _write_csv

__all__ = ["drive_speed"]


def _timed(fn, repeat: int) -> tuple[float, float, float, float]:
    """Wall median, min and max, and the median CPU seconds of this process."""
    fn()  # warm-up
    times, cpu = [], []
    for _ in range(repeat):
        t0, c0 = time.perf_counter(), time.process_time()
        fn()
        times.append(time.perf_counter() - t0)
        cpu.append(time.process_time() - c0)
    return statistics.median(times), min(times), max(times), statistics.median(cpu)


def _load() -> float:
    """The one-minute load average (0 where the platform has none)."""
    try:
        return os.getloadavg()[0]
    except (OSError, AttributeError):
        return 0.0


def drive_speed(out: Path, quick: bool = False) -> list:
    """Wall and CPU time of the drive's solve, datasheet and Monte Carlo, per contact law,
    on needles without and with a 5 um diametral clearance; each row with the load
    average it met (``load_avg``, the one-minute figure at its end)."""
    from corr_cad.mechanics.crank.bearing import EccentricBearing

    design = GearDesign()
    repeat = 1 if quick else 3
    samples = 20 if quick else 100
    rows = []
    for law in ("nonlinear", "palmgren"):
        for clearance in (0.0, 0.005):
            needles = EccentricBearing(40, 6.0, 12.0, diametral_clearance=clearance)
            tag = f", {clearance * 1e3:g} um clearance" if clearance else ""
            rows += _one_drive(design, needles, law, tag, samples, repeat)
    from corr_cad.mechanics.datasheet import DatasheetSpec

    spec = DatasheetSpec(rated_torque=design.roller_count * M0)
    rows.extend(_with_crank(design, EccentricBearing(40, 6.0, 12.0), spec, repeat))
    rows.extend(_datasheet_files_rows(repeat))
    rows.extend(_compile_rows())
    header = [
        "case",
        "median_s",
        "min_s",
        "max_s",
        "target_s",
        "samples_per_s",
        "two_idle_cores_per_s",
        "cpu_s",
        "load_avg",
    ]
    _table("drive model, prototype, one process", header, rows)
    _write_csv(out, "drive_speed.csv", header, rows)
    return rows


def _datasheet_files_rows(repeat: int) -> list:
    """The ``datasheet_files`` stage of ``corr-cad run`` (its manifest's seconds: writing
    the datasheet's files and drawing its two PNGs, matplotlib's import included), the
    prototype on 40 needles without and with a 5 um clearance, Palmgren's law."""
    rows = []
    for clearance in (0.0, 0.005):
        t = [_cli_stage("datasheet_files", _datasheet_scene(clearance)) for _ in range(repeat)]
        tag = f", {clearance * 1e3:g} um clearance" if clearance else ""
        name = f"datasheet_files (corr-cad run's stage), bearings, palmgren{tag}"
        rows.append([name, statistics.median(t), min(t), max(t), 1.0, "", "", "", _load()])
    return rows


_COMPILE = """
import json, os, time
c0 = time.process_time()
from corr_cad.run import warmup
out = []
for name, *_ in warmup.GROUPS:
    c = time.process_time()
    warmup._RUNS[name]()
    out.append([name, time.process_time() - c])
out.append(["all", time.process_time() - c0])
print(json.dumps(out))
"""


def _compile_rows() -> list:
    """Every kernel group of ``corr-cad warm-up`` compiled from an empty numba cache
    (``NUMBA_CACHE_DIR`` a new folder), in order in one fresh process (the first group
    carries numba's import): the CPU seconds of each, of the four a scene with rigid
    bodies may use (target 15 s) and of all; then ``corr-cad warm-up`` itself from
    another empty cache, its chains in parallel processes: its wall seconds and its
    processes' CPU seconds."""
    import json
    import resource
    import shutil
    import subprocess
    import sys
    import tempfile

    folder = tempfile.mkdtemp(prefix="corr-cad-bench-numba-")
    try:
        env = {**os.environ, "NUMBA_CACHE_DIR": folder}
        r = subprocess.run(
            [sys.executable, "-c", _COMPILE], env=env, check=True, capture_output=True, text=True
        )
        shutil.rmtree(folder, ignore_errors=True)
        before = resource.getrusage(resource.RUSAGE_CHILDREN)
        t0 = time.perf_counter()
        subprocess.run(
            [sys.executable, "-m", "corr_cad", "warm-up"], env=env, check=True, capture_output=True
        )
        wall = time.perf_counter() - t0
        after = resource.getrusage(resource.RUSAGE_CHILDREN)
    finally:
        shutil.rmtree(folder, ignore_errors=True)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    load = _load()
    groups = json.loads(r.stdout.strip().splitlines()[-1])
    rigid = sum(c for name, c in groups if name in _RIGID_GROUPS)
    groups.insert(-1, ["all but the bodies kernels", rigid])
    rows = [
        [
            f"compile from an empty cache: {name}",
            "",
            "",
            "",
            15.0 if name == "all but the bodies kernels" else "",
            "",
            "",
            cpu_s,
            load,
        ]
        for name, cpu_s in groups
    ]
    processes = min(os.cpu_count() or 1, 3)
    name = f"compile from an empty cache: corr-cad warm-up, {processes} processes (wall)"
    rows.append([name, wall, wall, wall, "", "", "", cpu, _load()])
    return rows


#: The kernel groups a scene may use without ``[solver] bodies = "elastic"``.
_RIGID_GROUPS = (
    "Monte Carlo kernel",
    "datasheet windup kernel",
    "free-play kernel",
    "drive kernels",
)


def _datasheet_scene(clearance: float) -> str:
    return (
        '[export]\nformats = ["datasheet"]\n[load]\ninput_torque = 1.1e5\n'
        '[solver]\nmodel = "drive"\ncontact_law = "palmgren"\n'
        "[bearings.eccentric]\nneedles = 40\nneedle_diameter = 6.0\nneedle_length = 12.0\n"
        f"diametral_clearance = {clearance!r}\n"
    )


def _cli_stage(stage: str, scene: str) -> float:
    """The seconds ``manifest.json`` gives ``stage`` of ``corr-cad run`` on ``scene``
    (a fresh process)."""
    import json
    import shutil
    import subprocess
    import sys
    import tempfile

    folder = Path(tempfile.mkdtemp(prefix="corr-cad-bench-"))
    try:
        (folder / "s.toml").write_text(scene)
        subprocess.run(
            [sys.executable, "-m", "corr_cad", "run", "s.toml", "--out", "out", "--quiet"],
            cwd=folder,
            check=True,
            capture_output=True,
        )
        manifest = json.loads((folder / "out" / "manifest.json").read_text())
        return next(x["seconds"] for x in manifest["stages"] if x["name"] == stage)
    finally:
        shutil.rmtree(folder, ignore_errors=True)


def _with_crank(design, needles, spec, repeat) -> list:
    """The drive with the crankshaft on its support bearings (the design's defaults,
    ``[bearings.crank]`` cylindrical), Palmgren's law: the solve and the datasheet."""
    from corr_cad.mechanics.datasheet import datasheet
    from corr_cad.mechanics.drive.drive import solve_drive
    from corr_cad.run.scene.scene import parse_scene

    bearing = {"needles": 40, "needle_diameter": 6.0, "needle_length": 12.0}
    scene = parse_scene(
        {
            "solver": {"model": "drive", "contact_law": "palmgren"},
            "load": {"input_torque": M0},
            "bearings": {"eccentric": bearing, "crank": {"type": "cylindrical"}},
        }
    )
    crank = scene.crank
    t = _timed(
        lambda: solve_drive(
            design, M0, positions=3600, bearing=needles, contact_model="palmgren", crank=crank
        ),
        repeat,
    )
    rows = [["3600 positions, bearings and crank, palmgren", *t[:3], "", "", "", t[3], _load()]]
    drive = {"errors_b": None, "bearing": needles, "bearing_b": None, "crank": crank}
    t = _timed(lambda: datasheet(design, spec, contact_model="palmgren", drive=drive), repeat)
    rows.append(
        ["datasheet stage, bearings and crank, palmgren", *t[:3], "", "", "", t[3], _load()]
    )
    return rows


def _one_drive(design, needles, law: str, tag: str, samples: int, repeat: int) -> list:
    """The rows of one contact law and bearing (``tag``: its clearance, "" for none)."""
    from concurrent.futures import ProcessPoolExecutor

    from corr_cad.mechanics.datasheet import DatasheetSpec, datasheet
    from corr_cad.mechanics.drive.drive import solve_drive
    from corr_cad.tolerance.mc_datasheet import DatasheetMC
    from corr_cad.tolerance.montecarlo import Distribution, monte_carlo

    spec = DatasheetSpec(rated_torque=design.roller_count * M0)
    tol = {"roller_radius": Distribution("normal", 0.001)}
    many = 4 * samples
    rows = []
    drive = {"errors_b": None, "bearing": needles, "bearing_b": None}
    t = _timed(
        lambda: solve_drive(design, M0, positions=3600, bearing=needles, contact_model=law),
        repeat,
    )
    rows.append([f"3600 positions, bearings, {law}{tag}", *t[:3], 0.3, "", "", t[3], _load()])
    t = _timed(lambda: datasheet(design, spec, contact_model=law, drive=drive), repeat)
    rows.append([f"datasheet stage, bearings, {law}{tag}", *t[:3], 1.5, "", "", t[3], _load()])
    mc = {"bearing": needles, "contact_model": law}
    t = [_cli_fixed_cost(law, needles.diametral_clearance) for _ in range(repeat)]
    name = f"Monte Carlo fixed cost (1 sample, corr-cad run's stage), {law}{tag}"
    rows.append([name, statistics.median(t), min(t), max(t), 1.0, "", "", "", _load()])
    t = _timed(lambda: monte_carlo(design, M0, tol, samples, 1, 72, drive=mc), 1)
    # CPU time per sample in this process: what the machine's other load cannot
    # inflate; two idle cores give about 2 / cpu samples per second.
    cpu = t[3] / samples
    name = f"Monte Carlo {samples} samples (72 positions), {law}{tag}"
    rows.append([name, *t[:3], "", samples / t[0], 2.0 / cpu, t[3], _load()])
    with ProcessPoolExecutor(2) as ex:
        t = _timed(
            lambda: monte_carlo(
                design, M0, tol, many, 1, 72, drive=mc, executor=ex, chunk=many // 2
            ),
            repeat,
        )
    name = f"Monte Carlo {many} samples (72 positions), {law}{tag}, 2 workers"
    rows.append([name, *t[:3], "", many / t[0], "", "", _load()])
    rows.extend(_with_datasheet(design, tol, mc, law, tag, samples, repeat, DatasheetMC(spec)))
    return rows


def _cli_fixed_cost(law: str, clearance: float) -> float:
    """The Monte Carlo stage's seconds (``manifest.json``) of ``corr-cad run`` with one
    sample of the drive on 40 needles (2 workers, the kernels' cache warm): the fixed
    cost, imports, pool and plot included."""
    import json
    import shutil
    import subprocess
    import sys
    import tempfile

    folder = Path(tempfile.mkdtemp(prefix="corr-cad-bench-"))
    contact = "palmgren" if law == "palmgren" else "paper"
    scene = (
        '[export]\nformats = ["montecarlo"]\n[load]\ninput_torque = 1.1e5\n'
        f'[solver]\nmodel = "drive"\ncontact_law = "{contact}"\n'
        "[tolerances]\nroller_radius = { normal = 0.001 }\n[montecarlo]\nsamples = 1\n"
        "positions = 72\n[bearings.eccentric]\nneedles = 40\nneedle_diameter = 6.0\n"
        f"needle_length = 12.0\ndiametral_clearance = {clearance!r}\n"
    )
    try:
        (folder / "s.toml").write_text(scene)
        subprocess.run(
            [sys.executable, "-m", "corr_cad", "run", "s.toml", "--out", "out", "--quiet"],
            cwd=folder,
            check=True,
            capture_output=True,
        )
        manifest = json.loads((folder / "out" / "manifest.json").read_text())
        return next(x["seconds"] for x in manifest["stages"] if x["name"] == "montecarlo")
    finally:
        shutil.rmtree(folder, ignore_errors=True)


def _with_datasheet(design, tol, mc, law, tag, samples, repeat, sheet) -> list:
    """The Monte Carlo with the datasheet metrics: in this process (its wall rate and 2 / the
    CPU seconds a sample) and on 2 pool workers; without bearings (``tag`` ""), the cams
    fixed as well."""
    from concurrent.futures import ProcessPoolExecutor

    from corr_cad.tolerance.montecarlo import monte_carlo

    def run(n, drive=mc, **kw):
        return monte_carlo(design, M0, tol, n, 1, 72, drive=drive, datasheet=sheet, **kw)

    t = _timed(lambda: run(samples), 1)
    cpu = t[3] / samples
    name = f"Monte Carlo + datasheet metrics {samples} samples (72 + 104 positions), {law}{tag}"
    rows = [[name, *t[:3], "", samples / t[0], 2.0 / cpu, t[3], _load()]]
    many = 2 * samples
    with ProcessPoolExecutor(2) as ex:
        t = _timed(lambda: run(many, executor=ex, chunk=max(1, many // 4)), repeat)
    rows.append([f"{name}, {many} samples, 2 workers", *t[:3], "", many / t[0], "", "", _load()])
    if not tag:
        fixed = {**mc, "bearing": None}  # the cams fixed: the rigid solve alone
        t = _timed(lambda: run(samples, drive=fixed), 1)
        cpu = t[3] / samples
        rows.append([f"{name}, cams fixed", *t[:3], "", samples / t[0], 2.0 / cpu, t[3], _load()])
    return rows
