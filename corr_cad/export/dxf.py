"""DXF export of the second-stage parts (the only module importing ezdxf).

Every file is DXF R2018 in millimetres (``$INSUNITS = 4``), one part per
file, each contour closed and on a named layer, nothing duplicated. The
design parameters and the measured deviation are stored as custom header
properties so that the file documents itself.
"""

from __future__ import annotations

import math
from contextlib import contextmanager
from pathlib import Path

import ezdxf
import numpy as np

from corr_cad._version import __version__
from corr_cad.errors import ExportError
from corr_cad.export.dxf_flatten import (
    FlatteningTooLarge,
    flatten_bulge_polygon,
    flatten_spline,
    spline_chord_counts,
)
from corr_cad.export.files import writing
from corr_cad.geometry.design import SLOT_END_CLEARANCE, GearDesign
from corr_cad.geometry.parts import frame_slot_outline
from corr_cad.geometry.sampling import (
    ProfileApproximation,
    spline_tooth_pieces,
)

__all__ = [
    "PART_FILES",
    "write_inner_gear",
    "write_disk_cam",
    "write_roller",
    "write_teeth_frame",
    "write_all",
    "read_closed_contour",
    "contour_area",
]

PART_FILES = {
    "inner_gear": "inner_gear.dxf",
    "disk_cam": "disk_cam.dxf",
    "roller": "roller.dxf",
    "teeth_frame": "teeth_frame.dxf",
}

LAYERS = {
    "WORKING_PROFILE": 1,
    "THEORETICAL_PROFILE": 8,
    "CONJUGATE_PROFILE": 9,
    "RING_OUTER": 7,
    "CAM_OUTER": 7,
    "CAM_BORE": 5,
    "ROLLER": 7,
    "FRAME_OUTER": 7,
    "FRAME_INNER": 7,
    "FRAME_SLOTS": 3,
    # the first stage's gears: cut contours red (the outline), white (the
    # rim) and blue (the bore); the reference circles grey
    "PROFILE": 1,
    "BORE": 5,
    "PITCH_CIRCLE": 8,
    "BASE_CIRCLE": 9,
}


@contextmanager
def _fixed_metadata():
    """ezdxf's fixed metadata (2000-01-01 stamps, constant GUIDs), for reproducible bytes."""
    previous = ezdxf.options.write_fixed_meta_data_for_testing
    ezdxf.options.write_fixed_meta_data_for_testing = True
    try:
        yield
    finally:
        ezdxf.options.write_fixed_meta_data_for_testing = previous


def _new_doc(design: GearDesign, part: str, extra: dict | None = None) -> ezdxf.document.Drawing:
    with _fixed_metadata():
        doc = ezdxf.new("R2018", setup=False)
    doc.header["$INSUNITS"] = 4  # millimetres
    doc.header["$MEASUREMENT"] = 1  # metric
    doc.header["$LUNITS"] = 2  # decimal
    doc.header["$LUPREC"] = 6
    props = {"corr_cad.version": __version__, "corr_cad.part": part, "corr_cad.units": "mm"}
    props.update({f"corr_cad.{k}": v for k, v in design.as_dict().items()})
    props.update(extra or {})
    for key, value in props.items():
        doc.header.custom_vars.append(key, _fmt(value))
    return doc


def _fmt(value: object) -> str:
    if isinstance(value, float):
        return repr(value)
    return str(value)


def _layer(doc: ezdxf.document.Drawing, name: str) -> str:
    if name not in doc.layers:
        doc.layers.add(name, color=LAYERS.get(name, 7))
    return name


def _add_profile(msp, approx: ProfileApproximation, layer: str) -> None:
    attribs = {"layer": layer}
    if approx.representation == "spline":
        # One SPLINE per tooth, each ending on the next one's first control
        # point (C1 where the profile is smooth): CAD programs integrate a
        # several-hundred-span SPLINE badly (FreeCAD's face from one closed
        # spline of the whole profile measured 70,942 instead of 72,262 mm^2).
        for knots, ctrl in spline_tooth_pieces(approx):
            msp.add_open_spline(
                [tuple(p) for p in ctrl], degree=3, knots=list(knots), dxfattribs=attribs
            )
    else:
        _add_bulge_polyline(msp, approx.vertices, approx.bulges, attribs)


def _add_bulge_polyline(msp, vertices: np.ndarray, bulges: np.ndarray, attribs: dict) -> None:
    """Closed LWPOLYLINE from (n, 2) vertices and (n,) bulges.

    ezdxf appends vertices one by one (quadratic in n); filling its packed
    (x, y, start width, end width, bulge) array directly is linear.
    """
    pl = msp.add_lwpolyline([], format="xyb", close=True, dxfattribs=attribs)
    packed = np.zeros((len(vertices), 5))
    packed[:, :2] = vertices
    packed[:, 4] = bulges
    pl.lwpoints.values = packed


def _pin_class_order(doc: ezdxf.document.Drawing) -> None:
    """Register the CLASSES entries in a fixed order before ezdxf does.

    ezdxf adds the classes of the entity types in use by iterating a ``set``
    of type names (``ClassesSection.add_required_classes``), so the order of
    e.g. ``ACDBPLACEHOLDER`` and ``LAYOUT`` followed ``PYTHONHASHSEED``.
    Registering the required ones first and then the types in use sorted by
    name makes ezdxf's own pass a no-op (it keeps existing entries).
    """
    from ezdxf.sections.classes import REQ_R2004, REQUIRED_CLASSES

    for name in REQUIRED_CLASSES.get(doc.dxfversion, REQ_R2004):
        doc.classes.add_class(name)
    for name in sorted(doc.entitydb.dxf_types_in_use()):
        doc.classes.add_class(name)


def _save(doc: ezdxf.document.Drawing, path: Path) -> Path:
    """Save via a temporary file; fixed timestamps and GUIDs make the bytes reproducible.

    ezdxf's fixed metadata stamps 2000-01-01 as creation/update date: the
    same scene then gives byte-identical files (the file's real provenance is
    in its custom properties and in manifest.json).
    """
    path = Path(path)
    _pin_class_order(doc)
    with _fixed_metadata(), writing(path) as tmp:
        doc.saveas(tmp)
    return path


def write_inner_gear(
    design: GearDesign,
    working: ProfileApproximation,
    theoretical: ProfileApproximation,
    path: Path,
    conjugate: ProfileApproximation | None = None,
    modification: dict | None = None,
) -> Path:
    """Inner gear ring: working profile, theoretical profile (own layer), outer circle.

    With a profile modification the working profile is the modified one and
    the unmodified conjugate profile sits on the reference layer
    ``CONJUGATE_PROFILE`` (not to be cut).
    """
    extra = {
        "corr_cad.representation": working.representation,
        "corr_cad.tolerance_mm": working.tolerance,
        "corr_cad.max_deviation_mm": working.max_deviation,
        "corr_cad.within_tolerance": str(working.within_tolerance).lower(),
        "corr_cad.theoretical_max_deviation_mm": theoretical.max_deviation,
        "corr_cad.theoretical_within_tolerance": str(theoretical.within_tolerance).lower(),
    }
    if modification is not None:
        extra.update({f"corr_cad.modification.{k}": v for k, v in modification.items()})
    doc = _new_doc(design, "inner_gear", extra)
    msp = doc.modelspace()
    _add_profile(msp, working, _layer(doc, "WORKING_PROFILE"))
    _add_profile(msp, theoretical, _layer(doc, "THEORETICAL_PROFILE"))
    if conjugate is not None:
        _add_profile(msp, conjugate, _layer(doc, "CONJUGATE_PROFILE"))
    msp.add_circle(
        (0.0, 0.0), design.ring_outer_radius, dxfattribs={"layer": _layer(doc, "RING_OUTER")}
    )
    return _save(doc, path)


def write_disk_cam(design: GearDesign, path: Path, floating: bool = False) -> Path:
    """Disk cam centred on the origin; eccentric bore (crankshaft axis) at (0, -e), or with
    ``floating`` a concentric bore: the outer race of the cam's needle bearing."""
    extra = {"corr_cad.cam_bore": "concentric: needle bearing outer race"} if floating else None
    doc = _new_doc(design, "disk_cam", extra)
    msp = doc.modelspace()
    msp.add_circle((0.0, 0.0), design.cam_radius, dxfattribs={"layer": _layer(doc, "CAM_OUTER")})
    msp.add_circle(
        (0.0, 0.0) if floating else (0.0, -design.eccentricity),
        design.cam_bore_radius,
        dxfattribs={"layer": _layer(doc, "CAM_BORE")},
    )
    return _save(doc, path)


def write_roller(design: GearDesign, path: Path) -> Path:
    """One roller (all z + 1 are identical)."""
    doc = _new_doc(design, "roller")
    doc.modelspace().add_circle(
        (0.0, 0.0), design.roller_radius, dxfattribs={"layer": _layer(doc, "ROLLER")}
    )
    return _save(doc, path)


def write_teeth_frame(design: GearDesign, path: Path) -> Path:
    """Movable-teeth frame plate: two circles and z + 1 radial slots of width 2r."""
    doc = _new_doc(design, "teeth_frame", {"corr_cad.slot_end_clearance_mm": SLOT_END_CLEARANCE})
    msp = doc.modelspace()
    msp.add_circle(
        (0.0, 0.0), design.frame_outer_radius, dxfattribs={"layer": _layer(doc, "FRAME_OUTER")}
    )
    msp.add_circle(
        (0.0, 0.0), design.frame_inner_radius, dxfattribs={"layer": _layer(doc, "FRAME_INNER")}
    )
    layer = _layer(doc, "FRAME_SLOTS")
    for i in range(design.roller_count):
        verts, bulges = frame_slot_outline(design, i * design.slot_pitch_rad)
        _add_bulge_polyline(msp, verts, bulges, {"layer": layer})
    return _save(doc, path)


def write_all(
    design: GearDesign,
    working: ProfileApproximation,
    theoretical: ProfileApproximation,
    out_dir: Path,
    conjugate: ProfileApproximation | None = None,
    modification: dict | None = None,
    floating: bool = False,
) -> dict[str, Path]:
    """Write the four part files into ``out_dir``; returns ``{part: path}``."""
    out_dir = Path(out_dir)
    return {
        "inner_gear": write_inner_gear(
            design,
            working,
            theoretical,
            out_dir / PART_FILES["inner_gear"],
            conjugate,
            modification,
        ),
        "disk_cam": write_disk_cam(design, out_dir / PART_FILES["disk_cam"], floating),
        "roller": write_roller(design, out_dir / PART_FILES["roller"]),
        "teeth_frame": write_teeth_frame(design, out_dir / PART_FILES["teeth_frame"]),
    }


# --- reading back -----------------------------------------------------------
def read_closed_contour(
    path: Path,
    layer: str,
    flatten_distance: float = 1e-5,
    max_points: int | None = None,
    doc: ezdxf.document.Drawing | None = None,
) -> tuple[np.ndarray, str]:
    """Read the single closed contour on ``layer`` as dense points (n, 2).

    Accepts a closed LWPOLYLINE (bulges honoured), a closed POLYLINE, a
    SPLINE whose ends meet, or SPLINEs (one per tooth) that join into a
    closed chain. Raises :class:`ExportError` if the layer holds
    none, more than one, or an open contour, and
    :class:`~corr_cad.export.dxf_flatten.FlatteningTooLarge` before flattening
    a contour to more than ``max_points`` points (counted first:
    :mod:`corr_cad.export.dxf_flatten`). ``doc``: the file already read.
    Returns ``(points, dxftype)``.
    """
    if doc is None:
        try:
            doc = ezdxf.readfile(str(path))
        except Exception as exc:  # ezdxf raises StopIteration etc. on truncated files
            reason = str(exc) or type(exc).__name__
            raise ExportError(f"{path}: not a readable DXF file ({reason})") from exc
    ents = [e for e in doc.modelspace() if e.dxf.layer == layer]
    if len(ents) > 1 and all(e.dxftype() == "SPLINE" for e in ents):
        return _chain_splines(ents, path, layer, flatten_distance, max_points), "SPLINE"
    if len(ents) != 1:
        raise ExportError(
            f"{path}: layer {layer!r} must hold exactly one contour, found {len(ents)}"
        )
    ent = ents[0]
    kind = ent.dxftype()
    if kind == "LWPOLYLINE":
        if not ent.closed:
            raise ExportError(f"{path}: the LWPOLYLINE on layer {layer!r} is not closed")
        data = np.array(ent.get_points("xyb"), dtype=float).reshape(-1, 3)
        return flatten_bulge_polygon(data[:, :2], data[:, 2], flatten_distance, max_points), kind
    if kind == "POLYLINE":
        if not ent.is_closed:
            raise ExportError(f"{path}: the POLYLINE on layer {layer!r} is not closed")
        pts = np.array([(v.dxf.location.x, v.dxf.location.y) for v in ent.vertices], dtype=float)
        return pts, kind
    if kind == "SPLINE":
        pts = flatten_spline(ent.construction_tool(), flatten_distance, max_points)
        gap = float(np.linalg.norm(pts[0] - pts[-1]))
        if not gap <= 1e-6:
            raise ExportError(f"{path}: the SPLINE on layer {layer!r} is open (gap {gap:.3g} mm)")
        return pts[:-1], kind
    raise ExportError(f"{path}: layer {layer!r} holds a {kind}, expected LWPOLYLINE or SPLINE")


def _chain_splines(
    ents, path: Path, layer: str, flatten_distance: float, max_points: int | None
) -> np.ndarray:
    """Dense points of SPLINE entities that join end to start into one closed contour."""
    tools = [e.construction_tool() for e in ents]
    if max_points is not None:  # all of them counted before any is flattened
        total = sum(float(spline_chord_counts(t, flatten_distance)[0].sum()) + 1 for t in tools)
        if total > max_points:
            raise FlatteningTooLarge(
                f"its {len(tools)} splines would flatten to {total:.3g} points", total, max_points
            )
    pieces = [flatten_spline(t, flatten_distance) for t in tools]
    out = [pieces.pop(0)]
    while pieces:
        gaps = [float(np.linalg.norm(q[0] - out[-1][-1])) for q in pieces]
        k = int(np.argmin(gaps))
        if not gaps[k] <= 1e-6:
            raise ExportError(
                f"{path}: the SPLINEs on layer {layer!r} do not join (gap {gaps[k]:.3g} mm)"
            )
        out.append(pieces.pop(k)[1:])
    pts = np.concatenate(out)
    gap = float(np.linalg.norm(pts[0] - pts[-1]))
    if not gap <= 1e-6:
        raise ExportError(f"{path}: the SPLINEs on layer {layer!r} are open (gap {gap:.3g} mm)")
    return pts[:-1]


def contour_area(points: np.ndarray) -> float:
    """Unsigned shoelace area of a closed polygon (n, 2), mm^2."""
    x, y = points[:, 0], points[:, 1]
    return 0.5 * abs(float(np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1))))


def bulge_polygon_area(vertices: np.ndarray, bulges: np.ndarray) -> float:
    """Exact unsigned area of a closed polygon with bulge arcs, mm^2."""
    x, y = vertices[:, 0], vertices[:, 1]
    signed = 0.5 * float(np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1)))
    theta = 4.0 * np.arctan(bulges)
    chord = np.linalg.norm(np.roll(vertices, -1, axis=0) - vertices, axis=1)
    with np.errstate(divide="ignore", invalid="ignore"):
        radius = np.where(np.abs(theta) > 1e-15, chord / (2 * np.sin(np.abs(theta) / 2)), 0.0)
    seg = 0.5 * radius**2 * (np.abs(theta) - np.sin(np.abs(theta))) * np.sign(theta)
    total = signed + float(seg.sum())
    return abs(total) if math.isfinite(total) else math.nan
