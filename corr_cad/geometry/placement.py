"""Where every part sits in the running reducer at one crank angle (pure numpy).

The placements of the assembly exports: the same layout as the mesh
assembly (:func:`corr_cad.export.mesh.assembly`, see :mod:`corr_cad.geometry.parts`
for the axial layout). A placement moves a part from its own coordinates by
``T(offset) . R(angle) . T(pre_offset)``, where ``R(angle)`` turns every
polar angle (measured from +y towards +x) by ``angle_rad``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from corr_cad.geometry.design import GearDesign
from corr_cad.geometry.kinematics import centre_distance, floating_cam_spin, unit_radial
from corr_cad.geometry.parts import roller_z_range

__all__ = ["Placement", "assembly_placements"]


@dataclass(frozen=True)
class Placement:
    """One instance of a part in the assembly.

    Attributes
    ----------
    name : str
        Instance name (``ring_a``, ``cam_b``, ``frame_2``, ``roller_a_07``...).
    part : str
        Which part: ``ring``, ``cam``, ``roller`` or ``frame`` (one plate).
    angle_rad : float
        Turn about the axis, polar angles growing (clockwise seen from +z).
    offset : (3,) float, mm
        Translation after the turn.
    pre_offset : (2,) float, mm
        Translation in the part's own plane before the turn.
    """

    name: str
    part: str
    angle_rad: float
    offset: tuple[float, float, float] = (0.0, 0.0, 0.0)
    pre_offset: tuple[float, float] = (0.0, 0.0)


def assembly_placements(
    design: GearDesign, crank_angle_rad: float, floating: bool = False
) -> list[Placement]:
    """Every part instance at ``crank_angle_rad`` (relative to the frame, as in the forces).

    The frame turns by ``crank / z``, the crankshaft by ``crank + crank / z``;
    cam B is half a turn out of phase and ring B turned by half a tooth
    pitch; each roller sits at its crank-slider radius in its slot. Three
    frame plates: ``[-t, 0]``, ``[w, w + t]``, ``[2 w + t, 2 w + 2 t]``; the rollers
    at :func:`corr_cad.geometry.parts.roller_z_range`. With ``floating`` (the cams on
    their needle bearings, bores concentric) each cam turns about its centre, ``e`` from
    the axis along the eccentric's direction, by the rolling kinematics' spin
    (:func:`~corr_cad.geometry.kinematics.floating_cam_spin`: ``2 L / R_j`` times the
    output's ``crank / z``), the spin the lives and the input inertia use.
    """
    z = design.tooth_count
    w, t = design.face_width, design.frame_thickness
    e = design.eccentricity
    theta0 = crank_angle_rad / z
    phi = crank_angle_rad + theta0
    out = [
        Placement("ring_a", "ring", 0.0),
        Placement("ring_b", "ring", math.pi / z, (0.0, 0.0, w + t)),
    ]
    if floating:
        (xa, ya) = e * unit_radial(phi)
        cam = theta0 * floating_cam_spin(design)
        out += [
            Placement("cam_a", "cam", cam, (float(xa), float(ya), 0.0)),
            Placement("cam_b", "cam", cam, (-float(xa), -float(ya), w + t)),
        ]
    else:
        out += [
            # The cam's bore (the crank axis) is at (0, -e): move it to the axis, then turn.
            Placement("cam_a", "cam", phi, (0.0, 0.0, 0.0), (0.0, e)),
            Placement("cam_b", "cam", phi + math.pi, (0.0, 0.0, w + t), (0.0, e)),
        ]
    for k, z0 in enumerate((-t, w, 2 * w + t), 1):
        out.append(Placement(f"frame_{k}", "frame", theta0, (0.0, 0.0, z0)))
    for row, dphi in (("a", 0.0), ("b", math.pi)):
        zbase = roller_z_range(design, row)[0]
        for i in range(design.roller_count):
            theta = theta0 + i * design.slot_pitch_rad
            s = float(centre_distance(phi + dphi - theta, e, design.link_length))
            x, y = s * unit_radial(theta)
            out.append(Placement(f"roller_{row}_{i + 1:02d}", "roller", 0.0, (x, y, zbase)))
    return out
