"""What ``[friction]``'s figures cost in the datasheet stage: efficiency forward and
backdriving, starting torque, the hysteresis loop and the life, over the datasheet's span
at ``[friction] positions_per_mesh``. A datasheet pulled in by a check alone
(``min_efficiency``, ``min_life_h``) runs them too."""

from __future__ import annotations

__all__ = ["FRICTION_CELL_SECONDS", "friction_seconds"]

#: Seconds a (friction position, roller) of the paper's row; the drive's cell costs
#: ``DRIVE_CELLS`` times. 1.6 s of CPU measured for the prototype's drive (Palmgren, 40
#: needles 6 x 12 mm, 5 um clearance, 4 positions a mesh period: 1,040 drive cells;
#: ``formats = ["forces"]`` with ``[checks] min_efficiency`` against the same scene without
#: it, less the datasheet's own 0.4 s) at a load average of 14 on 2 cores.
FRICTION_CELL_SECONDS = 1.5e-3


def friction_seconds(scene, datasheet_positions: int, rollers: int, drive_cells: float) -> float:
    """``[friction]``'s figures (0 without the section): the datasheet's span
    (``datasheet_positions`` at its own density) at the friction's density."""
    if not getattr(scene, "friction", None):
        return 0.0
    positions = datasheet_positions // scene.datasheet["positions_per_mesh"]
    positions *= scene.friction["positions_per_mesh"]
    cells = positions * rollers * (drive_cells if scene.solver.drive else 1.0)
    return FRICTION_CELL_SECONDS * cells
