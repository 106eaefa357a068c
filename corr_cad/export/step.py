"""STEP AP214 export as real B-rep solids (Open CASCADE via OCP, an optional extra).

The working profile goes in as the ``spline`` approximation (the curve the
``spline`` DXF holds, within the tolerance), written as cubic B-spline edges
of three knot spans each (:mod:`corr_cad.export.step_profile`): each edge is
its tooth's B-spline cut at two of its knots, the same cubic pieces, so the
edges are the same curve, joined C1 through shared vertices, and every tooth
is a whole number of edges. Circles are exact circles, slots exact lines and
arcs. Faces are extruded to solids.

Why so few spans per edge: Open CASCADE's mass properties (``BRepGProp``,
what FreeCAD's ``Shape.Volume`` calls) integrate each face of an extruded
edge with a fixed number of Gauss points, whatever the edge's knot count.
On one edge of the whole profile that gives 134,818 mm^3 for a 354,305 mm^3
ring; one edge per tooth still misses by 2e-5 (z = 25) to 8e-5 (z = 39); one
edge per span is integrated exactly (1e-12 against the spline's own area),
three spans per edge within 2.4e-7 (z = 25) to 6.4e-7 (z = 39) of that (a
tenth to a fifth of the spline's own area error at 0.001 mm) in 40 % of the
bytes, which Open CASCADE writes, and every reader parses, at a cost that
grows with them.

Every file is written through XCAF, so each STEP product carries its part's
name; :func:`write_assembly_step` writes the placed assembly as instances
of those products.
"""

from __future__ import annotations

import errno
import math
import os
import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from corr_cad.errors import ExportError
from corr_cad.export.files import writing
from corr_cad.geometry.design import GearDesign
from corr_cad.geometry.parts import frame_slot_outline, roller_solid_length
from corr_cad.geometry.placement import Placement
from corr_cad.geometry.sampling import ProfileApproximation

__all__ = [
    "require_ocp",
    "part_shapes",
    "write_step",
    "write_assembly_step",
    "write_compound_step",
    "read_solids",
    "read_step",
    "StepPart",
    "mass_properties",
    "volume",
    "bounding_box",
    "readback_facts",
    "unplaced",
    "transform_points",
    "read_step_curves",
]

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


def _static(cls, name: str):
    """OCP 7 suffixes static methods with ``_s``; OCP 8 does not.

    The suffixed name wins: ``TDataStd_Name.Set`` is also an instance method.
    """
    return getattr(cls, name + "_s", None) or getattr(cls, name)


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


def part_shapes(
    design: GearDesign, working_spline: ProfileApproximation, floating: bool = False
) -> dict:
    """B-rep solids of ``ring``, ``cam``, ``roller`` and ``frame`` (part coordinates);
    with ``floating`` the cam's bore concentric (its needle bearing's outer race)."""
    from corr_cad.export.step_profile import profile_edges

    require_ocp()
    ring = _extrude(
        _wire([_circle_edge(design.ring_outer_radius)]),
        [_wire(profile_edges(working_spline))],
        design.face_width,
    )
    bore = (0.0, 0.0 if floating else -design.eccentricity)
    cam = _extrude(
        _wire([_circle_edge(design.cam_radius)]),
        [_wire([_circle_edge(design.cam_bore_radius, bore)])],
        design.face_width,
    )
    roller = _extrude(
        _wire([_circle_edge(design.roller_radius)]),
        [],
        roller_solid_length(design),
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


# --- writing ------------------------------------------------------------------
def _new_document():
    """An XCAF document and its shape tool."""
    from OCP.TCollection import TCollection_ExtendedString
    from OCP.TDocStd import TDocStd_Document
    from OCP.XCAFApp import XCAFApp_Application
    from OCP.XCAFDoc import XCAFDoc_DocumentTool, XCAFDoc_ShapeTool

    app = _static(XCAFApp_Application, "GetApplication")()
    doc = TDocStd_Document(TCollection_ExtendedString("MDTV-XCAF"))
    app.InitDocument(doc)
    tool = _static(XCAFDoc_DocumentTool, "ShapeTool")(doc.Main())
    _static(XCAFDoc_ShapeTool, "SetAutoNaming")(False)
    return doc, tool


def _set_name(label, name: str) -> None:
    from OCP.TCollection import TCollection_ExtendedString
    from OCP.TDataStd import TDataStd_Name

    _static(TDataStd_Name, "Set")(label, TCollection_ExtendedString(name))


def _write_document(doc, path: Path, what: str, subshape_names: bool = False) -> Path:
    """Write an XCAF document as STEP AP214 (mm) via a temporary file;
    ``subshape_names`` writes the names of sub-shape labels (on their solids)."""
    from OCP.IFSelect import IFSelect_RetDone
    from OCP.Interface import Interface_Static
    from OCP.STEPCAFControl import STEPCAFControl_Writer
    from OCP.STEPControl import STEPControl_AsIs

    path = Path(path)
    # The first writer initialises Open CASCADE's STEP statics: set ours after.
    writer = STEPCAFControl_Writer()
    set_cval = _static(Interface_Static, "SetCVal")
    set_cval("write.step.schema", "AP214IS")
    set_cval("write.step.unit", "MM")
    # With 2D parameter curves beside the 3D ones (half the file's size): a
    # reader without them must rebuild them by shape healing, and an unhealed
    # read of such a file gives Open CASCADE's GProp a third of the volume.
    _static(Interface_Static, "SetIVal")("write.surfacecurve.mode", 1)
    _static(Interface_Static, "SetIVal")("write.stepcaf.subshapes.name", int(subshape_names))
    writer.SetNameMode(True)
    writer.SetColorMode(False)
    writer.SetLayerMode(False)
    if not writer.Transfer(doc, STEPControl_AsIs):
        raise ExportError(f"STEP: could not transfer {what}")
    with writing(path, ".part.step") as tmp:
        if writer.Write(str(tmp)) != IFSelect_RetDone:
            raise OSError(errno.EIO, "Open CASCADE could not write the STEP file (disk full?)")
        _pin_timestamp(tmp)
    return path


def write_step(shape, path: Path, name: str) -> Path:
    """Write one solid as STEP AP214 (mm) whose product is named ``name``."""
    require_ocp()
    doc, tool = _new_document()
    label = tool.AddShape(shape, False)
    _set_name(label, name)
    return _write_document(doc, path, name)


def _location(p: Placement):
    """``T(offset) . Rz(-angle) . T(pre_offset)`` as an OCC location."""
    from OCP.gp import gp_Ax1, gp_Dir, gp_Trsf, gp_Vec
    from OCP.TopLoc import TopLoc_Location

    pre, rot, post = gp_Trsf(), gp_Trsf(), gp_Trsf()
    pre.SetTranslation(gp_Vec(float(p.pre_offset[0]), float(p.pre_offset[1]), 0.0))
    # Polar angles grow clockwise seen from +z: a mathematical rotation by -angle.
    rot.SetRotation(gp_Ax1(_pnt(0, 0, 0), gp_Dir(0, 0, 1)), -float(p.angle_rad))
    post.SetTranslation(gp_Vec(*(float(c) for c in p.offset)))
    return TopLoc_Location(post.Multiplied(rot).Multiplied(pre))


def write_assembly_step(
    shapes: dict,
    part_names: dict[str, str],
    placements: list[Placement],
    path: Path,
    name: str,
) -> Path:
    """Write an assembly: one product per part, one named instance per placement.

    ``shapes`` and ``part_names`` are keyed by part (``ring``, ``cam``, ...);
    each placement puts an instance of ``shapes[p.part]`` named ``p.name``.
    """
    require_ocp()
    doc, tool = _new_document()
    top = tool.NewShape()
    _set_name(top, name)
    labels = {}
    for key in dict.fromkeys(p.part for p in placements):
        labels[key] = tool.AddShape(shapes[key], False)
        _set_name(labels[key], part_names[key])
    for p in placements:
        comp = tool.AddComponent(top, labels[p.part], _location(p))
        _set_name(comp, p.name)
    tool.UpdateAssemblies()
    return _write_document(doc, path, name)


def write_compound_step(shapes: dict, placements: list[Placement], path: Path, name: str) -> Path:
    """Write every placed instance as its own solid of one compound, the
    file's only product ``name``, without an assembly structure; each solid
    carries its instance's name (``MANIFOLD_SOLID_BREP``). FreeCAD 0.20's
    headless importer opens this with its default preferences, where it
    crashes on any file of two or more shapes."""
    require_ocp()
    from OCP.BRep import BRep_Builder
    from OCP.TopoDS import TopoDS_Compound

    builder, compound = BRep_Builder(), TopoDS_Compound()
    builder.MakeCompound(compound)
    moved = [shapes[p.part].Moved(_location(p)) for p in placements]
    for shape in moved:
        builder.Add(compound, shape)
    doc, tool = _new_document()
    top = tool.AddShape(compound, False, False)
    _set_name(top, name)
    for p, shape in zip(placements, moved, strict=True):
        _set_name(tool.AddSubShape(top, shape), p.name)
    return _write_document(doc, path, name, subshape_names=True)


def read_solids(path: Path, heal: bool = True) -> list:
    """The solids of a STEP file, in file order (Open CASCADE's own reader)."""
    from OCP.TopAbs import TopAbs_SOLID
    from OCP.TopExp import TopExp_Explorer

    explorer = TopExp_Explorer(_read_one_shape(path, heal), TopAbs_SOLID)
    solids = []
    while explorer.More():
        solids.append(explorer.Current())
        explorer.Next()
    return solids


# --- reading back -------------------------------------------------------------
@dataclass
class StepPart:
    """One solid read back from a STEP file.

    ``name`` is its instance name in an assembly, else its product name;
    ``product`` the name of the product it instantiates; ``shape`` is placed.
    """

    name: str
    product: str
    shape: object


def _label_sequence():
    try:  # OCP 8
        from OCP.OCP.collections import Sequence_TDF_Label
    except ImportError:  # OCP 7
        from OCP.TDF import TDF_LabelSequence as Sequence_TDF_Label
    return Sequence_TDF_Label()


def _label_name(label) -> str:
    from OCP.TDataStd import TDataStd_Name

    attr = TDataStd_Name()
    if label.FindAttribute(_static(TDataStd_Name, "GetID")(), attr):
        return attr.Get().ToExtString()
    return ""


def _healing_off(reader) -> None:
    """Switch Open CASCADE's shape healing off for one transfer (after ReadFile).

    Healing (``FixShape``, on by default) checks every wire for
    self-intersection and reorders it, quadratic in the edges of a wire: 2.5 s
    for a z = 39 ring. Our files are built clean; the tests read them with
    healing on, as FreeCAD does, and get the same mass properties.
    """
    from OCP.OCP.collections import DataMap_TCollection_AsciiString_TCollection_AsciiString
    from OCP.TCollection import TCollection_AsciiString

    params = DataMap_TCollection_AsciiString_TCollection_AsciiString()
    for mode in _FIX_MODES:
        params.Bind(TCollection_AsciiString(f"FixShape.{mode}"), TCollection_AsciiString("0"))
    reader.SetShapeFixParameters(params)


_FIX_MODES = (
    "FixFreeShellMode FixFreeFaceMode FixFreeWireMode FixSameParameterMode FixSolidMode "
    "FixShellOrientationMode CreateOpenSolidMode FixShellMode FixFaceOrientationMode FixFaceMode "
    "FixWireMode FixOrientationMode FixAddNaturalBoundMode FixMissingSeamMode "
    "FixSmallAreaWireMode RemoveSmallAreaFaceMode FixIntersectingWiresMode FixLoopWiresMode "
    "FixSplitFaceMode AutoCorrectPrecisionMode ModifyTopologyMode ModifyGeometryMode "
    "ClosedWireMode PreferencePCurveMode FixReorderMode FixSmallMode FixConnectedMode "
    "FixEdgeCurvesMode FixDegeneratedMode FixLackingMode FixSelfIntersectionMode RemoveLoopMode "
    "FixReversed2dMode FixRemovePCurveMode FixRemoveCurve3dMode FixAddPCurveMode "
    "FixAddCurve3dMode FixSeamMode FixShiftedMode FixEdgeSameParameterMode FixNotchedEdgesMode "
    "FixTailMode FixSelfIntersectingEdgeMode FixIntersectingEdgesMode "
    "FixNonAdjacentIntersectingEdgesMode FixVertexPositionMode FixVertexToleranceMode"
).split()


def read_step(path: Path, heal: bool = True) -> tuple[str, list[StepPart]]:
    """Read a STEP file with its names (XCAF): ``(top product name, solids)``.

    A single-part file gives one :class:`StepPart`; an assembly gives one per
    instance, its shape moved to the instance's location. ``heal=False``
    skips Open CASCADE's shape healing (see :func:`_healing_off`).
    """
    require_ocp()
    from OCP.IFSelect import IFSelect_RetDone
    from OCP.STEPCAFControl import STEPCAFControl_Reader
    from OCP.TDF import TDF_Label
    from OCP.XCAFDoc import XCAFDoc_ShapeTool

    doc, tool = _new_document()
    reader = STEPCAFControl_Reader()
    reader.SetNameMode(True)
    reader.SetColorMode(False)
    reader.SetLayerMode(False)
    if reader.ReadFile(str(path)) != IFSelect_RetDone:
        raise ExportError(f"{path}: not a readable STEP file")
    if not heal:
        _healing_off(reader.ChangeReader())
    if not reader.Transfer(doc):
        raise ExportError(f"{path}: its shapes could not be transferred")
    roots = _label_sequence()
    tool.GetFreeShapes(roots)
    if roots.Length() != 1:
        raise ExportError(f"{path}: expected one top-level product, found {roots.Length()}")
    top = roots.Value(1)
    is_assembly = _static(XCAFDoc_ShapeTool, "IsAssembly")
    get_shape = _static(XCAFDoc_ShapeTool, "GetShape")
    parts = []
    if is_assembly(top):
        comps = _label_sequence()
        _static(XCAFDoc_ShapeTool, "GetComponents")(top, comps, False)
        for i in range(1, comps.Length() + 1):
            comp = comps.Value(i)
            ref = TDF_Label()
            _static(XCAFDoc_ShapeTool, "GetReferredShape")(comp, ref)
            # A component's shape carries its location.
            parts.append(StepPart(_label_name(comp), _label_name(ref), get_shape(comp)))
    else:
        parts.append(StepPart(_label_name(top), _label_name(top), get_shape(top)))
    return _label_name(top), parts


def volume(shape) -> float:
    """Open CASCADE's own volume of ``shape``, mm^3 (:func:`mass_properties`' first figure,
    without the surface integral)."""
    from OCP.BRepGProp import BRepGProp
    from OCP.GProp import GProp_GProps

    vol = GProp_GProps()
    _static(BRepGProp, "VolumeProperties")(shape, vol)
    return float(vol.Mass())


def mass_properties(shape) -> tuple[float, float]:
    """Open CASCADE's own ``(volume mm^3, surface area mm^2)`` of ``shape`` (BRepGProp)."""
    from OCP.BRepGProp import BRepGProp
    from OCP.GProp import GProp_GProps

    vol, area = GProp_GProps(), GProp_GProps()
    _static(BRepGProp, "VolumeProperties")(shape, vol)
    _static(BRepGProp, "SurfaceProperties")(shape, area)
    return float(vol.Mass()), float(area.Mass())


def bounding_box(shape, optimal: bool = True) -> np.ndarray:
    """The box (2, 3) of ``shape``, mm: the optimal one from its exact geometry,
    or (``optimal=False``) Open CASCADE's quick one, from control points and
    enlarged by tolerances, 4 to 20 times faster: equal for equal geometry."""
    from OCP.Bnd import Bnd_Box
    from OCP.BRepBndLib import BRepBndLib

    box = Bnd_Box()
    if optimal:
        _static(BRepBndLib, "AddOptimal")(shape, box, False, False)
    else:
        _static(BRepBndLib, "Add")(shape, box, False)
    return np.array([_xyz(box.CornerMin()), _xyz(box.CornerMax())])


def unplaced(shape):
    """``shape`` without its location (an assembly instance's product shape)."""
    from OCP.TopLoc import TopLoc_Location

    return shape.Located(TopLoc_Location())


def transform_points(shape, points: np.ndarray) -> np.ndarray:
    """``points`` (n, 3) moved by ``shape``'s location, as Open CASCADE applies it."""
    from OCP.gp import gp_Pnt

    trsf = shape.Location().Transformation()
    return np.array([_xyz(gp_Pnt(*map(float, q)).Transformed(trsf)) for q in points])


def _read_one_shape(path: Path, heal: bool = True):
    from OCP.IFSelect import IFSelect_RetDone
    from OCP.STEPControl import STEPControl_Reader

    reader = STEPControl_Reader()
    if reader.ReadFile(str(path)) != IFSelect_RetDone:
        raise ExportError(f"{path}: not a readable STEP file")
    if not heal:
        _healing_off(reader)
    reader.TransferRoots()
    return reader.OneShape()


def _xyz(p):
    return (p.X(), p.Y(), p.Z())


def read_step_curves(path: Path, samples_per_edge: int = 200) -> list[np.ndarray]:
    """Points (n, 3) sampled on every distinct B-spline edge of a STEP file, as read by OCP."""
    require_ocp()
    from OCP.BRepAdaptor import BRepAdaptor_Curve
    from OCP.GeomAbs import GeomAbs_BSplineCurve
    from OCP.TopAbs import TopAbs_EDGE
    from OCP.TopExp import TopExp
    from OCP.TopoDS import TopoDS

    try:  # OCP 8
        from OCP.OCP.collections import (
            IndexedMap_TopoDS_Shape_TopTools_ShapeMapHasher as IndexedMapOfShape,
        )
    except ImportError:  # OCP 7
        from OCP.TopTools import TopTools_IndexedMapOfShape as IndexedMapOfShape

    edges = IndexedMapOfShape()
    _static(TopExp, "MapShapes")(_read_one_shape(path, heal=False), TopAbs_EDGE, edges)
    out = []
    for i in range(1, edges.Extent() + 1):
        curve = BRepAdaptor_Curve(_static(TopoDS, "Edge")(edges.FindKey(i)))
        if curve.GetType() == GeomAbs_BSplineCurve:
            u = np.linspace(curve.FirstParameter(), curve.LastParameter(), samples_per_edge)
            out.append(np.array([_xyz(curve.Value(float(x))) for x in u]))
    return out


def readback_facts(
    fname: str, product: str, expected: str, shape, exact: float, bound: float, **extra
) -> dict:
    """The read-back check of one part file: its product name, Open CASCADE's volume
    and area, the exact volume with the allowed error ``bound`` and the box, then
    ``extra``; raises :class:`ExportError` when the name or the volume is off."""
    volume, area = mass_properties(shape)
    facts = {
        "product_name": product,
        "readback_volume_mm3": volume,
        "readback_area_mm2": area,
        "exact_volume_mm3": exact,
        "volume_error_mm3": volume - exact,
        "volume_relative_error": (volume - exact) / exact,
        "volume_error_bound_mm3": bound,
        "bbox_mm": bounding_box(shape).tolist(),
        **extra,
    }
    if product != expected or not abs(facts["volume_error_mm3"]) <= bound:
        raise ExportError(f"{fname}: read-back check failed ({facts})")
    return facts
