"""Watertight solids with manifold3d, files with trimesh (the only module importing them).

Every part is an extrusion of its :mod:`corr_cad.geometry.parts` outline. Meshes are
checked watertight, consistently wound and of positive volume before they
are written; the measured volume error against the exact volume goes into
the manifest.
"""

from __future__ import annotations

import hashlib
import io
import itertools
import math
import re
import uuid
import zipfile
from dataclasses import dataclass
from pathlib import Path

import manifold3d as m3d
import numpy as np
import trimesh

from corr_cad.errors import ExportError
from corr_cad.export.files import writing
from corr_cad.geometry.design import GearDesign
from corr_cad.geometry.kinematics import centre_distance, unit_radial
from corr_cad.geometry.parts import PartOutline, roller_z_range

__all__ = [
    "MESH_FORMATS",
    "MESH_UNITS",
    "solid",
    "to_trimesh",
    "check_mesh",
    "assembly",
    "write_mesh",
    "interference_at",
    "frame_stack",
    "frame_pieces",
]

#: File formats trimesh writes for us (binary STL).
MESH_FORMATS = ("stl", "3mf", "glb", "ply")


def solid(outline: PartOutline) -> m3d.Manifold:
    """Extrude an outline to a manifold solid (z from 0 to its thickness)."""
    section = m3d.CrossSection(
        [np.ascontiguousarray(c, dtype=np.float64) for c in outline.contours], m3d.FillRule.EvenOdd
    )
    man = m3d.Manifold.extrude(section, outline.thickness)
    if man.status() != m3d.Error.NoError or man.is_empty():
        raise ExportError(f"{outline.name}: manifold3d could not build the solid ({man.status()})")
    return man


def to_trimesh(man: m3d.Manifold) -> trimesh.Trimesh:
    mesh = man.to_mesh()
    return trimesh.Trimesh(
        vertices=np.asarray(mesh.vert_properties)[:, :3],
        faces=np.asarray(mesh.tri_verts),
        process=False,
    )


def check_mesh(mesh: trimesh.Trimesh, name: str) -> dict:
    """Watertight, winding-consistent, positive volume; returns the facts."""
    facts = {
        "watertight": bool(mesh.is_watertight),
        "winding_consistent": bool(mesh.is_winding_consistent),
        "volume_mm3": float(mesh.volume),
        "triangles": int(len(mesh.faces)),
    }
    if not (facts["watertight"] and facts["winding_consistent"] and facts["volume_mm3"] > 0):
        raise ExportError(f"{name}: mesh is not a closed, consistently oriented solid ({facts})")
    return facts


def stacked_solid(pieces: list) -> m3d.Manifold:
    """One solid from extruded outlines ``[(PartOutline, z0), ...]`` (a union)."""
    return m3d.Manifold.batch_boolean(
        [solid(o).translate((0.0, 0.0, float(z0))) for o, z0 in pieces], m3d.OpType.Add
    )


def place(man: m3d.Manifold, p) -> m3d.Manifold:
    """A part solid moved to a :class:`~corr_cad.geometry.placement.Placement`."""
    pre = man.translate((float(p.pre_offset[0]), float(p.pre_offset[1]), 0.0))
    return _placed(pre, p.angle_rad, p.offset[:2], p.offset[2])


def _placed(man: m3d.Manifold, angle_rad: float, offset_xy=(0.0, 0.0), z0: float = 0.0):
    """Rotate about z so that polar angles (from +y towards +x) grow by ``angle_rad``, then move."""
    # Our polar angle grows clockwise seen from +z: a mathematical rotation by -angle.
    return man.rotate((0.0, 0.0, -math.degrees(angle_rad))).translate(
        (float(offset_xy[0]), float(offset_xy[1]), float(z0))
    )


@dataclass
class Assembly:
    """Placed solids at one crank angle (relative to the frame, rad).

    ``frame_pieces[i]`` is the part of the frame plates around slot ``i``
    (placed like the frame): what roller ``i`` can touch, precut so that the
    interference check does not intersect every roller with all the plates.
    """

    crank_angle: float
    parts: dict[str, m3d.Manifold]
    rollers_a: list[m3d.Manifold]
    rollers_b: list[m3d.Manifold]
    frame_pieces: list[m3d.Manifold] | None = None

    def all_solids(self) -> dict[str, m3d.Manifold]:
        out = dict(self.parts)
        for i, r in enumerate(self.rollers_a):
            out[f"roller_a_{i + 1:02d}"] = r
        for i, r in enumerate(self.rollers_b):
            out[f"roller_b_{i + 1:02d}"] = r
        return out


def frame_stack(design: GearDesign, plate: m3d.Manifold) -> m3d.Manifold:
    """The three frame plates in frame coordinates (see :mod:`corr_cad.geometry.parts`)."""
    w, t = design.face_width, design.frame_thickness
    return m3d.Manifold.batch_boolean(
        [
            plate.translate((0, 0, -t)),
            plate.translate((0, 0, w)),
            plate.translate((0, 0, 2 * w + t)),
        ],
        m3d.OpType.Add,
    )


def frame_pieces(design: GearDesign, stack: m3d.Manifold) -> list[m3d.Manifold]:
    """The frame stack cut into one wedge per slot (frame coordinates)."""
    R = 2.0 * design.frame_outer_radius
    half = 0.5 * design.slot_pitch_rad
    zlo = -2.0 * design.frame_thickness
    height = 2.0 * design.face_width + 4.0 * design.frame_thickness
    pieces = []
    for i in range(design.roller_count):
        a = i * design.slot_pitch_rad
        tri = np.array([[0.0, 0.0], R * unit_radial(a - half), R * unit_radial(a + half)])
        if _signed_area(tri) < 0:
            tri = tri[::-1]
        wedge = m3d.Manifold.extrude(m3d.CrossSection([tri]), height).translate((0, 0, zlo))
        pieces.append(m3d.Manifold.batch_boolean([stack, wedge], m3d.OpType.Intersect))
    return pieces


def _signed_area(p: np.ndarray) -> float:
    x, y = p[:, 0], p[:, 1]
    return 0.5 * float(np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1)))


def assembly(
    design: GearDesign,
    solids: dict[str, m3d.Manifold],
    crank_angle_rad: float,
    roller_solids: list[m3d.Manifold] | None = None,
    stack: m3d.Manifold | None = None,
    pieces: list[m3d.Manifold] | None = None,
    floating: bool = False,
) -> Assembly:
    """Place every part as in the running reducer at one crank angle.

    ``crank_angle_rad`` is relative to the frame (``z`` x frame angle), as in
    the force outputs. The frame turns by ``crank/z``, the crankshaft by
    ``crank + crank/z``; cam B is 180 deg out of phase and ring B turned by
    half a tooth pitch. ``roller_solids[i]`` may give roller ``i`` its own
    solid (e.g. with a radius error); ``stack`` and ``pieces`` reuse a frame
    built once by :func:`frame_stack` and :func:`frame_pieces`. With ``floating``
    the cams (bores concentric) sit on their needle bearings as
    :func:`corr_cad.geometry.placement.assembly_placements` places them.
    """
    z = design.tooth_count
    w, t = design.face_width, design.frame_thickness
    e = design.eccentricity
    theta0 = crank_angle_rad / z
    phi = crank_angle_rad + theta0
    parts: dict[str, m3d.Manifold] = {}
    parts["ring_a"] = solids["ring"]
    parts["ring_b"] = _placed(solids["ring"], math.pi / z, z0=w + t)
    # The cam solid has its disc centred on the origin and the bore (the
    # crank axis) at (0, -e): move the bore to the axis, then turn.
    if floating:
        centre = e * unit_radial(phi)
        parts["cam_a"] = _placed(solids["cam"], theta0, centre)
        parts["cam_b"] = _placed(solids["cam"], theta0, -centre, w + t)
    else:
        cam_centred = solids["cam"].translate((0.0, e, 0.0))
        parts["cam_a"] = _placed(cam_centred, phi)
        parts["cam_b"] = _placed(cam_centred, phi + math.pi, z0=w + t)
    # One solid per frame plate, named as the STEP assembly's instances
    # (corr_cad.geometry.placement): frame_1 below row A, frame_2 between the
    # rows, frame_3 above row B.
    for k, z0 in enumerate((-t, w, 2 * w + t), 1):
        parts[f"frame_{k}"] = _placed(solids["frame"], theta0, z0=z0)
    rollers = {}
    for row, dphi in (("a", 0.0), ("b", math.pi)):
        zbase = roller_z_range(design, row)[0]
        placed = []
        for i in range(design.roller_count):
            theta = theta0 + i * design.slot_pitch_rad
            s = float(centre_distance(phi + dphi - theta, e, design.link_length))
            centre = s * unit_radial(theta)
            shape = roller_solids[i] if roller_solids is not None else solids["roller"]
            placed.append(_placed(shape, 0.0, centre, zbase))
        rollers[row] = placed
    placed_pieces = [_placed(p, theta0) for p in pieces] if pieces is not None else None
    return Assembly(crank_angle_rad, parts, rollers["a"], rollers["b"], placed_pieces)


def interference_at(asm: Assembly, search_length: float) -> list[dict]:
    """Intersection volume and minimum gap of every roller with ring, cam and frame."""
    rows = []
    plates = None
    if not asm.frame_pieces:
        plates = m3d.Manifold.batch_boolean(
            [asm.parts[f"frame_{k}"] for k in (1, 2, 3)], m3d.OpType.Add
        )
    for row, rollers in (("a", asm.rollers_a), ("b", asm.rollers_b)):
        for i, roller in enumerate(rollers):
            rec = {"row": row, "roller": i + 1}
            others = {
                "ring": asm.parts[f"ring_{row}"],
                "cam": asm.parts[f"cam_{row}"],
                "frame": asm.frame_pieces[i] if asm.frame_pieces else plates,
            }
            for name, other in others.items():
                inter = m3d.Manifold.batch_boolean([roller, other], m3d.OpType.Intersect)
                rec[f"{name}_volume"] = float(inter.volume())
                rec[f"{name}_gap"] = float(roller.min_gap(other, search_length))
            rows.append(rec)
    return rows


#: Largest intersection volume of two solids that do not touch by design, mm^3:
#: manifold3d's own arithmetic (a shared face or a tangent plane intersects
#: in a sliver of about 1e-9 mm^3 or nothing).
OVERLAP_VOLUME_TOL = 1e-6


def _is_contact(a: str, b: str) -> bool:
    """A roller and a part it touches by design (its ring, its cam, a frame plate)."""
    for x, y in ((a, b), (b, a)):
        if x.startswith("roller_"):
            row = x.split("_")[1]
            return y in (f"ring_{row}", f"cam_{row}") or y.startswith("frame_")
    return False


#: Pairs fitted on one circle by design (a cam's bore on the crankshaft): both
#: circles are polygons inscribed within the chord tolerance, so turned
#: against each other they overlap in slivers at most that deep.
_FITS = (("cam_", "crankshaft"),)


def _is_fit(a: str, b: str) -> bool:
    return any(
        (a.startswith(x) and b.startswith(y)) or (b.startswith(x) and a.startswith(y))
        for x, y in _FITS
    )


def _contact_allowance(a: str, b: str, contacts: dict | None) -> float:
    for (x, y), allow in (contacts or {}).items():
        if (a.startswith(x) and b.startswith(y)) or (b.startswith(x) and a.startswith(y)):
            return allow
    return 0.0


def solid_overlaps(
    solids: dict[str, m3d.Manifold],
    fit_allowance_mm3: float = 0.0,
    contacts: dict | None = None,
) -> tuple[int, list[dict]]:
    """Every pair of solids that does not touch by design, intersected.

    Pairs whose bounding boxes are apart cannot intersect and are counted as
    checked without a boolean. Returns ``(pairs checked, overlaps)``, each
    overlap ``{"a", "b", "volume_mm3"}`` above :data:`OVERLAP_VOLUME_TOL`
    (above ``fit_allowance_mm3`` for a bore on its shaft, the tessellation's
    sliver; above ``contacts[(prefix_a, prefix_b)]`` for a pair of instances
    whose names start so, a contact by design such as a needle on its races).
    The contacts a roller makes by design are left to :func:`interference_at`.
    """
    names = sorted(solids)
    boxes = {n: np.asarray(solids[n].bounding_box(), dtype=float) for n in names}
    checked, found = 0, []
    for i, a in enumerate(names):
        for b in names[i + 1 :]:
            if _is_contact(a, b):
                continue
            checked += 1
            ba, bb = boxes[a], boxes[b]
            if np.any(ba[3:] <= bb[:3]) or np.any(bb[3:] <= ba[:3]):
                continue
            vol = float(
                m3d.Manifold.batch_boolean([solids[a], solids[b]], m3d.OpType.Intersect).volume()
            )
            allow = max(
                OVERLAP_VOLUME_TOL,
                fit_allowance_mm3 if _is_fit(a, b) else 0.0,
                _contact_allowance(a, b, contacts),
            )
            if vol > allow:
                found.append({"a": a, "b": b, "volume_mm3": vol})
    return checked, found


_UUID_ATTR = re.compile(rb'UUID="([0-9a-fA-F-]{36})"')


def stable_3mf(data: bytes, compress_type: int | None = None) -> bytes:
    """The 3MF archive with trimesh's random ``p:UUID`` values derived from its content.

    Each UUID becomes a version-4 UUID built from the sha256 of the model XML
    (with the UUIDs blanked) and the UUID's position in it: the same geometry
    and names give the same bytes in every process. Member order, dates
    (trimesh's fixed 1980-01-01), compression and attributes are kept;
    ``compress_type`` (a ``zipfile.ZIP_*``) replaces each member's, so that an
    archive trimesh stored uncompressed is deflated once, here.
    """
    src = zipfile.ZipFile(io.BytesIO(data))
    buf = io.BytesIO()
    with zipfile.ZipFile(buf, "w") as dst:
        for info in src.infolist():
            body = src.read(info)
            if info.filename.endswith(".model"):
                base = hashlib.sha256(_UUID_ATTR.sub(b'UUID=""', body)).digest()
                count = itertools.count()

                def derived(_m, base=base, count=count) -> bytes:
                    h = hashlib.sha256(base + str(next(count)).encode()).digest()
                    return b'UUID="%s"' % str(uuid.UUID(bytes=h[:16], version=4)).encode()

                body = _UUID_ATTR.sub(derived, body)
            zi = zipfile.ZipInfo(info.filename, date_time=info.date_time)
            zi.compress_type = info.compress_type if compress_type is None else compress_type
            zi.external_attr = info.external_attr
            zi.create_system = info.create_system
            dst.writestr(zi, body, compresslevel=5)
    return buf.getvalue()


#: Length unit of each mesh file. glTF is defined in metres (glTF 2.0, 3.4:
#: "the units for all linear distances are meters"); 3MF says millimetres in
#: its ``unit`` attribute (trimesh writes ``unit="millimeter"``); STL and PLY
#: carry no unit and stay in millimetres.
MESH_UNITS = {"stl": "mm", "3mf": "mm", "glb": "m", "ply": "mm"}
_SCALE = {"mm": 1.0, "m": 1e-3}


def write_mesh(meshes: dict[str, trimesh.Trimesh] | trimesh.Trimesh, path: Path, fmt: str) -> Path:
    """Write one part or an assembly (a scene of named parts) via a temporary file.

    Coordinates are scaled from millimetres to the format's unit
    (:data:`MESH_UNITS`): GLB is written in metres.
    """
    if fmt not in MESH_FORMATS:
        raise ExportError(
            f"mesh format {fmt!r} is unknown; valid formats: {', '.join(MESH_FORMATS)}"
        )
    path = Path(path)
    scale = _SCALE[MESH_UNITS[fmt]]
    if scale != 1.0:
        if isinstance(meshes, dict):
            meshes = {name: _scaled(m, scale) for name, m in meshes.items()}
        else:
            meshes = _scaled(meshes, scale)
    if isinstance(meshes, dict):
        obj = trimesh.Scene()
        for name, mesh in meshes.items():
            obj.add_geometry(mesh, node_name=name, geom_name=name)
        if fmt in ("stl", "ply"):
            obj = trimesh.util.concatenate(list(meshes.values()))
    else:
        obj = meshes
    if fmt == "3mf":
        # trimesh deflates (level 5) and stable_3mf re-deflates at level 5:
        # deflating once gives the same bytes at half the cost.
        data = stable_3mf(_stored_3mf(obj), zipfile.ZIP_DEFLATED)
    else:
        data = obj.export(file_type=fmt)
    with writing(path) as tmp:
        tmp.write_bytes(data if isinstance(data, bytes) else data.encode())
    return path


class _ListFlat(np.ndarray):
    """An array whose ``flatten()`` is a list of Python numbers.

    trimesh's 3MF writer formats each batch of ``vertices[i:j].flatten()`` with
    ``str.format``: on Python floats that is about 1.7 times faster than on numpy
    scalars, and the text is the same (both print the shortest round-trip repr).
    """

    def flatten(self, order="C"):  # noqa: D102 - see the class
        return np.asarray(self).flatten(order).tolist()


class _Listed:
    """What trimesh's 3MF writer reads of a mesh: ``vertices``, ``faces`` as :class:`_ListFlat`."""

    def __init__(self, m: trimesh.Trimesh) -> None:
        self.vertices = np.asarray(m.vertices).view(_ListFlat)
        self.faces = np.asarray(m.faces).view(_ListFlat)


def _stored_3mf(obj: trimesh.Trimesh | trimesh.Scene) -> bytes:
    """trimesh's 3MF archive of ``obj``, members stored (not deflated): its exact bytes,
    made faster by handing its writer the meshes as :class:`_Listed` for the call."""
    from trimesh.exchange.threemf import export_3MF

    scene = obj if isinstance(obj, trimesh.Scene) else trimesh.Scene(obj)
    geometry = scene.geometry
    scene.geometry = {name: _Listed(m) for name, m in geometry.items()}
    try:
        return export_3MF(scene, compression=zipfile.ZIP_STORED)
    finally:
        scene.geometry = geometry


def _scaled(mesh: trimesh.Trimesh, factor: float) -> trimesh.Trimesh:
    """A copy of ``mesh`` with every coordinate times ``factor`` (faces, winding kept)."""
    return trimesh.Trimesh(
        vertices=np.asarray(mesh.vertices) * factor, faces=np.asarray(mesh.faces), process=False
    )
