"""2D outlines of the second-stage parts, and their exact areas.

One source of truth for the part geometry: the DXF exporter draws these
shapes exactly (circles, bulge arcs, the profile approximation); the mesh
and STEP exporters extrude polygons of them made within a chord tolerance.
Pure numpy; no file formats.

Axial layout of the assembly (z along the shaft, mm):

* frame plate 0: ``[-t, 0]``; row A (ring A, cam A, contact length of
  rollers A): ``[0, w]``; frame plate 1: ``[w, w + t]``; row B:
  ``[w + t, 2 w + t]``; frame plate 2: ``[2 w + t, 2 w + 2 t]`` with
  ``w`` the face width and ``t`` the frame plate thickness.
* Each roller runs through its outer plate and ends within its half of the
  middle plate, ``ROLLER_END_GAP / 2`` short of the plate's mid-plane
  (:func:`roller_z_range`): row A ``[-t, w + t/2 - g/2]``, row B
  ``[w + t/2 + g/2, 2 w + 2 t]`` with ``g = min(ROLLER_END_GAP, t / 2)``, so
  that the two rows' rollers in one slot never overlap. The contact length
  stays ``roller_length``.
* Cam B is 180 deg out of phase; ring B is ring A turned by half a tooth
  pitch (``pi / z``) so that row B meshes with the same slots.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from corr_cad.geometry.design import SLOT_END_CLEARANCE, GearDesign
from corr_cad.geometry.kinematics import unit_radial, unit_tangential
from corr_cad.geometry.profile import ProfileCurve
from corr_cad.geometry.sampling import approximate

__all__ = [
    "PartOutline",
    "circle_polygon",
    "frame_slot_outline",
    "slot_polygon",
    "part_outlines",
    "circle_segments",
    "roller_outline",
    "roller_solid_length",
    "roller_z_range",
    "ROLLER_END_GAP",
]

#: Axial gap between the end faces of the two rows' rollers in one slot, mm,
#: at the middle frame plate's mid-plane (at most half the plate thickness).
ROLLER_END_GAP = 0.2


def _end_gap(design: GearDesign) -> float:
    return min(ROLLER_END_GAP, 0.5 * design.frame_thickness)


def roller_solid_length(design: GearDesign) -> float:
    """Axial length of a roller's solid, mm: ``w + 1.5 t - g / 2`` (see the module doc)."""
    return design.face_width + 1.5 * design.frame_thickness - 0.5 * _end_gap(design)


def roller_z_range(design: GearDesign, row: str) -> tuple[float, float]:
    """``(z_low, z_high)`` of a roller of row ``"a"`` or ``"b"`` in the assembly, mm."""
    w, t = design.face_width, design.frame_thickness
    length = roller_solid_length(design)
    if row == "a":
        return (-t, -t + length)
    return (2.0 * w + 2.0 * t - length, 2.0 * w + 2.0 * t)


@dataclass(frozen=True)
class PartOutline:
    """A part as a 2D region extruded along z.

    Attributes
    ----------
    name : str
    outer : (n, 2) float, mm
        Counter-clockwise outer boundary.
    holes : list of (m, 2) float, mm
        Clockwise hole boundaries.
    thickness : float, mm
    exact_area : float, mm^2
        Area of the exact (not tessellated) region.
    boundary_length : float, mm
        Total length of all boundaries (bounds the area error: tol x length).
    """

    name: str
    outer: np.ndarray
    holes: list[np.ndarray] = field(default_factory=list)
    thickness: float = 1.0
    exact_area: float = 0.0
    boundary_length: float = 0.0

    @property
    def exact_volume(self) -> float:
        return self.exact_area * self.thickness

    @property
    def contours(self) -> list[np.ndarray]:
        return [self.outer, *self.holes]


def circle_segments(radius: float, chord_tol: float) -> int:
    """Segments of an inscribed polygon whose sagitta stays below ``chord_tol``."""
    if chord_tol >= radius:
        return 8
    return max(8, math.ceil(math.pi / math.acos(1.0 - chord_tol / radius)))


def circle_polygon(
    radius: float, chord_tol: float, centre: tuple[float, float] = (0.0, 0.0)
) -> np.ndarray:
    """Counter-clockwise inscribed polygon of a circle, (n, 2)."""
    n = circle_segments(radius, chord_tol)
    a = 2.0 * np.pi * np.arange(n) / n
    return np.stack([centre[0] + radius * np.cos(a), centre[1] + radius * np.sin(a)], axis=1)


def frame_slot_outline(design: GearDesign, slot_angle_rad: float) -> tuple[np.ndarray, np.ndarray]:
    """Closed obround slot of width 2r at polar angle ``slot_angle_rad``.

    Returns 4 vertices (4, 2) and their bulges (4,): two radial flanks and two
    semicircular ends whose centres sit ``SLOT_END_CLEARANCE`` beyond the
    roller centre's extreme radii ``L - e`` and ``L + e``.
    """
    r = design.roller_radius
    rho_in = design.link_length - design.eccentricity - SLOT_END_CLEARANCE
    rho_out = design.link_length + design.eccentricity + SLOT_END_CLEARANCE
    u = unit_radial(slot_angle_rad)
    v = unit_tangential(slot_angle_rad)
    verts = np.array(
        [rho_in * u - r * v, rho_out * u - r * v, rho_out * u + r * v, rho_in * u + r * v]
    )
    bulges = np.array([0.0, -1.0, 0.0, -1.0])
    return verts, bulges


def slot_polygon(design: GearDesign, slot_angle_rad: float, chord_tol: float) -> np.ndarray:
    """Clockwise polygon of a frame slot within ``chord_tol`` (the ends inscribed)."""
    r = design.roller_radius
    rho_in = design.link_length - design.eccentricity - SLOT_END_CLEARANCE
    rho_out = design.link_length + design.eccentricity + SLOT_END_CLEARANCE
    u = unit_radial(slot_angle_rad)
    v = unit_tangential(slot_angle_rad)
    n = max(4, circle_segments(r, chord_tol) // 2)
    a = np.linspace(0.0, np.pi, n + 1)
    # Outer end: from -v side over +u to +v side; inner end back.
    outer_end = rho_out * u + r * (-np.cos(a)[:, None] * v + np.sin(a)[:, None] * u)
    inner_end = rho_in * u + r * (np.cos(a)[:, None] * v - np.sin(a)[:, None] * u)
    poly = np.vstack([outer_end, inner_end])
    return _oriented(poly, clockwise=True)


def _signed_area(p: np.ndarray) -> float:
    x, y = p[:, 0], p[:, 1]
    return 0.5 * float(np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1)))


def _oriented(p: np.ndarray, clockwise: bool) -> np.ndarray:
    ccw = _signed_area(p) > 0
    return p[::-1].copy() if ccw == clockwise else p


def _slot_area(design: GearDesign) -> float:
    r = design.roller_radius
    length = 2.0 * (design.eccentricity + SLOT_END_CLEARANCE)
    return 2.0 * r * length + math.pi * r * r


def part_outlines(
    design: GearDesign, working: ProfileCurve, chord_tol: float, floating: bool = False
) -> dict[str, PartOutline]:
    """Outlines of ``ring``, ``cam``, ``roller`` and ``frame`` within ``chord_tol``.

    The ring's inner boundary is the working profile's polyline
    approximation (vertices on the exact curve, measured deviation at most
    ``chord_tol``); circles are inscribed polygons. The cam's bore is at
    ``(0, -e)`` (the crankshaft's axis), or with ``floating`` concentric with
    its disc (the outer race of its needle bearing,
    :mod:`corr_cad.geometry.bearing_parts`).
    """
    w = design.face_width
    t = design.frame_thickness
    r = design.roller_radius
    profile = approximate(working, "polyline", chord_tol).vertices
    ring = PartOutline(
        "ring",
        circle_polygon(design.ring_outer_radius, chord_tol),
        [_oriented(profile, clockwise=True)],
        w,
        math.pi * design.ring_outer_radius**2 - working.area(),
        2 * math.pi * design.ring_outer_radius + _perimeter(profile),
    )
    cam = PartOutline(
        "cam",
        circle_polygon(design.cam_radius, chord_tol),
        [
            _oriented(
                circle_polygon(
                    design.cam_bore_radius,
                    chord_tol,
                    (0.0, 0.0) if floating else (0.0, -design.eccentricity),
                ),
                True,
            )
        ],
        w,
        math.pi * (design.cam_radius**2 - design.cam_bore_radius**2),
        2 * math.pi * (design.cam_radius + design.cam_bore_radius),
    )
    roller = roller_outline(design, 0.0, chord_tol)
    slots = [
        slot_polygon(design, i * design.slot_pitch_rad, chord_tol)
        for i in range(design.roller_count)
    ]
    slot_perimeter = 2 * math.pi * r + 4 * (design.eccentricity + SLOT_END_CLEARANCE)
    frame = PartOutline(
        "frame",
        circle_polygon(design.frame_outer_radius, chord_tol),
        [_oriented(circle_polygon(design.frame_inner_radius, chord_tol), True), *slots],
        t,
        math.pi * (design.frame_outer_radius**2 - design.frame_inner_radius**2)
        - design.roller_count * _slot_area(design),
        2 * math.pi * (design.frame_outer_radius + design.frame_inner_radius)
        + design.roller_count * slot_perimeter,
    )
    return {p.name: p for p in (ring, cam, roller, frame)}


def _perimeter(p: np.ndarray) -> float:
    return float(np.sum(np.linalg.norm(np.roll(p, -1, axis=0) - p, axis=1)))


def roller_outline(design: GearDesign, radius_error: float, chord_tol: float) -> PartOutline:
    """A roller whose radius is off by ``radius_error`` (mm)."""
    r = design.roller_radius + radius_error
    return PartOutline(
        "roller",
        circle_polygon(r, chord_tol),
        [],
        roller_solid_length(design),
        math.pi * r * r,
        2 * math.pi * r,
    )
