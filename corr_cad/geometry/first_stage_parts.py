"""The first stage's parts as extruded outlines, and where they sit at a crank angle.

Parts (file stems): ``pinion``, ``wheel`` (three instances), ``crank_gear``
(the internal gear, bolted to the crankshaft's flange), ``crankshaft``
(flange and shaft; the cams sit on the shaft, whose radius is the cams' bore
radius: the eccentricity ``e`` lies in the cams' eccentric bores, 180 deg
apart, as the second stage's parts are drawn), ``wheel_bearing`` (three
needle-bearing placeholders in the wheel bores) and ``crank_bearing`` (two
placeholder bearings on the shaft, beyond the outer frame plates). The
housing, the wheel pins and the input shaft are not modelled.

Axial layout, below the second stage (z along the shaft, mm; ``b`` the
first stage's face width, ``g = 1`` mm axial gap, ``L = b`` a crank bearing's
width, ``f`` the flange's thickness, ``t`` the frame plate thickness):

* crank bearing 1: ``[-t - g - L, -t - g]``, just below frame plate 0;
* crankshaft flange: ``[z_f, z_f + f]`` with ``z_f + f = -t - 2 g - L``;
* gears: ``[z_f - g - b, z_f - g]``; the crank gear's rim reaches up to the
  flange (height ``b + g``);
* shaft: from the flange to crank bearing 2 above frame plate 2.

Placement (polar angles grow clockwise seen from +z, as everywhere): the
crankshaft and the crank gear turn with the crank, the pinion by ``i1`` times
the crank, each wheel (at ``120 k`` deg, ``a`` from the axis) by
``-z_p / z_w`` times the pinion, with tooth phases that put every tooth into
the middle of its mating space.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from corr_cad.errors import DesignError
from corr_cad.geometry.bearing_parts import OffsetCircle, crankshaft_pieces, seat_radius
from corr_cad.geometry.design import GearDesign
from corr_cad.geometry.first_stage import FirstStageGeometry
from corr_cad.geometry.parts import PartOutline, circle_polygon
from corr_cad.geometry.placement import Placement

__all__ = [
    "FIRST_STAGE_PARTS",
    "FITS",
    "Layout",
    "first_stage_layout",
    "first_stage_outlines",
    "piece_outlines",
    "first_stage_profiles",
    "exact_volume",
    "first_stage_placements",
    "gear_phases",
    "mesh_clearance",
]

#: Part keys of the first stage (also their file stems).
FIRST_STAGE_PARTS = (
    "pinion",
    "wheel",
    "crank_gear",
    "crankshaft",
    "wheel_bearing",
    "crank_bearing",
)
#: Instance-name prefixes that touch by design (a fit, not an interference).
FITS = (
    ("crank_gear", "crankshaft"),
    ("crank_bearing", "crankshaft"),
    ("wheel_bearing", "wheel"),
    ("cam", "crankshaft"),
)
AXIAL_GAP = 1.0
WHEEL_ANGLES = (0.0, 2.0 * math.pi / 3.0, 4.0 * math.pi / 3.0)


def _round(x: float, step: float) -> float:
    return step * math.floor(x / step + 0.5)


@dataclass(frozen=True)
class Layout:
    """Radii and axial positions of the first stage's parts, mm.

    Attributes
    ----------
    z_gears : float
        Bottom face of the gears.
    z_flange, flange_thickness : float
    z_top : float
        Top of the shaft.
    pinion_bore, wheel_bore, wheel_bearing_inner : float
        Radii: the input shaft's seat, the wheel's bore, the pin's.
    shaft_radius, crank_bearing_outer, rim_outer : float
    face_width, bearing_width : float
    bearing_z : tuple of float
        Bottom faces of the two crank bearings.
    """

    z_gears: float
    z_flange: float
    flange_thickness: float
    z_top: float
    pinion_bore: float
    wheel_bore: float
    wheel_bearing_inner: float
    shaft_radius: float
    crank_bearing_outer: float
    rim_outer: float
    face_width: float
    bearing_width: float
    bearing_z: tuple[float, float] = (0.0, 0.0)


def first_stage_layout(design: GearDesign, fs: FirstStageGeometry, rows=None) -> Layout:
    """The stated sizes of the parts the scene does not describe.

    ``rows`` (:func:`corr_cad.geometry.bearing_parts.needle_rows`): the cams float on
    needle bearings, the shaft's radius is the support seats'
    (:func:`~corr_cad.geometry.bearing_parts.seat_radius`). With the crankshaft drawn
    from the crank model (``rows.crank``, a
    :class:`~corr_cad.geometry.bearing_parts.CrankDrawing`) the layout is the model's:
    the flange's face toward the eccentrics at its ``gear_position``, the crank
    bearings of its support ``width`` centred at its ``support_positions``, the shaft
    its ``shaft_diameter`` up to the upper bearing's outer face.
    """
    m, b, g = fs.stage.module, fs.stage.face_width, AXIAL_GAP
    t, w = design.frame_thickness, design.face_width
    f = max(5.0, 2.0 * m)
    crank = getattr(rows, "crank", None)
    z_flange = -t - 2 * g - b - f
    z_top = 2 * w + 2 * t + g + b
    bearing_width = b
    bearing_z = (-t - g - b, 2 * w + 2 * t + g)
    rim = fs.crank_gear.root_radius + 3.0 * m
    shaft = design.cam_bore_radius if rows is None else seat_radius(design, rows)
    outer = _round(shaft * 1.25, 0.5)
    if crank is not None:
        bearing_width = crank.support_width
        s1, s2 = sorted(crank.support_positions)
        hb = 0.5 * bearing_width
        zg = crank.gear_position
        if zg is None or zg > s1 - hb + 1e-9:
            raise DesignError(
                f"[crankshaft] gear_position = {zg!r}: with [first_stage] the crank gear's "
                f"flange sits on the shaft below the lower support bearing (centred at "
                f"{s1:g} mm, {bearing_width:g} mm wide); allowed range (-inf, {s1 - hb:g}] mm, "
                f"e.g. {s1 - 2.0 * hb:g}"
            )
        z_flange = zg - f
        z_top = s2 + hb
        bearing_z = (s1 - hb, s2 - hb)
        outer = 0.5 * crank.support_outer_diameter
    pin_bore = _round(0.4 * fs.pinion.root_radius, 0.5)
    wheel_bore = _round(0.45 * fs.wheel.root_radius, 0.5)
    if shaft + 1.0 >= rim or min(pin_bore, wheel_bore) < 1.0:
        raise DesignError(
            f"module = {m:g}: the first stage is too small for the crankshaft "
            f"(shaft radius {shaft:g} mm, crank gear rim {rim:.4g} mm); use a larger module"
        )
    return Layout(
        z_gears=z_flange - g - b,
        z_flange=z_flange,
        flange_thickness=f,
        z_top=z_top,
        pinion_bore=pin_bore,
        wheel_bore=wheel_bore,
        wheel_bearing_inner=_round(0.75 * wheel_bore, 0.1),
        shaft_radius=shaft,
        crank_bearing_outer=outer,
        rim_outer=rim,
        face_width=b,
        bearing_width=bearing_width,
        bearing_z=bearing_z,
    )


def _oriented(p: np.ndarray, clockwise: bool) -> np.ndarray:
    x, y = p[:, 0], p[:, 1]
    ccw = float(np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1))) > 0
    return p[::-1].copy() if ccw == clockwise else p


def _perimeter(p: np.ndarray) -> float:
    return float(np.sum(np.linalg.norm(np.roll(p, -1, axis=0) - p, axis=1)))


def _polygon_area(p: np.ndarray) -> float:
    x, y = p[:, 0], p[:, 1]
    return 0.5 * abs(float(np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1))))


def _area(c) -> float:
    if isinstance(c, OffsetCircle):
        c = c.radius
    return math.pi * c * c if isinstance(c, float) else _polygon_area(c)


def _length(c) -> float:
    if isinstance(c, OffsetCircle):
        c = c.radius
    return 2.0 * math.pi * c if isinstance(c, float) else _perimeter(c)


def first_stage_profiles(
    design: GearDesign, fs: FirstStageGeometry, gear_vertices: dict, rows=None
) -> dict:
    """Each part as ``[(outer, holes, height, z0), ...]`` extrusions in part coordinates.

    A contour is a circle (its radius, a float), an eccentric circle
    (:class:`~corr_cad.geometry.bearing_parts.OffsetCircle`) or a polyline ((n, 2)
    array: a gear's outline from :func:`~corr_cad.geometry.gear_outline.approximate_gear`,
    its vertices on the exact outline). With ``rows`` (the cams on needle bearings) the
    crankshaft's shaft is :func:`~corr_cad.geometry.bearing_parts.crankshaft_pieces`:
    seats, core and the two eccentric journals.
    """
    lay = first_stage_layout(design, fs, rows)
    b, g = lay.face_width, AXIAL_GAP
    pin, whl, crk = (gear_vertices[k] for k in ("pinion", "wheel", "crank_gear"))
    shaft_len = lay.z_top - (lay.z_flange + lay.flange_thickness)
    shaft = [(lay.shaft_radius, [], shaft_len, lay.flange_thickness)]
    if rows is not None:
        top = lay.z_flange + lay.flange_thickness
        shaft = [
            (o, hs, h, z0 - lay.z_flange)
            for o, hs, h, z0 in crankshaft_pieces(design, rows, lay.bearing_width, top)
        ]
    crank = getattr(rows, "crank", None)
    bore = [0.5 * crank.bore_diameter] if crank is not None and crank.bore_diameter else []
    return {
        "pinion": [(pin, [lay.pinion_bore], b, 0.0)],
        "wheel": [(whl, [lay.wheel_bore], b, 0.0)],
        "crank_gear": [(lay.rim_outer, [crk], b + g, 0.0)],
        "crankshaft": [
            (lay.rim_outer, bore, lay.flange_thickness, 0.0),
            *shaft,
        ],
        "wheel_bearing": [(lay.wheel_bore, [lay.wheel_bearing_inner], b, 0.0)],
        "crank_bearing": [(lay.crank_bearing_outer, [lay.shaft_radius], lay.bearing_width, 0.0)],
    }


def exact_volume(pieces: list) -> float:
    """Volume of a part from :func:`first_stage_profiles` (circles exact), mm^3."""
    return sum((_area(o) - sum(_area(h) for h in hs)) * t for o, hs, t, _ in pieces)


def first_stage_outlines(
    design: GearDesign, fs: FirstStageGeometry, gear_vertices: dict, tol: float, rows=None
) -> dict[str, list[tuple[PartOutline, float]]]:
    """Each part as polygon outlines (circles inscribed within ``tol``) with their bottom z.

    ``exact_area`` counts circles exactly and a gear's outline as its polygon
    (whose deviation from the exact outline is the outline's measured one).
    """
    return piece_outlines(first_stage_profiles(design, fs, gear_vertices, rows), tol)


def piece_outlines(profiles: dict, tol: float) -> dict[str, list[tuple[PartOutline, float]]]:
    """Parts given as :func:`first_stage_profiles` gives them, as polygon outlines."""

    def poly(c):
        if isinstance(c, OffsetCircle):
            return circle_polygon(c.radius, tol, c.centre)
        return circle_polygon(c, tol) if isinstance(c, float) else c

    out = {}
    for part, pieces in profiles.items():
        out[part] = [
            (
                PartOutline(
                    part,
                    _oriented(poly(o), False),
                    [_oriented(poly(h), True) for h in hs],
                    t,
                    _area(o) - sum(_area(h) for h in hs),
                    _length(o) + sum(_length(h) for h in hs),
                ),
                z0,
            )
            for o, hs, t, z0 in pieces
        ]
    return out


def gear_phases(fs: FirstStageGeometry, pinion_rad: float) -> tuple[list[float], float]:
    """Turns of the three wheels and of the crank gear for a pinion turned by ``pinion_rad``.

    Each gear's tooth space 0 is centred on its ``+y`` in part coordinates.
    Across the line of centres a space of one gear faces a tooth of the other;
    rolling maps an angle ``x`` on the pinion to ``x z_p / z_w`` on the wheel
    (opposite sense) and ``x z_w / z_c`` on the crank gear (same sense).
    Raises when the three wheels ask the crank gear for different phases
    (never, if ``(z_p + z_c) / 3`` is whole).
    """
    zp, zw, zc = fs.pinion.teeth, fs.wheel.teeth, fs.crank_gear.teeth
    wheels, crank = [], []
    for beta in WHEEL_ANGLES:
        psi_w = beta + math.pi - (pinion_rad - beta) * zp / zw - math.pi / zw
        wheels.append(psi_w)
        crank.append(beta + (psi_w + math.pi / zw - beta) * zw / zc)
    pitch = 2.0 * math.pi / zc
    spread = [((c - crank[0] + 0.5 * pitch) % pitch) - 0.5 * pitch for c in crank]
    if max(abs(s) for s in spread) > 1e-9:
        raise DesignError("the three wheels cannot all mesh with the crank gear")
    return wheels, crank[0]


def first_stage_placements(
    design: GearDesign, fs: FirstStageGeometry, crank_angle_rad: float, rows=None
) -> list[Placement]:
    """The first stage's instances at ``crank_angle_rad`` (relative to the frame).

    The crankshaft turns by ``crank + crank / z`` (as the cams); the pinion
    by ``i1`` times that; the crank gear's phase follows from the meshes.
    ``rows`` as :func:`first_stage_layout` takes them (the axial places).
    """
    lay = first_stage_layout(design, fs, rows)
    phi = crank_angle_rad + crank_angle_rad / design.tooth_count
    pinion = fs.ratio * phi
    wheels, crank = gear_phases(fs, pinion)
    a = fs.centre_distance
    zg = lay.z_gears
    out = [
        Placement("pinion", "pinion", pinion, (0.0, 0.0, zg)),
        Placement("crank_gear", "crank_gear", crank, (0.0, 0.0, zg)),
        Placement("crankshaft", "crankshaft", phi, (0.0, 0.0, lay.z_flange)),
    ]
    for k, (beta, psi) in enumerate(zip(WHEEL_ANGLES, wheels, strict=True), 1):
        x, y = a * math.sin(beta), a * math.cos(beta)
        out.append(Placement(f"wheel_{k}", "wheel", psi, (x, y, zg)))
        out.append(Placement(f"wheel_bearing_{k}", "wheel_bearing", psi, (x, y, zg)))
    below, above = lay.bearing_z
    out.append(Placement("crank_bearing_1", "crank_bearing", phi, (0.0, 0.0, below)))
    out.append(Placement("crank_bearing_2", "crank_bearing", phi, (0.0, 0.0, above)))
    return out


def _local_gap(a: np.ndarray, b: np.ndarray, centre: np.ndarray, radius: float) -> float:
    """Smallest distance between two closed polylines near ``centre`` (vertex to segment)."""

    def near(p):
        return np.flatnonzero(np.linalg.norm(p - centre, axis=1) < radius)

    def vertex_to_segments(q, p, idx):
        s0, s1 = p[idx], p[(idx + 1) % len(p)]
        d = s1 - s0
        # |q - s0| bounds a vertex's distance to a segment from above and |q - s0| - |d|
        # from below: only the pairs whose lower bound reaches the least upper bound can
        # hold the minimum (a 1e-9 mm margin for rounding), and only they are projected
        r = np.hypot(q[:, None, 0] - s0[None, :, 0], q[:, None, 1] - s0[None, :, 1])
        qi, si = np.nonzero(r - np.hypot(d[:, 0], d[:, 1])[None] <= r.min() + 1e-9)
        qq, ss, dd = q[qi], s0[si], d[si]
        t = np.clip(np.einsum("ij,ij->i", qq - ss, dd) / np.einsum("ij,ij->i", dd, dd), 0, 1)
        return float(np.linalg.norm(qq - (ss + t[:, None] * dd), axis=-1).min())

    ia, ib = near(a), near(b)
    return min(vertex_to_segments(a[ia], b, ib), vertex_to_segments(b[ib], a, ia))


def mesh_clearance(
    design: GearDesign, fs: FirstStageGeometry, gear_vertices: dict, positions: int = 36
) -> dict:
    """Exact 2D clearance of both meshes over one pinion tooth pitch (the period of both).

    The gears' outline polygons are placed as in the assembly at ``positions``
    pinion angles across one pinion pitch (the wheels then advance one wheel
    pitch: every tooth pair repeats); per mesh the smallest distance between
    a wheel and the pinion, and between a wheel and the crank gear's teeth,
    over the three wheels, measured between the polylines within 4 modules of
    the pitch point (vertex to segment). Negative (-1): the outlines overlap.
    """
    import shapely

    def placed(part: str, angle: float, offset=(0.0, 0.0)) -> np.ndarray:
        v = gear_vertices[part]
        c, s = math.cos(angle), math.sin(angle)
        return np.stack([v[:, 0] * c + v[:, 1] * s, -v[:, 0] * s + v[:, 1] * c], 1) + offset

    a, m = fs.centre_distance, fs.stage.module
    r1 = fs.pinion.base_radius / math.cos(math.radians(fs.working_pressure_angle_deg[0]))
    r2 = fs.crank_gear.base_radius / math.cos(math.radians(fs.working_pressure_angle_deg[1]))
    pitch = 2.0 * math.pi / fs.pinion.teeth
    gaps = {"pinion_wheel": [], "wheel_crank_gear": []}
    for j in range(positions):
        p = j * pitch / positions
        wheels, crank = gear_phases(fs, p)
        pin, ring = placed("pinion", p), placed("crank_gear", crank)
        pin_poly, ring_poly = shapely.Polygon(pin), shapely.Polygon(ring)
        g1, g2 = math.inf, math.inf
        for beta, psi in zip(WHEEL_ANGLES, wheels, strict=True):
            u = np.array([math.sin(beta), math.cos(beta)])
            w = placed("wheel", psi, a * u)
            w_poly = shapely.Polygon(w)
            overlap1 = shapely.contains_xy(pin_poly, w[:, 0], w[:, 1]).any()
            overlap2 = not shapely.contains_xy(ring_poly, w[:, 0], w[:, 1]).all()
            g1 = min(g1, -1.0 if overlap1 else _local_gap(pin, w, r1 * u, 4 * m))
            g2 = min(g2, -1.0 if overlap2 else _local_gap(ring, w, r2 * u, 4 * m))
            if shapely.contains_xy(w_poly, pin[:, 0], pin[:, 1]).any():
                g1 = -1.0
        gaps["pinion_wheel"].append(g1)
        gaps["wheel_crank_gear"].append(g2)
    return {
        "positions": positions,
        "period": "one pinion tooth pitch",
        **{f"{k}_min_gap_mm": float(min(v)) for k, v in gaps.items()},
        "ok": bool(min(min(v) for v in gaps.values()) > 0),
    }
