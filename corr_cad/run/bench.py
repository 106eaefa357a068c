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

from corr_cad.run.bench_accuracy import fidelity, interference, profile_export, solids
from corr_cad.run.bench_datasheet import datasheet_speed
from corr_cad.run.bench_resources import resources
from corr_cad.run.bench_speed import (
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
    "resources": resources,
}


def run(out: Path, studies: Sequence[str] = tuple(STUDIES), quick: bool = False) -> dict:
    """Run the chosen studies, writing into ``out``; returns their rows."""
    import platform

    from corr_cad._version import __version__
    from corr_cad.export.files import write_json

    out = Path(out)
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
    return {name: STUDIES[name](out, quick) for name in studies}
