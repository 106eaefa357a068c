"""Wire-EDM files: ``inner_gear_edm.dxf`` and ``inner_gear_edm.nc`` from one :class:`EdmProgram`.

Both files are written from the same rounded moves, so they describe the
same path: the DXF vertices are the G-code end points, each DXF bulge is the
sweep of the G-code arc about its programmed centre.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from corr_cad._version import __version__
from corr_cad.export import dxf
from corr_cad.export.files import _atomic_text
from corr_cad.geometry.design import GearDesign
from corr_cad.shop.edm import EdmProgram, Move

__all__ = ["write_edm_dxf", "write_gcode", "EDM_FILES"]

EDM_FILES = ("inner_gear_edm.dxf", "inner_gear_edm.nc")


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
    extra = {f"corr_cad.edm.{k}": v for k, v in prog.as_dict().items() if not isinstance(v, dict)}
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


def _move_line(m: Move, dec: int) -> str:
    x, y = (f"{v:.{dec}f}" for v in m.end)
    if m.kind == "line":
        return f"G01 X{x} Y{y}"
    i, j = (f"{c - s:.{dec}f}" for c, s in zip(m.centre, m.start, strict=True))
    return f"{'G02' if m.clockwise else 'G03'} X{x} Y{y} I{i} J{j}"


def write_gcode(design: GearDesign, prog: EdmProgram, scene_name: str, path: Path) -> Path:
    """ISO G-code (G21, G90, G17; G01/G02/G03 in XY; I, J incremental from the arc start)."""
    dec = prog.decimals
    d = design
    li = prog.lead_in_point
    hx, hy = (f"{v:.{dec}f}" for v in prog.start_hole_centre)
    peak = li.get("peak_gear_force_N")
    load = f", peak gear force there {peak:.4g} N" if peak is not None else ""
    head = [
        "%",
        f"(corr_cad {__version__} wire EDM program, scene {scene_name})",
        f"(part: inner gear, z = {d.tooth_count}, e = {d.eccentricity:g}, Rj = {d.cam_radius:g}, "
        f"r = {d.roller_radius:g}, L = Rj + r = {d.link_length:g} mm)",
        "(units mm, absolute, XY plane; origin on the gear axis, tooth space 1 on +Y)",
        f"(wire diameter {prog.spec.wire_diameter:g} mm + spark gap {prog.spec.spark_gap:g} mm: "
        f"wire centre offset {prog.spec.offset:g} mm into the opening, the scrap side)",
        "(offset already in the path: no G41/G42 compensation)",
        f"(contour: exact offset of the exact working profile by {prog.spec.offset:g} mm, "
        f"tangent-continuous arcs, tolerance {prog.tolerance:g} mm)",
        f"(measured max deviation of this path from the exact offset curve: "
        f"{prog.written_deviation:.3g} mm)",
        f"(smallest concave radius seen from the scrap side: "
        f"{prog.smallest_concave_radius:.6g} mm)",
        f"(start hole: diameter {prog.spec.start_hole_diameter:g} mm at X{hx} Y{hy})",
        f"(lead-in: tangent at the {li['where']}; chosen by {li['source']}{load})",
        "(cut direction: clockwise seen from +Z)",
        "G21",
        "G90",
        "G17",
        "G40",
        f"G00 X{hx} Y{hy} (start hole centre: thread the wire here)",
        "(lead-in)",
    ]
    body = [_move_line(m, dec) for m in prog.lead_in]
    body[0] += f" F{prog.spec.feed_mm_per_min:g}"
    body.append("(contour)")
    body += [_move_line(m, dec) for m in prog.contour]
    body.append("(lead-out)")
    body += [_move_line(m, dec) for m in prog.lead_out]
    body += ["M30", "%"]
    return _atomic_text(Path(path), "\n".join(head + body) + "\n")
