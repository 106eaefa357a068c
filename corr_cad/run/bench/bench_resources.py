"""The resource estimate against whole runs: ``corr-cad bench --study resources``.

Each scene of a grid runs through the real CLI in a child process (under an
address-space cap, so a wrong estimate cannot take the machine's memory);
a thread reads every process of the run's tree every 20 ms. The estimate
is for the machine's memory: the main process plus its pool workers, the
library files they all map counted once; it is compared with the same
(``peak_MB``: the largest sum of the processes' anonymous pages plus the
file pages of the process that maps most, at least the main process's own
peak RSS). ``rss_sum_MB`` is the sum of each process's peak RSS
(``VmHWM``), shared pages counted in every process. Also the wall time and
the bytes written, against the estimate the run printed. The memory
estimate must never be below the measured peak. ``load_avg``: the one-minute
load average as the run started; ``est_time_at_load_s``: the time estimate
scaled by the load (:func:`~corr_cad.run.progress.load_factor`, what the run's
estimate line gives on a busy machine) and its ratio to the measured time.
"""

from __future__ import annotations

import os
import subprocess
import sys
import threading
import time
from pathlib import Path

from corr_cad.run.bench.bench_common import _table, _write_csv

__all__ = ["resources", "GRID", "measure"]

#: Address-space cap of every benchmark run (numba, OCP and thread stacks
#: reserve far more address space than they touch).
CAP_BYTES = 10 * 1024**3

_MC = "[load]\ninput_torque = 1.1e5\n[tolerances]\nroller_radius = { normal = 0.001 }\n"
#: The prototype's drive on 40 needles 6 x 12 mm with a 5 um diametral clearance, Palmgren.
_DRIVE = (
    '[solver]\nmodel = "drive"\ncontact_law = "palmgren"\n[bearings.eccentric]\nneedles = 40\n'
    "needle_diameter = 6.0\nneedle_length = 12.0\ndiametral_clearance = 0.005\n"
)
_Z1000 = "[design]\ntooth_count = 1000\neccentricity = 0.05\nroller_radius = 0.3\n"

#: name -> (scene text, extra CLI arguments, in the quick grid?)
GRID = {
    "forces 3600": ('[export]\nformats = ["forces"]\n[load]\ninput_torque = 1.1e5\n', (), True),
    "forces 120855": (
        '[export]\nformats = ["forces"]\n[load]\ninput_torque = 1.1e5\n'
        "[solver]\npositions = 120855\n",
        (),
        True,
    ),
    "forces 300000": (
        '[export]\nformats = ["forces"]\n[load]\ninput_torque = 1.1e5\n'
        "[solver]\npositions = 300000\n",
        (),
        False,
    ),
    "clearance 36000": (
        '[export]\nformats = ["interference"]\ninterference_positions = 36000\n',
        (),
        True,
    ),
    "clearance z1000 15000": (
        _Z1000 + '[export]\nformats = ["interference"]\ninterference_positions = 15000\n',
        (),
        False,
    ),
    "mesh interference 12": (
        '[export]\nformats = ["interference"]\ninterference_method = "both"\n'
        "interference_positions = 12\n",
        (),
        False,
    ),
    "meshes 4 formats x 4": (
        '[export]\nformats = ["stl", "3mf", "glb", "ply"]\n'
        "assembly_angles_deg = [0.0, 5.0, 10.0, 15.0]\n",
        (),
        True,
    ),
    "stl 1e-4 x 2": (
        '[export]\nformats = ["stl"]\nchord_tolerance = 0.0001\nassembly_angles_deg = [0.0, 7.0]\n',
        (),
        False,
    ),
    "step x 2": (
        '[export]\nformats = ["step", "png"]\nassembly_angles_deg = [0.0, 7.0]\n',
        (),
        False,
    ),
    "dxf 1e-4 edm cmm report": (
        '[export]\nformats = ["dxf", "png", "edm", "cmm", "report"]\ntolerance = 0.0001\n',
        (),
        True,
    ),
    "montecarlo 3000 serial": (
        '[export]\nformats = ["montecarlo"]\n' + _MC + "[montecarlo]\nsamples = 3000\n",
        ("--executor", "serial"),
        True,
    ),
    "montecarlo 20000 pool": (
        '[export]\nformats = ["montecarlo"]\n' + _MC + "[montecarlo]\nsamples = 20000\n",
        (),
        False,
    ),
    "allocation 400": (
        '[export]\nformats = ["allocation"]\n' + _MC + "[checks]\nmax_gear_force = 5000.0\n"
        "[montecarlo]\nallocation_samples = 400\n",
        (),
        False,
    ),
    "sweeps 40": (
        '[export]\nformats = ["sweeps"]\n[load]\ninput_torque = 1.1e5\n[sweeps]\npoints = 40\n',
        (),
        True,
    ),
    "measured 2M rows": ("", (), False),  # the file is written by the study
    # 10^6 rows of which 10 % lie 0.05 to 0.5 mm off the contour (radially: the
    # contour stays simple and the fit passes); 200,000 points kept.
    "measured 1M rows 10% outliers": ("", (), True),
    # A [modification] normal_table waving 30 times along each tooth space
    # (wave.csv, written by the study): the ring's vertices follow the waves.
    "step wavy normal_table": (
        '[export]\nformats = ["step"]\nassembly_angles_deg = [0.0]\n'
        '[modification]\nnormal_table = "wave.csv"\n',
        (),
        True,
    ),
    "meshes wavy normal_table 4 formats x 2": (
        '[export]\nformats = ["stl", "3mf", "glb", "ply"]\nassembly_angles_deg = [0.0, 5.0]\n'
        '[modification]\nnormal_table = "wave.csv"\n',
        (),
        True,
    ),
    "modification free 4 steps": (
        '[export]\nformats = ["modification"]\n' + _MC + "[modification.design]\n"
        'family = "free"\nequidistant_range_mm = [0.0, 0.03]\ntarget_backlash_arcmin = 3.0\n'
        "steps = 4\nsamples = 10\npositions = 8\n",
        (),
        True,
    ),
    "drive montecarlo 400 palmgren 5 um": (
        '[export]\nformats = ["montecarlo"]\n' + _MC + _DRIVE + "[montecarlo]\nsamples = 400\n"
        "positions = 72\n",
        (),
        True,
    ),
    "drive montecarlo + datasheet 100 palmgren 5 um": (
        '[export]\nformats = ["montecarlo"]\n' + _MC + _DRIVE + "[montecarlo]\nsamples = 100\n"
        "positions = 72\n[checks]\nmax_lost_motion_arcmin = 5.0\n",
        (),
        True,
    ),
    "montecarlo 100000 x 36 pool": (
        '[export]\nformats = ["montecarlo"]\n' + _MC + "cam_phase = { normal = 0.01 }\n"
        "[montecarlo]\nsamples = 100000\npositions = 36\n",
        (),
        False,
    ),
}


def _wave_file(folder: Path, rows: int = 61, waves: int = 30, amplitude: float = 0.002) -> None:
    """``wave.csv``: a symmetric normal table 0.01 mm + ``amplitude`` sin(``waves`` psi)."""
    import numpy as np

    psi = np.linspace(0.0, 180.0, rows)
    n = 0.01 + amplitude * np.sin(np.radians(psi) * waves)
    text = "".join(f"{a:.6f},{b:.6f}\n" for a, b in zip(psi, n, strict=True))
    (folder / "wave.csv").write_text("psi_deg,normal_mm\n" + text)


def _children(pid: int) -> list[int]:
    out = []
    try:
        for tid in os.listdir(f"/proc/{pid}/task"):
            with open(f"/proc/{pid}/task/{tid}/children") as f:
                out += [int(c) for c in f.read().split()]
    except OSError:
        pass
    return out


def _hwm(pid: int) -> float:
    try:
        with open(f"/proc/{pid}/status") as f:
            for line in f:
                if line.startswith("VmHWM:"):
                    return int(line.split()[1]) * 1024.0
    except OSError:
        pass
    return 0.0


def _rss_parts(pid: int) -> tuple[float, float]:
    """Resident (anonymous + shared-memory, file-backed) bytes of ``pid`` now ((0, 0) if gone)."""
    parts = {"RssAnon:": 0.0, "RssShmem:": 0.0, "RssFile:": 0.0}
    try:
        with open(f"/proc/{pid}/status") as f:
            for line in f:
                key = line.split(maxsplit=1)[0] if line.strip() else ""
                if key in parts:
                    parts[key] = int(line.split()[1]) * 1024.0
    except OSError:
        pass
    return parts["RssAnon:"] + parts["RssShmem:"], parts["RssFile:"]


def measure(folder: Path, scene: str, args=(), timeout: float = 900) -> dict:
    """Run ``scene`` from ``folder``; peak bytes of its process tree, seconds, bytes written.

    ``peak``: the sum of each process's own peak RSS (the file pages every
    forked pool worker maps, numba's and numpy's libraries, counted in each);
    ``tree``: the memory the run held of the machine, the largest at one poll
    of the processes' anonymous pages plus the file pages of the process
    that maps most (the workers map the same library files), and at least
    the main process's own peak RSS. The estimate is compared with ``tree``.
    """
    (folder / "s.toml").write_text(scene)
    out = folder / "out"
    cmd = [sys.executable, "-m", "corr_cad", "run", "s.toml", "--out", "out", "--quiet", *args]
    if os.path.exists("/usr/bin/prlimit"):
        cmd = ["prlimit", f"--as={CAP_BYTES}", *cmd]
    t0 = time.monotonic()
    p = subprocess.Popen(cmd, cwd=folder, stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    peaks: dict[int, float] = {}
    tree = [0.0]
    stop = threading.Event()

    def poll():
        while not stop.is_set():
            todo, anon, files = [p.pid], 0.0, 0.0
            while todo:
                pid = todo.pop()
                peaks[pid] = max(peaks.get(pid, 0.0), _hwm(pid))
                a, f = _rss_parts(pid)
                anon, files = anon + a, max(files, f)
                todo += _children(pid)
            tree[0] = max(tree[0], anon + files)
            stop.wait(0.02)

    poller = threading.Thread(target=poll, daemon=True)
    poller.start()
    try:
        _, err = p.communicate(timeout=timeout)
    finally:
        stop.set()
        poller.join()
    seconds = time.monotonic() - t0
    if p.returncode not in (0, 1):
        raise RuntimeError(f"{scene!r} failed: {err.decode()[-400:]}")
    files = sum(f.stat().st_size for f in out.iterdir()) if out.exists() else 0
    tree[0] = max(tree[0], peaks.get(p.pid, 0.0))
    return {"peak": sum(peaks.values()), "tree": tree[0], "seconds": seconds, "bytes": files}


def _measured_file(folder: Path, rows: int, outliers: float = 0.0) -> str:
    """``m.csv``: the prototype's working profile in ``rows`` points, a share ``outliers``
    of them moved 0.05 to 0.5 mm outward (seeded); the scene that reads it."""
    import numpy as np

    from corr_cad.geometry.design import GearDesign
    from corr_cad.geometry.profile import working_profile

    w = working_profile(GearDesign())
    rng = np.random.default_rng(1)
    with open(folder / "m.csv", "w") as f:
        f.write("x,y\n")
        t = np.linspace(0.0, 2 * np.pi, rows, endpoint=False)
        for a in range(0, rows, 500_000):
            p = w.points(t[a : a + 500_000])
            off = rng.random(len(p)) < outliers
            r = np.hypot(p[off, 0], p[off, 1])
            p[off] *= (1.0 + rng.uniform(0.05, 0.5, int(off.sum())) / r)[:, None]
            np.savetxt(f, p, fmt="%.4f", delimiter=",")
    return (
        '[export]\nformats = ["inspection", "forces"]\n[load]\ninput_torque = 1.1e5\n'
        '[errors]\nmeasured_profile = "m.csv"\n'
    )


def resources(out: Path, quick: bool = False) -> list:
    """Estimate / measured peak memory, time and bytes over the grid; table, CSV, PNG."""
    import shutil
    import tempfile

    from corr_cad.export.bench_plots import resources_png
    from corr_cad.run.budget.resources import estimate
    from corr_cad.run.progress import load_factor
    from corr_cad.run.scene.scene import load_scene

    rows = []
    for name, (scene, args, in_quick) in GRID.items():
        if quick and not in_quick:
            continue
        folder = Path(tempfile.mkdtemp(prefix="corr-cad-bench-"))
        try:
            if name.startswith("measured 2M"):
                scene = _measured_file(folder, 2_000_000)
            elif name.startswith("measured 1M"):
                scene = _measured_file(folder, 1_000_000, outliers=0.1)
            if "wavy" in name:
                _wave_file(folder)
            (folder / "s.toml").write_text(scene)
            serial = "serial" in args
            est = estimate(load_scene(folder / "s.toml"), 1 if serial else None,
                           "serial" if serial else "process")  # fmt: skip
            factor, load, _ = load_factor(est.workers)  # the machine's load as the run starts
            got = measure(folder, scene, args)
        finally:
            shutil.rmtree(folder, ignore_errors=True)
        mb = 1024.0**2
        rows.append(
            [
                name,
                est.memory / mb,
                got["tree"] / mb,
                est.memory / got["tree"],
                est.seconds,
                got["seconds"],
                est.seconds / got["seconds"],
                est.output_bytes / mb,
                got["bytes"] / mb,
                (est.output_bytes / got["bytes"]) if got["bytes"] else float("nan"),
                got["peak"] / mb,
                load,
                est.seconds * factor,
                est.seconds * factor / got["seconds"],
            ]
        )
    header = [
        "scene",
        "est_memory_MB",
        "peak_MB",
        "memory_ratio",
        "est_time_s",
        "time_s",
        "time_ratio",
        "est_output_MB",
        "output_MB",
        "output_ratio",
        "rss_sum_MB",
        "load_avg",
        "est_time_at_load_s",
        "time_ratio_at_load",
    ]
    _table("Resource estimate / measured (peak memory of the process tree)", header, rows)
    _write_csv(out, "resources.csv", header, rows)
    resources_png(out / "resources.png", rows)
    low = [r[0] for r in rows if r[3] < 1.0]
    if low:
        print(f"MEMORY ESTIMATE BELOW THE PEAK: {', '.join(low)}")
    return rows
