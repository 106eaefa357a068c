"""The cost of reading and registering a measured ring (the ``measured_profile`` stage's
estimate in :mod:`corr_cad.run.budget.costs`, once per measured ring)."""

from __future__ import annotations

__all__ = ["measured_points", "measured_read", "measured_stage"]

MB = 1024.0**2


def measured_points(path, size: int, is_dxf: bool, lines: int = 0, kept: int = 0):
    """Rows read and points kept of one measured profile: a CSV's as counted up front
    (``measured_io.csv_points_kept``: ``lines``, ``kept``), a DXF's or mesh's from its size."""
    from corr_cad.export.measured_io import MAX_MEASURED_POINTS

    if lines:
        return float(lines), float(kept)
    mesh = str(path).lower().endswith((".stl", ".ply"))
    # A mesh's section is decimated to 20,000 points; "154.5008,0.0003" is the shortest row.
    rows = 20_000.0 if mesh else size / (30.0 if is_dxf else 16.0)
    return rows, min(rows, MAX_MEASURED_POINTS)


def measured_read(
    path, size: int, is_dxf: bool, picture: bool, knob: str, lines: int = 0, kept: int = 0
) -> dict:
    """The needs (a :class:`~corr_cad.run.budget.costs.Cost`'s fields) of reading and
    registering one measured ring of ``size`` bytes (a CSV's ``lines`` and ``kept`` points
    counted up front, 0: from its size); ``picture``: it draws measured_profile.dxf;
    ``knob``: its scene key."""
    mesh = str(path).lower().endswith((".stl", ".ply"))
    rows, kept = measured_points(path, size, is_dxf, lines, kept)
    if mesh:
        # trimesh holds the file, its vertices and faces: 609 MB above the
        # interpreter for a 50 MB binary STL of 1e6 triangles (ru_maxrss), ~13 bytes a
        # byte; 11.6 s to read and slice it.
        read, parse = 14.0 * size, 12.0 * size / 50e6
    elif is_dxf:
        # ezdxf holds every entity: ~40 bytes of memory per byte of DXF (measured
        # on LWPOLYLINE contours), then the flattened points.
        read, parse = 40.0 * size, 5e-7 * size
    else:
        read, parse = 24 * MB, 7e-7 * rows  # one 4 MB block at a time
    # Registration: +157 MB at 200,000 kept points (10^6 rows, stride 5), ~800 B a
    # point; the placed points, deviations and deviation table stay: 39 MB.
    out = {"measured_profile.dxf": 90 * kept + 0.5 * MB} if picture else {}
    return dict(
        memory=max(read, 1000 * kept) + 200 * kept,
        keeps=250 * kept,
        seconds=1.0 + parse + 50e-6 * kept,
        output=out,
        libraries=(("trimesh",) if mesh else ()) + (("ezdxf",) if is_dxf or out else ()),
        knobs=(knob,),
    )


def measured_stage(scene, env) -> dict:
    """The ``measured_profile`` stage: ring A's read (with its picture under ``"dxf"``) and
    ring B's (``[errors.row_b] measured_profile``), one after the other."""
    costs = []
    if scene.measured_profile is not None:
        picture = "dxf" in scene.formats
        costs.append(
            measured_read(
                scene.measured_profile,
                env.measured_bytes,
                env.measured_dxf,
                picture,
                "[errors] measured_profile",
                env.measured_lines,
                env.measured_kept,
            )
        )
    path_b = getattr(scene, "measured_profile_b", None)
    if path_b is not None:  # ring B: read and registered the same way, no picture
        costs.append(
            measured_read(
                path_b,
                env.measured_b_bytes,
                env.measured_b_dxf,
                False,
                "[errors.row_b] measured_profile",
                env.measured_b_lines,
                env.measured_b_kept,
            )
        )
    if len(costs) == 1:
        return costs[0]
    a, b = costs
    return dict(
        memory=max(a["memory"], a["keeps"] + b["memory"]),
        keeps=a["keeps"] + b["keeps"],
        seconds=a["seconds"] + b["seconds"],
        output=a["output"],
        libraries=tuple(dict.fromkeys(a["libraries"] + b["libraries"])),
        knobs=a["knobs"] + b["knobs"],
    )
