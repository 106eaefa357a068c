"""The cost of reading and registering a measured ring (the ``measured_profile`` stage's
estimate in :mod:`corr_cad.run.budget.costs`, once per measured ring)."""

from __future__ import annotations

__all__ = ["measured_read", "measured_stage"]

MB = 1024.0**2


def measured_read(path, size: int, is_dxf: bool, picture: bool, knob: str) -> dict:
    """The needs (a :class:`~corr_cad.run.budget.costs.Cost`'s fields) of reading and
    registering one measured ring of ``size`` bytes; ``picture``: it draws
    measured_profile.dxf; ``knob``: its scene key."""
    from corr_cad.export.measured_io import MAX_MEASURED_POINTS

    mesh = str(path).lower().endswith((".stl", ".ply"))
    if mesh:
        # trimesh holds the file, its vertices and faces: 609 MB above the
        # interpreter for a 50 MB binary STL of 1e6 triangles (ru_maxrss), ~13 bytes a
        # byte; 11.6 s to read and slice it.
        rows = 20_000.0  # the section, decimated to at most this
        read, parse = 14.0 * size, 12.0 * size / 50e6
    elif is_dxf:
        # ezdxf holds every entity: ~40 bytes of memory per byte of DXF (measured
        # on LWPOLYLINE contours), then the flattened points.
        rows = size / 30.0
        read, parse = 40.0 * size, 5e-7 * size
    else:
        rows = size / 16.0  # "154.5008,0.0003": the shortest useful row
        read, parse = 24 * MB, 7e-7 * rows  # one 4 MB block at a time
    kept = min(rows, MAX_MEASURED_POINTS)
    # Registration and deviations: ~1.3 kB a kept point; the deviation table it keeps.
    out = {"measured_profile.dxf": 90 * kept + 0.5 * MB} if picture else {}
    return dict(
        memory=max(read, 1300 * kept) + 600 * kept,
        keeps=1200 * kept,
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
