"""The parts the drive floats its cams on: needles, the crankshaft's eccentrics, its seats.

Drawn only under ``[solver] model = "drive"`` with ``[bearings.eccentric]`` (the
parts the model bends are the parts the files draw). Pure numpy; no file formats.

The needle bearing (one per row, :class:`corr_cad.mechanics.crank.bearing.EccentricBearing`):

* outer race: the cam's bore, radius ``R_b = cam_bore_radius``, concentric
  with the cam's disc (the cam is a ring on its bearing);
* ``Z`` needles of diameter ``D`` and length ``l``, their axes on the pitch
  circle of radius ``r_p = R_b - D / 2`` (pitch diameter ``2 R_b - D``, as the
  rating uses), centred axially in the row; no cage drawn (a full
  complement's layout: the needles keep their pitch in the drawing);
* inner race: the crankshaft's eccentric journal, radius
  ``r_j = R_b - D - Pd / 2`` (``Pd`` the diametral clearance), its centre ``e``
  from the axis: row A's at ``(0, e)``, row B's at ``(0, -e)`` in the
  crankshaft's coordinates (180 deg apart).

The crankshaft (z along the shaft as the assembly's, mm; ``w`` face width,
``t`` frame plate thickness, ``g = 1`` mm axial gap, ``L_s`` a seat's width):

* support seat 1: ``[z_bottom, -t - g]``, radius ``r_s`` (with
  ``z_bottom = -t - g - L_s``, or the first stage's flange);
* core (the shoulder of both seats, through the frame plates):
  ``[-t - g, 0]``, ``[w, w + t]`` and ``[2 w + t, 2 w + 2 t + g]``, radius
  ``r_c``: the largest half-millimetre radius at least 0.25 mm inside both
  eccentrics' projections, ``r_c + e < r_j`` (the cams and needles go on
  over the ends);
* eccentric A ``[0, w]``, eccentric B ``[w + t, 2 w + t]``;
* support seat 2: ``[2 w + 2 t + g, 2 w + 2 t + g + L_s]``, radius ``r_s = 0.9 r_c``
  rounded down to 0.5 mm, where the support bearings (``[bearings.crank]``)
  sit against the core's shoulders.

The run draws the crank model's shaft (``[crankshaft]`` / ``[bearings.crank]``, or
without them the same shaft derived from the design:
:func:`corr_cad.run.stages.stages_bearing_parts.crank_drawing`; rows carried as
:class:`BearingRows` with a :class:`CrankDrawing`); the layout above is what
:func:`crankshaft_pieces` gives for rows without one. The crank model's shaft is a
uniform shaft of its ``shaft_diameter`` from the lower support's outer face to the
upper's (with ``[first_stage]`` from the crank gear's flange,
:func:`~corr_cad.geometry.first_stage_parts.first_stage_layout`), the support seats of its bearing
``width`` centred at its ``support_positions`` (seat radius the shaft's), and
the eccentric journals of its ``eccentric_length`` centred at its
``eccentric_positions``, each of diameter ``eccentric_diameter`` less its needle
bearing's diametral clearance ``Pd`` (the model's journal is the needle set's
bore; the drawn one leaves the running clearance, as without the model).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from corr_cad.errors import DesignError
from corr_cad.geometry.design import GearDesign
from corr_cad.geometry.kinematics import floating_cam_spin, unit_radial
from corr_cad.geometry.placement import Placement

__all__ = [
    "AXIAL_GAP",
    "OffsetCircle",
    "CrankDrawing",
    "BearingRows",
    "NeedleRow",
    "needle_rows",
    "core_radius",
    "seat_radius",
    "crankshaft_pieces",
    "needle_pieces",
    "needle_part_names",
    "cage_angle",
    "needle_spin",
    "bearing_placements",
]

AXIAL_GAP = 1.0


@dataclass(frozen=True)
class OffsetCircle:
    """A circle of ``radius`` centred at ``centre`` (mm) in a part's coordinates."""

    radius: float
    centre: tuple[float, float]


@dataclass(frozen=True)
class NeedleRow:
    """One row's needle bearing as drawn (mm)."""

    row: str
    needles: int
    needle_diameter: float
    needle_length: float
    diametral_clearance: float
    pitch_radius: float
    journal_radius: float
    z_low: float

    @property
    def part(self) -> str:
        return "needle" if self.row == "a" else "needle_b"


@dataclass(frozen=True)
class CrankDrawing:
    """The crank model's shaft as the files draw it (mm, the assembly's z)."""

    shaft_diameter: float
    eccentric_diameter: float
    eccentric_length: float
    eccentric_positions: tuple[float, float]
    support_positions: tuple[float, float]
    support_width: float
    #: Where the crank gear's torque enters the shaft (the model's ``gear_position``):
    #: with ``[first_stage]`` the face of the crank gear's flange toward the eccentrics.
    gear_position: float | None = None
    bore_diameter: float = 0.0
    #: The support bearing's outside diameter (its pitch diameter plus two rollers).
    support_outer_diameter: float | None = None


class BearingRows(list):
    """Rows A and B (:class:`NeedleRow`) and, with the scene's crank model, ``crank``
    (:class:`CrankDrawing`): the shaft :func:`crankshaft_pieces` draws."""

    crank: CrankDrawing | None = None


def needle_rows(design: GearDesign, bearing_a, bearing_b=None) -> list[NeedleRow]:
    """Rows A and B's bearings as drawn; one line naming the key when they cannot be."""
    w, t = design.face_width, design.frame_thickness
    rb, e = design.cam_bore_radius, design.eccentricity
    out = []
    for row, b, z0, section in (
        ("a", bearing_a, 0.0, "bearings.eccentric"),
        ("b", bearing_b or bearing_a, w + t, "bearings.eccentric_b" if bearing_b else None),
    ):
        sec = section or "bearings.eccentric"
        d, length, pd, n = b.needle_diameter, b.needle_length, b.diametral_clearance, b.needles
        if length > w:
            raise DesignError(
                f"[{sec}] needle_length = {length:g}: the needles must fit the cam's width, "
                f"allowed range (0, {w:g}] mm (face_width), e.g. {w:g}"
            )
        rp = rb - 0.5 * d
        rj = rb - d - 0.5 * pd
        if 2.0 * rp * math.sin(math.pi / n) <= d:
            most = math.ceil(math.pi / math.asin(min(1.0, d / (2.0 * rp)))) - 1
            raise DesignError(
                f"[{sec}] needles = {n}: {n} needles of {d:g} mm do not fit on the pitch circle "
                f"of {2 * rp:g} mm (cam_bore_radius {rb:g} mm); allowed range 3..{most}"
            )
        if rj - e < 1.25:
            raise DesignError(
                f"[{sec}] needle_diameter = {d:g}: the eccentric journal (radius {rj:g} mm) "
                f"leaves no shaft inside it at e = {e:g} mm; allowed range (0, "
                f"{max(0.0, rb - e - 1.25 - 0.5 * pd):.4g}) mm"
            )
        out.append(NeedleRow(row, n, d, length, pd, rp, rj, z0 + 0.5 * (w - length)))
    return out


def core_radius(design: GearDesign, rows: list[NeedleRow]) -> float:
    """``r_c``: half-millimetre steps, at least 0.25 mm inside both eccentrics' projections
    (the crank model's shaft radius with one, :class:`BearingRows`)."""
    crank = getattr(rows, "crank", None)
    if crank is not None:
        return 0.5 * crank.shaft_diameter
    inner = min(r.journal_radius for r in rows) - design.eccentricity - 0.25
    return 0.5 * math.floor(2.0 * inner)


def seat_radius(design: GearDesign, rows: list[NeedleRow]) -> float:
    """``r_s``: a support bearing's seat, ``0.9 r_c`` rounded down to 0.5 mm (at least 0.5);
    the crank model's shaft radius with one (:class:`BearingRows`)."""
    crank = getattr(rows, "crank", None)
    if crank is not None:
        return 0.5 * crank.shaft_diameter
    return max(0.5, 0.5 * math.floor(1.8 * core_radius(design, rows)))


def crankshaft_pieces(
    design: GearDesign, rows: list[NeedleRow], seat_width: float, z_bottom: float | None = None
) -> list:
    """The crankshaft as ``[(outer, holes, height, z0), ...]`` in the assembly's z.

    ``outer`` a radius (centred) or an :class:`OffsetCircle` (an eccentric).
    ``z_bottom`` the bottom of the lower seat (default ``-t - g - seat_width``). With
    the crank model (:class:`BearingRows`) its shaft (module docstring); ``seat_width``
    is then unused and ``z_bottom`` (the first stage's flange) extends the lower seat.
    """
    crank = getattr(rows, "crank", None)
    if crank is not None:
        return _model_pieces(design, rows, crank, z_bottom)
    w, t, g, e = design.face_width, design.frame_thickness, AXIAL_GAP, design.eccentricity
    rc, rs = core_radius(design, rows), seat_radius(design, rows)
    lo = -t - g - seat_width if z_bottom is None else z_bottom
    top = 2 * w + 2 * t + g
    ra, rb = rows[0].journal_radius, rows[1].journal_radius
    return [
        (rs, [], -t - g - lo, lo),
        (rc, [], t + g, -t - g),
        (OffsetCircle(ra, (0.0, e)), [], w, 0.0),
        (rc, [], t, w),
        (OffsetCircle(rb, (0.0, -e)), [], w, w + t),
        (rc, [], t + g, 2 * w + t),
        (rs, [], seat_width, top),
    ]


def _model_pieces(design: GearDesign, rows, c: CrankDrawing, z_bottom) -> list:
    """:func:`crankshaft_pieces` from the crank model: seat, core, journal A, core,
    journal B, core, seat, bottom to top (empty cores left out), each with the model's
    bore (``bore_diameter``, centred on the shaft's axis) where it has one."""
    e, rs, half = design.eccentricity, 0.5 * c.shaft_diameter, 0.5 * c.eccentric_length
    (s1, s2), hb = sorted(c.support_positions), 0.5 * c.support_width
    ja, jb = c.eccentric_positions
    lo = s1 - hb if z_bottom is None else min(z_bottom, s1 - hb)
    cuts = [lo, s1 + hb, ja - half, ja + half, jb - half, jb + half, s2 - hb, s2 + hb]
    if any(b < a - 1e-9 for a, b in zip(cuts, cuts[1:], strict=False)):
        raise DesignError(
            f"[crankshaft] eccentric_positions = {[ja, jb]!r}: the journals "
            f"({c.eccentric_length:g} mm long) must lie in order between the supports "
            f"(support_positions {[s1, s2]!r}, width {c.support_width:g} mm) to be drawn"
        )
    rja = 0.5 * (c.eccentric_diameter - rows[0].diametral_clearance)
    rjb = 0.5 * (c.eccentric_diameter - rows[1].diametral_clearance)
    bore = 0.5 * float(c.bore_diameter)
    if bore > 0.0 and bore + e >= min(rja, rjb) - 0.25:
        raise DesignError(
            f"[crankshaft] bore_diameter = {c.bore_diameter:g}: the bore would cut the eccentric "
            f"journals (radius {min(rja, rjb):.4g} mm, {e:g} mm off the axis); allowed range "
            f"[0, {2.0 * (min(rja, rjb) - e - 0.25):.4g}) mm, e.g. 0"
        )
    holes = [bore] if bore > 0.0 else []
    outers = [rs, rs, OffsetCircle(rja, (0.0, e)), rs, OffsetCircle(rjb, (0.0, -e)), rs, rs]
    return [
        (o, list(holes), b - a, a)
        for o, a, b in zip(outers, cuts, cuts[1:], strict=False)
        if b - a > 1e-9
    ]


def needle_pieces(row: NeedleRow) -> list:
    """One needle: a cylinder of the bearing's diameter and length (z from 0)."""
    return [(0.5 * row.needle_diameter, [], row.needle_length, 0.0)]


def needle_part_names(rows: list[NeedleRow]) -> dict[str, NeedleRow]:
    """``{part: row}``: ``needle`` (row A's), and ``needle_b`` where row B's differs."""
    a, b = rows
    out = {"needle": a}
    if (b.needle_diameter, b.needle_length) != (a.needle_diameter, a.needle_length):
        out["needle_b"] = b
    return out


def cage_angle(row: NeedleRow, crank_turn: float, cam_turn: float) -> float:
    """The needle set's turn for the inner race (the eccentric) turned by ``crank_turn``
    and the outer race (the cam) by ``cam_turn``, both absolute (rad), rolling on both:
    ``psi_c = [psi_i (1 - gamma) + psi_o (1 + gamma)] / 2``, ``gamma = D / d_m``
    (Harris & Kotzalas, *Rolling Bearing Analysis*, 5th ed., Vol. 1, Ch. 8, the cage
    speed with both rings turning)."""
    gamma = row.needle_diameter / (2.0 * row.pitch_radius)
    return 0.5 * (crank_turn * (1.0 - gamma) + cam_turn * (1.0 + gamma))


def needle_spin(row: NeedleRow, crank_speed: float, cam_speed: float) -> float:
    """A needle's absolute spin about its own axis: the cage's plus, relative to the cage,
    ``(d_m / 2 D)(1 - gamma^2)(omega_o - omega_i)`` (Harris & Kotzalas, Ch. 8)."""
    dm = 2.0 * row.pitch_radius
    gamma = row.needle_diameter / dm
    cage = cage_angle(row, crank_speed, cam_speed)
    return cage + dm / (2.0 * row.needle_diameter) * (1.0 - gamma**2) * (cam_speed - crank_speed)


def bearing_placements(
    design: GearDesign,
    rows: list[NeedleRow],
    crank_angle_rad: float,
    crankshaft: bool = True,
) -> list[Placement]:
    """The crankshaft (``crankshaft``, when drawn here) and every needle at a crank angle.

    As :func:`corr_cad.geometry.placement.assembly_placements`: the crankshaft turns by
    ``phi = crank + crank / z``; each cam turns by the rolling kinematics' spin
    (:func:`~corr_cad.geometry.kinematics.floating_cam_spin` times the output's
    ``crank / z``, as the lives and the input inertia), its centre
    at ``e`` along ``phi`` (row B's half a turn on); the needle set by
    :func:`cage_angle`, needle ``j`` of row A named ``needle_a_01``... at the pitch
    radius from its eccentric's centre.
    """
    z = design.tooth_count
    e = design.eccentricity
    theta0 = crank_angle_rad / z
    phi = crank_angle_rad + theta0
    cam = theta0 * floating_cam_spin(design)
    out = []
    if crankshaft:
        out.append(Placement("crankshaft", "crankshaft", phi))
    parts = {r.row: p for p, r in needle_part_names(rows).items()}
    for row, dphi in zip(rows, (0.0, math.pi), strict=True):
        centre = e * unit_radial(phi + dphi)
        cage = cage_angle(row, phi, cam) + dphi
        part = parts.get(row.row, "needle")
        for j in range(row.needles):
            a = cage + 2.0 * math.pi * j / row.needles
            x, y = centre + row.pitch_radius * unit_radial(a)
            name = f"needle_{row.row}_{j + 1:02d}"
            out.append(Placement(name, part, 0.0, (float(x), float(y), row.z_low)))
    return out
