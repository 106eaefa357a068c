"""A scanned mesh of the made ring as a measured profile: STL (binary or ASCII) and PLY.

A 3D scanner or an inspection program exports the ring as a triangle mesh.
:func:`read_mesh_profile` slices it at mid face width and returns the inner
loop of the section, the tooth profile, as points (n, 2) in mm; the caller
registers and inspects them as any measured profile
(:mod:`corr_cad.tolerance.measured`, :mod:`corr_cad.tolerance.inspection`).

Conventions
-----------
* Units: mm.
* Axes: the ring's axis is the mesh's **z axis, through the origin**; the
  mesh's x and y are the design's (polar angles from +y towards +x), as
  corr_cad's own ``inner_gear.stl`` has them and as an inspection program
  aligns a scan to the part's datum axis. The registration then takes out a
  small rotation and centre offset.
* The section is the plane ``z = (z_min + z_max) / 2`` of the mesh's extent:
  mid face width.

Refused, each with one line
---------------------------
* a file over ``MAX_MEASURED_BYTES`` (200 MB) or with more than
  ``MAX_MESH_FACES`` (1,000,000) triangles, counted from the header (binary
  STL, PLY) or the ``endfacet`` lines (ASCII STL) before the mesh is built;
  the cap bounds memory (see ``MAX_MESH_FACES``). A section denser than
  ``MAX_SECTION_POINTS`` is thinned.
* a mesh whose z extent is not the design's face width, or whose largest
  radius about the axis is not the ring's rim (``ring_outer_radius``), both
  within ``EXTENT_TOLERANCE``: another part, or not mm;
* a mesh that is not closed (watertight);
* a section with no closed loop around the axis (the bore).

Only ``corr_cad.export`` reads meshes (trimesh); the core stays numpy.
"""

from __future__ import annotations

import io
import math
import re
from pathlib import Path

import numpy as np

from corr_cad.errors import ProfileError

__all__ = [
    "MESH_SUFFIXES",
    "MAX_MESH_FACES",
    "MAX_SECTION_POINTS",
    "EXTENT_TOLERANCE",
    "read_mesh_profile",
    "is_mesh",
]

#: File name endings read as meshes.
MESH_SUFFIXES = (".stl", ".ply")
#: Most triangles read. trimesh holds the mesh as float64 vertices and int64
#: faces while it merges, checks and slices it: about 0.6 kB per triangle at
#: the peak (measured: 1,000,000 triangles, a 50 MB binary STL, peak RSS
#: 609 MB above the interpreter's 129 MB, 11.6 s on the 2-core machine), so
#: the cap keeps a mesh under the run's default 3 GB budget with room for the rest.
#: A ring scanned at 0.05 mm point spacing has far fewer.
MAX_MESH_FACES = 1_000_000
#: Most section points handed on: a denser loop keeps every k-th point
#: (k = ceil(n / MAX_SECTION_POINTS)), 800 per tooth at z = 25, spacing about
#: 0.06 mm on the prototype; registration and inspection cost grows with them.
MAX_SECTION_POINTS = 20_000
#: Relative tolerance of the extent checks (face width, rim radius).
EXTENT_TOLERANCE = 0.1


def _face_count(raw: bytes, kind: str, src: str) -> int:
    """Triangles the file declares, without building the mesh."""
    if kind == "ply":
        head = raw[: raw.find(b"end_header")] if b"end_header" in raw[:65536] else b""
        m = re.search(rb"element\s+face\s+(\d+)", head)
        if not m:
            raise ProfileError(f"{src}: not a readable PLY file (no 'element face' in its header)")
        return int(m.group(1))
    if raw[:5].lower() == b"solid" and b"facet" in raw[:4096]:
        return raw.count(b"endfacet")
    if len(raw) < 84:
        raise ProfileError(f"{src}: not a readable STL file ({len(raw)} bytes)")
    n = int.from_bytes(raw[80:84], "little")
    if len(raw) != 84 + 50 * n:
        raise ProfileError(
            f"{src}: not a readable STL file (binary header says {n} triangles, "
            f"which need {84 + 50 * n} bytes; the file has {len(raw)})"
        )
    return n


def _load(raw: bytes, kind: str, src: str):
    import trimesh

    try:
        mesh = trimesh.load(io.BytesIO(raw), file_type=kind, force="mesh", process=True)
    except Exception as exc:  # trimesh raises many kinds on a broken file
        from corr_cad.bounds import show
        from corr_cad.export.inputfiles import quotable

        # its message may quote the file: bounded, and left out if it holds control bytes
        why = show(str(exc), 100) if str(exc) and quotable(str(exc)) else type(exc).__name__
        raise ProfileError(f"{src}: not a readable {kind.upper()} mesh ({why})") from exc
    if not isinstance(mesh, trimesh.Trimesh) or len(mesh.faces) == 0:
        raise ProfileError(f"{src}: the file holds no triangles")
    return mesh


def _check_extent(mesh, design, src: str) -> None:
    lo, hi = mesh.bounds
    height = float(hi[2] - lo[2])
    rim = float(np.max(np.hypot(mesh.vertices[:, 0], mesh.vertices[:, 1])))
    tol = EXTENT_TOLERANCE
    for what, got, want in (
        ("z extent (face width)", height, design.face_width),
        ("largest radius about the z axis (rim)", rim, design.ring_outer_radius),
    ):
        if not abs(got - want) <= tol * want:
            raise ProfileError(
                f"{src}: {what} is {got:.4g} mm, the design's is {want:.4g} mm "
                f"(within {100 * tol:g} %); the mesh must be this ring, in mm, "
                "its axis on z through the origin"
            )


def _inner_loop(mesh, src: str) -> np.ndarray:
    """The smallest closed loop of the mid-plane section that encloses the axis, (n, 2)."""
    import shapely

    z_mid = 0.5 * float(mesh.bounds[0][2] + mesh.bounds[1][2])
    section = mesh.section(plane_normal=[0.0, 0.0, 1.0], plane_origin=[0.0, 0.0, z_mid])
    loops = []
    if section is not None:
        to_plane = np.eye(4)
        to_plane[2, 3] = -z_mid
        planar, _ = section.to_2D(to_2D=to_plane)
        for pts in planar.discrete:
            pts = np.asarray(pts, dtype=float)
            if len(pts) < 4 or not np.allclose(pts[0], pts[-1]):
                continue
            poly = shapely.Polygon(pts)
            if poly.is_valid and poly.contains(shapely.Point(0.0, 0.0)):
                loops.append((poly.area, pts[:-1]))
    if not loops:
        raise ProfileError(
            f"{src}: the section at mid face width (z = {z_mid:.4g} mm) has no closed loop "
            "around the axis (the bore); the mesh must be the ring, its axis on z"
        )
    pts = min(loops, key=lambda a: a[0])[1]
    return pts[:: max(1, math.ceil(len(pts) / MAX_SECTION_POINTS))]


def read_mesh_profile(raw: bytes, suffix: str, design, src: str) -> np.ndarray:
    """The tooth profile (n, 2) mm of a ring mesh: the inner loop at mid face width.

    ``raw``: the file's bytes (already bounded by ``MAX_MEASURED_BYTES``);
    ``suffix``: ``".stl"`` or ``".ply"``; ``design``: the
    :class:`~corr_cad.geometry.design.GearDesign` whose face width and rim
    the mesh must match; ``src``: the file's name for messages.
    """
    kind = suffix.lower().lstrip(".")
    if "." + kind not in MESH_SUFFIXES:
        raise ProfileError(f"{src}: {suffix!r} is not a mesh format read; one of .stl, .ply")
    n = _face_count(raw, kind, src)
    if n > MAX_MESH_FACES:
        raise ProfileError(
            f"{src}: {n} triangles; at most {MAX_MESH_FACES} are read (decimate the scan, "
            "e.g. to 0.05 mm)"
        )
    mesh = _load(raw, kind, src)
    _check_extent(mesh, design, src)
    if not mesh.is_watertight:
        raise ProfileError(
            f"{src}: the mesh is not closed (watertight): {len(mesh.faces)} triangles with "
            "open or shared edges; fill the scan's holes first"
        )
    pts = _inner_loop(mesh, src)
    if not np.all(np.isfinite(pts)) or not math.isfinite(float(np.sum(pts))):
        raise ProfileError(f"{src}: the section has non-finite points")
    return pts


def is_mesh(path: Path) -> bool:
    """True for a file name read as a mesh (``.stl``, ``.ply``)."""
    return Path(path).suffix.lower() in MESH_SUFFIXES
