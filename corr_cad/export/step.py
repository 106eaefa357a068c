"""STEP AP214 export as real B-rep solids (Open CASCADE via OCP, an optional extra).

The working profile goes in as one closed cubic B-spline curve: the same
clamped spline, within the scene's tolerance, that ``spline`` DXF export
writes. Circles are exact circles, slots exact lines and arcs. Faces are
extruded to solids.

Read-back verification meshes the shape (``BRepMesh_IncrementalMesh``) and
takes the volume of that mesh: Open CASCADE's exact volume integration
(``GProp``) is unreliable on many-lobed B-spline faces.
"""

from __future__ import annotations

import math
import os
import re
from pathlib import Path

import numpy as np

from ..design import GearDesign
from ..errors import ExportError
from ..parts import frame_slot_outline
from ..sampling import ProfileApproximation

__all__ = ["require_ocp", "write_step", "read_step_mesh", "read_step_curves", "part_shapes"]

_INSTALL = "pip install -e '.[step]'  (installs cadquery-ocp-novtk, Open CASCADE)"


_QUIET = False


def require_ocp():
    """Import OCP or raise a clear error saying how to install it.

    Also silences Open CASCADE's console messages (it prints to stdout).
    """
    global _QUIET
    try:
        import OCP  # noqa: F401
    except ImportError as exc:
        raise ExportError(f"STEP export needs the 'step' extra: {_INSTALL}") from exc
    if not _QUIET:
        from OCP.Message import Message

        messenger = _static(Message, "DefaultMessenger")()
        for printer in list(messenger.Printers()):
            messenger.RemovePrinter(printer)
        _QUIET = True


def _pnt(x, y, z=0.0):
    from OCP.gp import gp_Pnt

    return gp_Pnt(float(x), float(y), float(z))


def _circle_edge(radius: float, centre=(0.0, 0.0)):
    from OCP.BRepBuilderAPI import BRepBuilderAPI_MakeEdge
    from OCP.gp import gp_Ax2, gp_Circ, gp_Dir

    circ = gp_Circ(gp_Ax2(_pnt(*centre), gp_Dir(0, 0, 1)), float(radius))
    return BRepBuilderAPI_MakeEdge(circ).Edge()


def _wire(edges):
    from OCP.BRepBuilderAPI import BRepBuilderAPI_MakeWire

    mk = BRepBuilderAPI_MakeWire()
    for e in edges:
        mk.Add(e)
    if not mk.IsDone():
        raise ExportError("STEP: could not close a wire")
    return mk.Wire()


def _bspline_edge(approx: ProfileApproximation):
    from OCP.BRepBuilderAPI import BRepBuilderAPI_MakeEdge
    from OCP.Geom import Geom_BSplineCurve

    # OCP 8 moved the TColgp / TColStd arrays to OCP.OCP.collections.
    from OCP.OCP.collections import Array1_double, Array1_gp_Pnt, Array1_int

    poles = approx.vertices
    knots, mults = np.unique(np.round(approx.knots, 14), return_counts=True)
    arr = Array1_gp_Pnt(1, len(poles))
    for i, (x, y) in enumerate(poles, 1):
        arr.SetValue(i, _pnt(x, y))
    kn = Array1_double(1, len(knots))
    mu = Array1_int(1, len(knots))
    for i, (k, m) in enumerate(zip(knots, mults, strict=True), 1):
        kn.SetValue(i, float(k))
        mu.SetValue(i, int(m))
    curve = Geom_BSplineCurve(arr, kn, mu, 3, False)
    return BRepBuilderAPI_MakeEdge(curve).Edge()


def _slot_wire(design: GearDesign, angle: float):
    from OCP.BRepBuilderAPI import BRepBuilderAPI_MakeEdge
    from OCP.GC import GC_MakeArcOfCircle, GC_MakeSegment

    v, _ = frame_slot_outline(design, angle)
    u = np.array([math.sin(angle), math.cos(angle)])
    r = design.roller_radius
    mid_out = 0.5 * (v[1] + v[2]) + r * u
    mid_in = 0.5 * (v[3] + v[0]) - r * u
    edges = [
        BRepBuilderAPI_MakeEdge(GC_MakeSegment(_pnt(*v[0]), _pnt(*v[1])).Value()).Edge(),
        BRepBuilderAPI_MakeEdge(
            GC_MakeArcOfCircle(_pnt(*v[1]), _pnt(*mid_out), _pnt(*v[2])).Value()
        ).Edge(),
        BRepBuilderAPI_MakeEdge(GC_MakeSegment(_pnt(*v[2]), _pnt(*v[3])).Value()).Edge(),
        BRepBuilderAPI_MakeEdge(
            GC_MakeArcOfCircle(_pnt(*v[3]), _pnt(*mid_in), _pnt(*v[0])).Value()
        ).Edge(),
    ]
    return _wire(edges)


def _extrude(outer_wire, hole_wires, height: float):
    from OCP.BRepBuilderAPI import BRepBuilderAPI_MakeFace
    from OCP.BRepPrimAPI import BRepPrimAPI_MakePrism
    from OCP.gp import gp_Vec
    from OCP.ShapeFix import ShapeFix_Face

    mk = BRepBuilderAPI_MakeFace(outer_wire, True)
    for w in hole_wires:
        mk.Add(w)
    if not mk.IsDone():
        raise ExportError("STEP: could not make a planar face")
    fix = ShapeFix_Face(mk.Face())
    fix.FixOrientation()
    fix.Perform()
    face = fix.Face()
    return BRepPrimAPI_MakePrism(face, gp_Vec(0, 0, float(height))).Shape()


def _static(cls, name: str):
    """OCP 7 suffixes static methods with ``_s``; OCP 8 does not."""
    return getattr(cls, name, None) or getattr(cls, name + "_s")


def part_shapes(design: GearDesign, working_spline: ProfileApproximation) -> dict:
    """B-rep solids of ``ring``, ``cam``, ``roller`` and ``frame`` (part coordinates)."""
    require_ocp()
    ring = _extrude(
        _wire([_circle_edge(design.ring_outer_radius)]),
        [_wire([_bspline_edge(working_spline)])],
        design.face_width,
    )
    cam = _extrude(
        _wire([_circle_edge(design.cam_radius)]),
        [_wire([_circle_edge(design.cam_bore_radius, (0.0, -design.eccentricity))])],
        design.face_width,
    )
    roller = _extrude(
        _wire([_circle_edge(design.roller_radius)]),
        [],
        design.roller_length + 2.0 * design.frame_thickness,
    )
    holes = [_wire([_circle_edge(design.frame_inner_radius)])] + [
        _slot_wire(design, i * design.slot_pitch_rad) for i in range(design.roller_count)
    ]
    frame = _extrude(
        _wire([_circle_edge(design.frame_outer_radius)]), holes, design.frame_thickness
    )
    return {"ring": ring, "cam": cam, "roller": roller, "frame": frame}


#: The FILE_NAME time stamp when SOURCE_DATE_EPOCH is not set (as ezdxf's DXF stamp).
DEFAULT_STAMP = "2000-01-01T00:00:00"
_FILE_NAME = re.compile(r"(FILE_NAME\('(?:[^']|'')*',')(\d{4}-\d\d-\d\dT\d\d:\d\d:\d\d)(')")


def step_timestamp() -> str:
    """The time stamp written into STEP headers: ``SOURCE_DATE_EPOCH`` (UTC) if set and valid.

    Reproducible-builds convention; otherwise a fixed 2000-01-01T00:00:00, so
    the same scene gives the same bytes (the real time of a run is in the
    file's modification time).
    """
    import datetime

    raw = os.environ.get("SOURCE_DATE_EPOCH", "").strip()
    if raw.isdigit():
        try:
            t = datetime.datetime.fromtimestamp(int(raw), tz=datetime.UTC)
            return t.strftime("%Y-%m-%dT%H:%M:%S")
        except (OverflowError, OSError, ValueError):
            pass
    return DEFAULT_STAMP


def _pin_timestamp(path: Path) -> None:
    """Replace Open CASCADE's wall-clock FILE_NAME time stamp by :func:`step_timestamp`."""
    data = Path(path).read_bytes()
    head, sep, rest = data.partition(b"ENDSEC;")
    text = head.decode("latin-1")
    new, n = _FILE_NAME.subn(lambda m: m.group(1) + step_timestamp() + m.group(3), text, count=1)
    if n != 1:
        raise ExportError(f"STEP: no FILE_NAME time stamp found in {path}")
    Path(path).write_bytes(new.encode("latin-1") + sep + rest)


def write_step(shape, path: Path, name: str) -> Path:
    """Write one shape as STEP AP214 via a temporary file."""
    require_ocp()
    from OCP.IFSelect import IFSelect_RetDone
    from OCP.Interface import Interface_Static
    from OCP.STEPControl import STEPControl_AsIs, STEPControl_Writer

    path = Path(path)
    set_cval = _static(Interface_Static, "SetCVal")
    set_cval("write.step.schema", "AP214IS")
    set_cval("write.step.unit", "MM")
    set_cval("write.step.product.name", name)
    writer = STEPControl_Writer()
    if writer.Transfer(shape, STEPControl_AsIs) != IFSelect_RetDone:
        raise ExportError(f"STEP: could not transfer {name}")
    tmp = path.with_name(path.name + ".part.step")
    if writer.Write(str(tmp)) != IFSelect_RetDone:
        raise ExportError(f"STEP: could not write {path}")
    _pin_timestamp(tmp)
    tmp.replace(path)
    return path


def read_step_mesh(path: Path, deflection: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Read a STEP file back; mesh it; return (vertices, faces, bbox (2, 3))."""
    require_ocp()
    from OCP.Bnd import Bnd_Box
    from OCP.BRep import BRep_Tool
    from OCP.BRepBndLib import BRepBndLib
    from OCP.BRepMesh import BRepMesh_IncrementalMesh
    from OCP.IFSelect import IFSelect_RetDone
    from OCP.STEPControl import STEPControl_Reader
    from OCP.TopAbs import TopAbs_FACE, TopAbs_REVERSED
    from OCP.TopExp import TopExp_Explorer
    from OCP.TopLoc import TopLoc_Location
    from OCP.TopoDS import TopoDS

    reader = STEPControl_Reader()
    if reader.ReadFile(str(path)) != IFSelect_RetDone:
        raise ExportError(f"{path}: not a readable STEP file")
    reader.TransferRoots()
    shape = reader.OneShape()
    BRepMesh_IncrementalMesh(shape, float(deflection), False, 0.5, True).Perform()
    verts, faces = [], []
    offset = 0
    exp = TopExp_Explorer(shape, TopAbs_FACE)
    while exp.More():
        face = _static(TopoDS, "Face")(exp.Current())
        loc = TopLoc_Location()
        tri = _static(BRep_Tool, "Triangulation")(face, loc)
        if tri is None:
            raise ExportError(f"{path}: a face could not be meshed")
        trsf = loc.Transformation()
        n = tri.NbNodes()
        pts = np.array([[*_xyz(tri.Node(i).Transformed(trsf))] for i in range(1, n + 1)])
        tris = np.array([tri.Triangle(i).Get() for i in range(1, tri.NbTriangles() + 1)]) - 1
        if face.Orientation() == TopAbs_REVERSED:
            tris = tris[:, ::-1]
        verts.append(pts)
        faces.append(tris + offset)
        offset += n
        exp.Next()
    box = Bnd_Box()
    # The optimal box, from the exact geometry (the plain one is enlarged by
    # tolerances and the triangulation).
    _static(BRepBndLib, "AddOptimal")(shape, box, False, False)
    lo, hi = box.CornerMin(), box.CornerMax()
    bbox = np.array([_xyz(lo), _xyz(hi)])
    return np.vstack(verts), np.vstack(faces), bbox


def _xyz(p):
    return (p.X(), p.Y(), p.Z())


def read_step_curves(path: Path, samples_per_edge: int = 2000) -> list[np.ndarray]:
    """Points (n, 3) sampled on every B-spline edge of a STEP file, as read back by OCP."""
    require_ocp()
    from OCP.BRepAdaptor import BRepAdaptor_Curve
    from OCP.GeomAbs import GeomAbs_BSplineCurve
    from OCP.IFSelect import IFSelect_RetDone
    from OCP.STEPControl import STEPControl_Reader
    from OCP.TopAbs import TopAbs_EDGE
    from OCP.TopExp import TopExp_Explorer
    from OCP.TopoDS import TopoDS

    reader = STEPControl_Reader()
    if reader.ReadFile(str(path)) != IFSelect_RetDone:
        raise ExportError(f"{path}: not a readable STEP file")
    reader.TransferRoots()
    exp = TopExp_Explorer(reader.OneShape(), TopAbs_EDGE)
    out = []
    while exp.More():
        curve = BRepAdaptor_Curve(_static(TopoDS, "Edge")(exp.Current()))
        if curve.GetType() == GeomAbs_BSplineCurve:
            u = np.linspace(curve.FirstParameter(), curve.LastParameter(), samples_per_edge)
            out.append(np.array([_xyz(curve.Value(float(x))) for x in u]))
        exp.Next()
    return out
