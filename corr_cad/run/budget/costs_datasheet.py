"""The size of the datasheet's work, for its estimate: windup positions, torque rows,
solved transmission-error positions and the transmission error's rows."""

from __future__ import annotations

__all__ = ["datasheet_size"]


def datasheet_size(scene) -> tuple[int, int, int, int]:
    """Windup positions, torque rows per position, solved transmission-error positions,
    and the transmission error's rows.

    Positions: ``positions_per_mesh`` per mesh period over the span after
    which the windup repeats (one mesh period, a tooth pitch of z + 1 mesh
    periods, or z (z + 1) for a ring deviation, a measured one included);
    the transmission error solves at most ``per_turn`` classes for alike
    parts, else every one of its ``per_turn (z + 1)`` positions.
    """
    from corr_cad.mechanics.datasheet import TORQUE_LEVELS, span_errors
    from corr_cad.mechanics.row.windup import mesh_period_rad, result_period_rad

    d = scene.design
    z, R = d.tooth_count, d.roller_count
    ds = scene.datasheet
    drive = {"errors_b": scene.errors_b} if scene.solver.drive else None
    periodic = span_errors(d, scene.errors, drive, scene.solver.variants)
    mult = round(result_period_rad(d, periodic, scene.solver.variants) / mesh_period_rad(d))
    if scene.measured_profile is not None:
        mult = z * R
    ppm, turn = ds["positions_per_mesh"], ds["transmission_error_positions_per_turn"]
    levels = TORQUE_LEVELS + 3  # the grid, 0- and 0+, the band rows
    solved = turn * (1 if mult == 1 else R)
    return mult * ppm, levels, solved, turn * R
