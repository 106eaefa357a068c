"""How the Monte Carlo scales with workers: ``corr-cad bench --study montecarlo --workers``.

For each worker count the prototype's Monte Carlo (four tolerances, the
datasheet metrics, 36 positions a sample), under the paper's row (``model``
``paper``) and under the drive on 40 needles 6 x 12 mm with a 5 um diametral
clearance, Palmgren's law (``model`` ``drive``), runs through the real CLI
(``corr-cad run --workers N``) in a child process at two sample counts.
From the Monte Carlo stage's own time (``manifest.json``) come the marginal
rate (samples/s between the two runs), the fixed cost (the stage's time at
the smaller count less its samples at that rate: pool tasks, numba loading
the cached kernels in every worker, the nominal solve, the plot), the
stage's time with one sample (the same fixed cost, measured directly) and the
parallel efficiency (the rate over ``N`` times the one-worker rate). Where no
machine of many cores is at hand, the fixed cost is the serial fraction of
Amdahl's law (:func:`amdahl_serial_fraction`, of the larger run on one worker)
and each row gives the efficiency it predicts at 16 and 64 workers
(:func:`amdahl_efficiency`), with the load average the row met. The
peak memory of the larger run is the machine's (``tree`` of
:func:`~corr_cad.run.bench.bench_resources.measure`), beside the estimate. The
first run warms the kernels' cache; it is not reported.
"""

from __future__ import annotations

import json
import os
import shutil
import tempfile
from pathlib import Path

from corr_cad.run.bench.bench_common import _table, _write_csv

__all__ = [
    "DRIVE_SCENE",
    "SCENE",
    "amdahl_efficiency",
    "amdahl_serial_fraction",
    "default_worker_counts",
    "machine_line",
    "workers_sweep",
]

#: The sweep's scene; ``{samples}`` is filled in.
SCENE = (
    '[export]\nformats = ["montecarlo"]\n[load]\ninput_torque = 1.1e5\n'
    "[tolerances]\nroller_radius = { normal = 0.001 }\ncam_radius = { uniform = 0.002 }\n"
    "eccentricity = { uniform = 0.002 }\nslot_angle = { normal = 0.005 }\n"
    "[checks]\nmax_lost_motion_arcmin = 3.0\n"
    "[montecarlo]\nsamples = {samples}\npositions = 36\n"
)


#: The same study under the drive (both rows, the cams on needles with their clearance).
DRIVE_SCENE = SCENE + (
    '[solver]\nmodel = "drive"\ncontact_law = "palmgren"\n[bearings.eccentric]\nneedles = 40\n'
    "needle_diameter = 6.0\nneedle_length = 12.0\ndiametral_clearance = 0.005\n"
)
#: The sweep's models and their scenes.
MODELS = {"paper": SCENE, "drive": DRIVE_SCENE}


def default_worker_counts() -> list[int]:
    """1, 2, 4, 8, 16, ... up to this machine's cores (and the core count itself)."""
    cores = os.cpu_count() or 1
    counts = [n for n in (1, 2, 4, 8, 16, 32, 64) if n <= cores]
    return counts + ([cores] if cores not in counts else [])


def machine_line() -> str:
    """The processor's model, its cores and memory, as this machine reports them."""
    model = "unknown processor"
    try:
        with open("/proc/cpuinfo") as f:
            for line in f:
                if line.startswith("model name"):
                    model = line.split(":", 1)[1].strip()
                    break
    except OSError:
        pass
    from corr_cad.run.budget.resources import machine_memory

    return f"{model}, {os.cpu_count()} cores, {machine_memory() / 1024**3:.0f} GB"


def _stage_seconds(folder: Path) -> float:
    manifest = json.loads((folder / "out" / "manifest.json").read_text())
    return next(s["seconds"] for s in manifest["stages"] if s["name"] == "montecarlo")


def _one(samples: int, workers: int, text: str = SCENE) -> tuple[float, dict, float]:
    """Stage seconds, the measurement and the memory estimate of one run."""
    from corr_cad.run.bench.bench_resources import measure
    from corr_cad.run.budget.resources import estimate
    from corr_cad.run.scene.scene import load_scene

    folder = Path(tempfile.mkdtemp(prefix="corr-cad-bench-"))
    try:
        scene = text.replace("{samples}", str(samples))
        (folder / "s.toml").write_text(scene)
        est = estimate(load_scene(folder / "s.toml"), workers, "process")
        got = measure(folder, scene, ("--workers", str(workers)), timeout=3600)
        return _stage_seconds(folder), got, est.memory
    finally:
        shutil.rmtree(folder, ignore_errors=True)


def amdahl_serial_fraction(fixed: float, samples: int, rate_one: float, workers: int) -> float:
    """The serial fraction of a run of ``samples`` on one worker: its fixed cost (imports,
    the nominal pass, the plot, the pool's hand-off: :func:`workers_sweep`'s
    ``fixed_cost_s``, measured at ``workers``) over the whole time, the samples at
    ``rate_one`` samples/s (one worker's rate, or this count's scaled to one).

    >>> round(amdahl_serial_fraction(1.0, 1000, 100.0, 2), 4)
    0.0909
    """
    whole = fixed + samples / max(rate_one, 1e-12)
    return fixed / whole if whole > 0 else 0.0


def amdahl_efficiency(serial: float, workers: int) -> float:
    """Amdahl's parallel efficiency at ``workers``: ``1 / (N f + 1 - f)``.

    >>> round(amdahl_efficiency(0.01, 16), 3), round(amdahl_efficiency(0.01, 64), 3)
    (0.87, 0.613)
    """
    return 1.0 / (workers * serial + 1.0 - serial)


def workers_sweep(out: Path, quick: bool = False, workers: list[int] | None = None) -> list:
    """Samples/s, parallel efficiency, fixed cost and peak memory per worker count."""
    counts = workers or default_worker_counts()
    small, large = (200, 4_000) if quick else (2_000, 100_000)
    rows = []
    for model, text in MODELS.items():
        rows += _sweep(model, text, counts, small, large)
    header = [
        "machine",
        "model",
        "workers",
        "samples",
        "stage_s",
        "samples_per_s",
        "parallel_efficiency",
        "fixed_cost_s",
        "one_sample_s",
        "peak_MB",
        "est_memory_MB",
        "memory_ratio",
        "serial_fraction",
        "amdahl_efficiency_16",
        "amdahl_efficiency_64",
        "load_avg",
    ]
    _table(
        "Monte Carlo workers sweep (4 tolerances, datasheet metrics, 36 positions)", header, rows
    )
    _write_csv(out, "montecarlo_workers.csv", header, rows)
    return rows


def _sweep(model: str, text: str, counts: list[int], small: int, large: int) -> list:
    """The rows of one model's scene over the worker counts."""
    _one(small, counts[0], text)  # the kernels' cache, compiled once per installation
    rows, base = [], None
    mb = 1024.0**2
    machine = machine_line()
    for n in counts:
        t_one, _, _ = _one(1, n, text)  # the fixed cost itself: the stage with one sample
        t_small, _, _ = _one(small, n, text)
        t_large, got, est = _one(large, n, text)
        rate = (large - small) / max(t_large - t_small, 1e-9)
        base = base or (n, rate)  # efficiency against the first count (1 by default)
        fixed = max(t_small - small / rate, 0.0)
        serial = amdahl_serial_fraction(fixed, large, base[1] / base[0], n)
        rows.append(
            [
                machine,
                model,
                n,
                large,
                t_large,
                rate,
                rate * base[0] / (n * base[1]),
                fixed,
                t_one,
                got["tree"] / mb,
                est / mb,
                est / got["tree"],
                serial,
                amdahl_efficiency(serial, 16),
                amdahl_efficiency(serial, 64),
                os.getloadavg()[0],
            ]
        )
    return rows
