"""Wire-EDM files: ``inner_gear_edm.dxf`` and ``inner_gear_edm.nc`` from one :class:`EdmProgram`.

Both files are written from the same rounded moves, so they describe the
same path: the DXF vertices are the G-code end points, each DXF bulge is the
sweep of the G-code arc about its programmed centre. The G-code itself, in
the dialect of the control, is written by :mod:`corr_cad.export.gcode`.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from corr_cad.export import dxf
from corr_cad.export.gcode import write_gcode
from corr_cad.geometry.design import GearDesign
from corr_cad.shop.edm import EdmProgram, Move

__all__ = ["write_edm_dxf", "write_gcode", "EDM_FILES"]

EDM_FILES = ("inner_gear_edm.dxf", "inner_gear_edm.nc")

#: Metadata added with G41/G42 and the slug stop: written into the DXF only when it
#: differs from these (the old behaviour), so an old scene's DXF stays byte-identical.
_QUIET_DEFAULTS = {"compensation": "path", "cut_direction": "clockwise", "slug_stop_mm": 0.0}


def _open_polyline(msp, moves: tuple[Move, ...], layer: str, close: bool) -> None:
    pts = [m.start for m in moves] + ([] if close else [moves[-1].end])
    bul = [m.bulge for m in moves] + ([] if close else [0.0])
    pl = msp.add_lwpolyline([], format="xyb", close=close, dxfattribs={"layer": layer})
    packed = np.zeros((len(pts), 5))
    packed[:, :2] = pts
    packed[:, 4] = bul
    pl.lwpoints.values = packed


def write_edm_dxf(design: GearDesign, prog: EdmProgram, path: Path) -> Path:
    """Only what is cut: CUT (closed contour), START_HOLE (circle), LEAD (lead-in, lead-out)."""
    extra = {
        f"corr_cad.edm.{k}": v
        for k, v in prog.as_dict().items()
        if not isinstance(v, dict) and _QUIET_DEFAULTS.get(k, ...) != v
    }
    extra["corr_cad.edm.lead_in"] = prog.lead_in_point["where"]
    extra["corr_cad.edm.lead_in_source"] = prog.lead_in_point["source"]
    doc = dxf._new_doc(design, "inner_gear_edm", extra)
    for name, color in (("CUT", 1), ("START_HOLE", 3), ("LEAD", 5)):
        doc.layers.add(name, color=color)
    msp = doc.modelspace()
    _open_polyline(msp, prog.contour, "CUT", close=True)
    msp.add_circle(
        prog.start_hole_centre,
        0.5 * prog.spec.start_hole_diameter,
        dxfattribs={"layer": "START_HOLE"},
    )
    _open_polyline(msp, prog.lead_in, "LEAD", close=False)
    _open_polyline(msp, prog.lead_out, "LEAD", close=False)
    return dxf._save(doc, path)
