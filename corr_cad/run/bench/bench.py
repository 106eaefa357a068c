"""What accuracy costs in time: the benchmarks behind ``corr-cad bench``.

Each study prints a table (median of repeated runs, the machine's core
count stated), writes a CSV and a PNG under the output folder, and returns
its rows. Nothing here asserts a time: the numbers are for reading.
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from corr_cad.run.bench.bench_accuracy import fidelity, interference, profile_export, solids
from corr_cad.run.bench.bench_bodies import bodies_speed
from corr_cad.run.bench.bench_compound import compound_speed
from corr_cad.run.bench.bench_datasheet import datasheet_speed
from corr_cad.run.bench.bench_drive import drive_speed
from corr_cad.run.bench.bench_friction import friction_speed
from corr_cad.run.bench.bench_progress import progress_study
from corr_cad.run.bench.bench_resources import resources
from corr_cad.run.bench.bench_sizing import sizing_speed
from corr_cad.run.bench.bench_speed import (
    cold_start,
    kernel_crossover,
    montecarlo,
    solver_speed,
    throughput,
)

__all__ = ["STUDIES", "run"]


STUDIES = {
    "profile": profile_export,
    "solids": solids,
    "solver": fidelity,
    "speed": solver_speed,
    "montecarlo": montecarlo,
    "throughput": throughput,
    "kernel": kernel_crossover,
    "interference": interference,
    "coldstart": cold_start,
    "datasheet": datasheet_speed,
    "friction": friction_speed,
    "resources": resources,
    "drive": drive_speed,
    "progress": progress_study,
    "compound": compound_speed,
    "bodies": bodies_speed,
    "sizing": sizing_speed,
}


def check_bench_folder(out: Path) -> None:
    """Refuse a folder the benchmarks did not make: they would replace files in it.

    A bench writes ``machine.json`` and one CSV and PNG per study into
    ``out``. It may write into a folder that does not exist, an empty one,
    or one whose ``machine.json`` a bench wrote (it names ``corr_cad``);
    anything else may hold a user's ``speed.csv``, and is refused.
    """
    import json

    from corr_cad.bounds import show
    from corr_cad.errors import OutputError

    shown = show(str(out), 120)
    if out.exists() and not out.is_dir():
        raise OutputError(f"bench --out {shown}: exists and is not a folder; choose another")
    if not out.is_dir() or not any(out.iterdir()):
        return
    try:
        mine = "corr_cad" in json.loads((out / "machine.json").read_text(encoding="utf-8"))
    except (OSError, ValueError, TypeError):
        mine = False
    if not mine:
        raise OutputError(
            f"bench --out {shown}: the folder holds files a benchmark did not write (no "
            "machine.json of corr-cad bench); its tables would replace files of the same "
            "name: choose an empty or new folder, e.g. --out outputs/bench"
        )


def run(
    out: Path,
    studies: Sequence[str] = tuple(STUDIES),
    quick: bool = False,
    workers: Sequence[int] | None = None,
) -> dict:
    """Run the chosen studies, writing into ``out``; returns their rows.

    ``workers``: the worker counts of the Monte Carlo study's sweep
    (:func:`~corr_cad.run.bench.bench_scaling.workers_sweep`; default 1, 2, 4, ...
    up to the cores).
    """
    import platform

    from corr_cad._version import __version__
    from corr_cad.export.files import write_json

    out = Path(out)
    check_bench_folder(out)
    out.mkdir(parents=True, exist_ok=True)
    write_json(
        out / "machine.json",
        {
            "cores": os.cpu_count(),
            "machine": platform.machine(),
            "python": platform.python_version(),
            "numpy": np.__version__,
            "corr_cad": __version__,
            "quick": quick,
        },
    )
    rows = {}
    for name in studies:
        rows[name] = STUDIES[name](out, quick)
        if name == "montecarlo":
            from corr_cad.run.bench.bench_scaling import workers_sweep

            rows[name] = rows[name] + workers_sweep(out, quick, list(workers) if workers else None)
    return rows
