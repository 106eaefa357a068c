"""What ``[solver] bodies = "elastic"`` adds to the estimate of the stages that solve the drive.

The finite-element reduction when its tables are not cached (the prototype: 450 MB
peak, 2.6-4.9 CPU s on the shared 2 cores), and the elastic solve against the rigid
one (about 10 times with the cams fixed, twice on needle bearings: ``corr-cad bench
--study bodies``).
"""

from __future__ import annotations

__all__ = ["BODIES_MEMORY", "BODIES_SECONDS", "ELASTIC_SOLVE", "elastic_terms"]

MB = 1024 * 1024
BODIES_MEMORY, BODIES_SECONDS, ELASTIC_SOLVE = 500 * MB, 10.0, 10


def elastic_terms(scene) -> tuple[float, float, float]:
    """``(memory bytes, seconds, solve factor)``: ``(0, 0, 1)`` with rigid bodies (the
    estimate then keeps its numbers bit for bit)."""
    if scene.solver.bodies != "elastic":
        return 0, 0, 1
    return BODIES_MEMORY, BODIES_SECONDS, ELASTIC_SOLVE
