"""What the design search costs: time, memory and files of the ``sizing`` stage.

The stage's estimator in :mod:`corr_cad.run.budget.costs` takes its numbers
from :func:`sizing_work`. A candidate's time is measured CPU time
(``corr-cad bench --study sizing``): the loader, the undercut test, the
datasheet (with ``[life]``: the efficiency map, the hysteresis and the lives)
and the forces at the screening resolution, for the prototype's 26 rollers,
scaled with the rollers; the front is evaluated again at the scene's own
resolution (about :data:`FULL_FACTOR` times a screening candidate).
"""

from __future__ import annotations

import math

__all__ = ["EVAL_SECONDS", "FULL_FACTOR", "sizing_work"]

MB = 1024.0**2
#: CPU seconds of one screened candidate, by (model, with [life]), 26 rollers.
EVAL_SECONDS = {
    ("paper", False): 0.12,
    ("paper", True): 0.35,
    ("drive", False): 0.6,
    ("drive", True): 1.5,
}
#: A full-resolution candidate over a screened one (more positions).
FULL_FACTOR = 1.5
#: The first stage's drive figures (gear outlines cached per process).
FIRST_STAGE_SECONDS = 0.05
#: Bytes of one row of sizing.csv.
ROW_BYTES = 420
#: A pool worker's evaluation beside its interpreter (the stages, the datasheet).
WORKER_EXTRA_BYTES = 120 * MB


def sizing_work(scene, workers: int, local: int) -> dict:
    """Seconds, memory, output and longest task of ``scene``'s search on ``workers``."""
    sz = scene.sizing
    n, pop = sz["evaluations"], sz["population"]
    life = sz["requirements"]["rated_life_h"] is not None
    model = "drive" if scene.solver.drive else "paper"
    each = EVAL_SECONDS[(model, life)] * scene.design.roller_count / 26.0
    if scene.first_stage is not None:
        each += FIRST_STAGE_SECONDS
    w = max(1, workers)
    front = 2 * pop  # the screened front evaluated again, at most about this
    seconds = 2.0 + each * n / w + FULL_FACTOR * each * (front + 1) / w
    chunk = math.ceil(pop / (2 * w))
    return {
        "seconds": seconds,
        "memory": 80 * MB + 2 * ROW_BYTES * (n + front),
        "workers": local * WORKER_EXTRA_BYTES,
        "output": {
            "sizing.csv": ROW_BYTES * (n + front + 1),
            "pareto.csv, pareto.png": 0.3 * MB,
            "design_NN.toml": 2048.0 * sz["designs"],
        },
        "task_seconds": FULL_FACTOR * each * chunk,
        "libraries": ("matplotlib",),
        "knobs": ("[sizing] evaluations",),
    }
