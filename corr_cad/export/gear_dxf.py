"""DXF files of the first gear stage: ``pinion.dxf``, ``wheel.dxf``, ``crank_gear.dxf``.

Each holds the gear's outline as one closed LWPOLYLINE on layer ``PROFILE``
(within the measured deviation written in its header), its pitch and base
circles on the reference layers ``PITCH_CIRCLE`` and ``BASE_CIRCLE`` (not to
be cut; grey, where the cut layers are red, white and blue), the bore of
the pinion and of the wheel on ``BORE``, and, for the internal crank gear,
the rim's outer circle on ``RIM_OUTER``: every contour of the solid, so the
file alone cuts the part. Same units, header and reproducible bytes as the
ring's files.

``crankshaft.dxf``, ``wheel_bearing.dxf`` and ``crank_bearing.dxf`` draw the
round parts as circles: each extruded piece's outer circle on ``OUTER_<n>``
and its bore on ``BORE_<n>`` (``n`` counts the pieces from the bottom: the
crankshaft's flange is 1, its shaft 2), with each piece's thickness and
bottom in the header.
"""

from __future__ import annotations

from pathlib import Path

from corr_cad.export.dxf import _layer, _new_doc, _save
from corr_cad.geometry.design import GearDesign
from corr_cad.geometry.first_stage import FirstStageGeometry
from corr_cad.geometry.first_stage_parts import first_stage_layout
from corr_cad.geometry.gear_outline import GearOutline

__all__ = ["GEAR_PARTS", "write_gear", "write_gears", "write_round_part"]

#: The first stage's parts with a tooth outline, in the order they are written.
GEAR_PARTS = ("pinion", "wheel", "crank_gear")


def write_gear(
    design: GearDesign, fs: FirstStageGeometry, part: str, outline: GearOutline, path: Path
) -> Path:
    """One gear's DXF (``part`` in :data:`GEAR_PARTS`)."""
    g = getattr(fs, part)
    lay = first_stage_layout(design, fs)
    extra = {
        "representation": "polyline",
        "tolerance_mm": outline.tolerance,
        "max_deviation_mm": outline.max_deviation,
        "within_tolerance": str(outline.within_tolerance).lower(),
        "teeth": g.teeth,
        "module_mm": g.module,
        "pressure_angle_deg": fs.stage.pressure_angle_deg,
        "shift": g.shift,
        "tip_radius_mm": g.tip,
        "root_radius_mm": g.root_radius,
        "face_width_mm": fs.stage.face_width,
    }
    doc = _new_doc(design, part, {f"corr_cad.{k}": v for k, v in extra.items()})
    msp = doc.modelspace()
    msp.add_lwpolyline(
        outline.vertices.tolist(), close=True, dxfattribs={"layer": _layer(doc, "PROFILE")}
    )
    circles = {"PITCH_CIRCLE": g.pitch_radius, "BASE_CIRCLE": g.base_radius}
    if g.internal:
        circles["RIM_OUTER"] = lay.rim_outer
    else:
        circles["BORE"] = lay.pinion_bore if part == "pinion" else lay.wheel_bore
    for layer, radius in circles.items():
        msp.add_circle((0.0, 0.0), radius, dxfattribs={"layer": _layer(doc, layer)})
    return _save(doc, path)


def write_gears(
    design: GearDesign, fs: FirstStageGeometry, outlines: dict, out_dir: Path
) -> list[Path]:
    """``pinion.dxf``, ``wheel.dxf`` and ``crank_gear.dxf`` in ``out_dir``."""
    return [
        write_gear(design, fs, part, outlines[part], Path(out_dir) / f"{part}.dxf")
        for part in GEAR_PARTS
    ]


def write_round_part(design: GearDesign, part: str, pieces: list, path: Path) -> Path:
    """A part made of extruded circles and annuli (``[(outer, holes, height, z0), ...]``)."""
    extra = {}
    for n, (_, _, height, z0) in enumerate(pieces, 1):
        extra[f"corr_cad.piece_{n}_thickness_mm"] = height
        extra[f"corr_cad.piece_{n}_bottom_mm"] = z0
    doc = _new_doc(design, part, extra)
    msp = doc.modelspace()
    for n, (outer, holes, _, _) in enumerate(pieces, 1):
        centre, radius = (0.0, 0.0), outer
        if hasattr(outer, "centre"):  # an eccentric journal (bearing_parts.OffsetCircle)
            centre, radius = tuple(outer.centre), outer.radius
        msp.add_circle(centre, radius, dxfattribs={"layer": _layer(doc, f"OUTER_{n}")})
        for h in holes:
            msp.add_circle((0.0, 0.0), h, dxfattribs={"layer": _layer(doc, f"BORE_{n}")})
    return _save(doc, path)
