"""The whole drive's ratio, mass and inertia, and the first stage's loads and stresses.

- Crank moment from the input torque at the pinion,
  ``M0 = T_in z_c / z_p eta1``, with ``eta1 = 1`` (no friction model of the
  first stage: the moment is an upper bound).
- Total ratio ``i = i1 (z + 1)``, signed: input turns over output turns.
- Mass and moment of inertia of an extruded part from its outline: area and
  polar second moment of area of each region (polygon formulas; circles
  exact), times thickness and density; steel (7850 kg/m^3) for every part.
- Inertia at the input: the pinion, the three wheels (with their bearings)
  times ``(z_p / z_w)^2``, the crank gear, crankshaft, crank bearings and both
  cams about the crank axis (the cams' ``I + m e^2`` by integrating about
  that axis) times ``(1 / i1)^2``, the rollers (``m (r^2 / 2 + L^2)``, on
  their mean orbit ``L = R_j + r``) and the three frame plates times
  ``(1 / i)^2``. The fixed ring does not count.
- Mesh forces per wheel with the load shared equally by the three wheels:
  tangential ``F_t = T_in / (3 r_w)`` on the pinion's working pitch circle
  and ``F_t2 = M0 / (3 r_w2)`` on the crank gear's, radial ``F_t tan a_w``; the
  wheel's bearing load is the vector sum of its two mesh forces (tangential
  parts add, radial parts oppose).
- Tooth-root bending by the Lewis formula ``s = F_t / (b pi m y)`` with the
  form factor ``y = 0.154 - 0.912 / z`` for 20 deg full-depth teeth (Shigley,
  *Mechanical Engineering Design*, 3rd ed., 1977, eq. 14-3 and table 14-2;
  the internal gear at the rack's 0.154), and contact stress by Hertz for two
  cylinders at the pitch point, radii ``r_w sin a_w`` (the internal gear's
  concave), ``p = sqrt(w E' / (pi R))`` with ``w = F_t / (b cos a_w)``. Both
  are stated as the classic formulas, not ISO 6336 (no dynamic, load
  distribution or life factors).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from corr_cad.geometry.bearing_parts import OffsetCircle
from corr_cad.geometry.first_stage import FirstStageGeometry
from corr_cad.geometry.kinematics import floating_cam_spin

__all__ = [
    "STEEL_DENSITY",
    "region_properties",
    "extrusion_mass_inertia",
    "FirstStageLoads",
    "first_stage_loads",
    "lewis_form_factor",
    "drive_mass_inertia",
    "FLOATING_CONVENTION",
    "cam_spin_per_crank",
]

#: Density of steel, kg/mm^3 (7850 kg/m^3).
STEEL_DENSITY = 7.85e-6


def _polygon(p: np.ndarray) -> tuple[float, float]:
    """Signed area and polar second moment about the origin of a polygon (shoelace)."""
    x, y = p[:, 0], p[:, 1]
    xn, yn = np.roll(x, -1), np.roll(y, -1)
    cross = x * yn - xn * y
    area = 0.5 * float(cross.sum())
    ixx = float(np.sum(cross * (y * y + y * yn + yn * yn))) / 12.0
    iyy = float(np.sum(cross * (x * x + x * xn + xn * xn))) / 12.0
    return area, ixx + iyy


def _contour(c, shift) -> tuple[float, float]:
    """|area| and polar moment about the origin of a circle (radius), an eccentric
    circle (:class:`~corr_cad.geometry.bearing_parts.OffsetCircle`) or a polyline."""
    if isinstance(c, OffsetCircle):
        a = math.pi * c.radius**2
        cx, cy = c.centre[0] + shift[0], c.centre[1] + shift[1]
        return a, a * (0.5 * c.radius**2 + cx * cx + cy * cy)
    if isinstance(c, float):
        a = math.pi * c * c
        return a, a * (0.5 * c * c + shift[0] ** 2 + shift[1] ** 2)
    area, j = _polygon(np.asarray(c, dtype=float) + np.asarray(shift))
    return abs(area), abs(j)


def region_properties(outer, holes, shift=(0.0, 0.0)) -> tuple[float, float]:
    """Area (mm^2) and polar second moment about the origin (mm^4) of ``outer`` minus ``holes``.

    A contour is a circle (its radius, centred on the part's origin) or an
    (n, 2) polyline; ``shift`` moves the region first.
    """
    a, j = _contour(outer, shift)
    for h in holes:
        ah, jh = _contour(h, shift)
        a, j = a - ah, j - jh
    return a, j


def extrusion_mass_inertia(pieces, density: float = STEEL_DENSITY, shift=(0.0, 0.0)):
    """Mass (kg) and moment of inertia about the z axis (kg mm^2) of extruded pieces.

    ``pieces``: ``[(outer, holes, thickness, z0), ...]`` as
    :func:`~corr_cad.geometry.first_stage_parts.first_stage_profiles` gives.
    """
    mass = inertia = 0.0
    for outer, holes, t, _ in pieces:
        a, j = region_properties(outer, holes, shift)
        mass += density * a * t
        inertia += density * j * t
    return mass, inertia


def lewis_form_factor(teeth: int | None) -> float:
    """Lewis ``y`` (on the circular pitch) of a 20 deg full-depth tooth; None: a rack."""
    return 0.154 if teeth is None else 0.154 - 0.912 / teeth


@dataclass(frozen=True)
class FirstStageLoads:
    """Forces (N), moments (N*mm) and stresses (MPa) of the first stage at one input torque."""

    input_torque: float
    crank_torque: float
    eta1: float
    tangential: tuple[float, float]
    radial: tuple[float, float]
    wheel_bearing_load: float
    bending: dict
    contact: tuple[float, float]

    def as_dict(self) -> dict:
        return {
            "input_torque_Nmm": self.input_torque,
            "crank_torque_M0_Nmm": self.crank_torque,
            "eta1": self.eta1,
            "eta1_source": "1: no friction model of the first stage (M0 an upper bound)",
            "per_wheel": {
                "pinion_mesh_tangential_N": self.tangential[0],
                "pinion_mesh_radial_N": self.radial[0],
                "crank_gear_mesh_tangential_N": self.tangential[1],
                "crank_gear_mesh_radial_N": self.radial[1],
                "bearing_load_N": self.wheel_bearing_load,
            },
            "root_bending_MPa": dict(self.bending),
            "root_bending_method": "Lewis, y = 0.154 - 0.912/z (20 deg full depth)",
            "contact_stress_MPa": {
                "pinion_wheel": self.contact[0],
                "wheel_crank_gear": self.contact[1],
            },
            "contact_stress_method": "Hertz, two cylinders at the pitch point",
        }


def first_stage_loads(
    fs: FirstStageGeometry, input_torque: float, young: float, poisson: float
) -> FirstStageLoads:
    """Loads of the first stage for ``input_torque`` (N*mm) at the pinion."""
    s = fs.stage
    t_in = abs(input_torque)
    eta1 = 1.0
    m0 = t_in * s.crank_gear_teeth / s.pinion_teeth * eta1
    aw1, aw2 = (math.radians(a) for a in fs.working_pressure_angle_deg)
    rw_p = fs.pinion.base_radius / math.cos(aw1)
    rw_c = fs.crank_gear.base_radius / math.cos(aw2)
    rw_w1, rw_w2 = fs.wheel.base_radius / math.cos(aw1), fs.wheel.base_radius / math.cos(aw2)
    ft1, ft2 = t_in / (3.0 * rw_p), m0 / (3.0 * rw_c)
    fr1, fr2 = ft1 * math.tan(aw1), ft2 * math.tan(aw2)
    bearing = math.hypot(ft1 + ft2, fr1 - fr2)
    b, m = s.face_width, s.module
    bending = {
        "pinion": ft1 / (b * math.pi * m * lewis_form_factor(s.pinion_teeth)),
        "wheel": max(ft1, ft2) / (b * math.pi * m * lewis_form_factor(s.wheel_teeth)),
        "crank_gear": ft2 / (b * math.pi * m * lewis_form_factor(None)),
    }
    e_prime = young / (2.0 * (1.0 - poisson**2))  # 1/E' = 2 (1 - nu^2) / E, same material

    def hertz(ft, aw, r1, r2, internal):
        rho1, rho2 = r1 * math.sin(aw), r2 * math.sin(aw)
        inv_r = 1.0 / rho1 - 1.0 / rho2 if internal else 1.0 / rho1 + 1.0 / rho2
        w = ft / (b * math.cos(aw))
        return math.sqrt(w * e_prime * inv_r / math.pi)

    contact = (hertz(ft1, aw1, rw_p, rw_w1, False), hertz(ft2, aw2, rw_w2, rw_c, True))
    return FirstStageLoads(t_in, m0, eta1, (ft1, ft2), (fr1, fr2), bearing, bending, contact)


def _outline_pieces(o) -> list:
    """A :class:`~corr_cad.geometry.parts.PartOutline` as one extrusion piece."""
    return [(o.outer, list(o.holes), o.thickness, 0.0)]


#: ``drive`` ``inertia_convention`` where the cams float on their needle bearings.
FLOATING_CONVENTION = (
    "cams on their needle bearings: each cam's centre orbits at e with the crank (m e^2 "
    "at the crank's speed) and the cam spins as the rolling kinematics gives it, the "
    "rollers about the cam a roller bearing with the frame as its cage: 2 L / R_j times "
    "the output's speed, (2 L / R_j) / (z + 1) of the crank's absolute speed (I_c about "
    "its centre; the same spin as the lives'); each needle is carried "
    "round the axis by its eccentric (m e^2), round the eccentric's centre at the "
    "bearing's cage speed [omega_i (1 - gamma) + omega_o (1 + gamma)] / 2 (m r_p^2) and "
    "spins rolling on both races (m D^2 / 8), omega_o the cam's spin; Harris & "
    "Kotzalas, Rolling Bearing Analysis, 5th ed., Vol. 1, Ch. 8; "
    "input_inertia_cams_fixed_kg_m2: the cams turning with the crank, an upper bound"
)


def cam_spin_per_crank(design) -> float:
    """A floating cam's absolute spin per absolute crank turn: the rolling kinematics'
    ``2 L / R_j`` per output turn (:func:`~corr_cad.geometry.kinematics.floating_cam_spin`)
    over ``z + 1``."""
    return floating_cam_spin(design) / design.roller_count


def _needle_parts(design, rows) -> tuple[dict, float]:
    """Each needle part's (mass, equivalent inertia at the crank's speed, count) and the
    cam's spin per crank turn (:func:`cam_spin_per_crank`); see :data:`FLOATING_CONVENTION`."""
    from corr_cad.geometry.bearing_parts import cage_angle, needle_part_names, needle_spin

    cam = cam_spin_per_crank(design)
    e = design.eccentricity
    out = {}
    names = needle_part_names(rows)
    for row in rows:
        part = "needle_b" if row.row == "b" and "needle_b" in names else "needle"
        rn = 0.5 * row.needle_diameter
        m, i_own = extrusion_mass_inertia([(rn, [], row.needle_length, 0.0)])
        kc, kn = cage_angle(row, 1.0, cam), needle_spin(row, 1.0, cam)
        eq = m * (e * e + (row.pitch_radius * kc) ** 2) + i_own * kn * kn
        n = out.get(part, (0, 0, 0, {}))[2] + row.needles
        out[part] = (m, eq, n, {"cage_per_crank": kc, "spin_per_crank": kn, "own_axis": i_own})
    return out, cam


def drive_mass_inertia(
    design, fs: FirstStageGeometry, profiles: dict, outlines: dict, rows=None
) -> dict:
    """Mass of every part, the whole drive's mass and the inertia at the input.

    ``profiles``: the first stage's parts
    (:func:`~corr_cad.geometry.first_stage_parts.first_stage_profiles`);
    ``outlines``: the second stage's
    (:func:`~corr_cad.geometry.parts.part_outlines`). Masses in kg, moments of
    inertia in kg m^2, each about the axis the part turns on. With ``rows``
    (:func:`~corr_cad.geometry.bearing_parts.needle_rows`: the cams float on needle
    bearings, their bores concentric) the cams and needles count as
    :data:`FLOATING_CONVENTION` says.
    """
    z = design.tooth_count
    e, r, link = design.eccentricity, design.roller_radius, design.link_length
    count = {"wheel": 3, "wheel_bearing": 3, "crank_bearing": 2}
    parts = {}
    for name, pieces in profiles.items():
        m, i = extrusion_mass_inertia(pieces)
        parts[name] = (m, i, count.get(name, 1))
    for name, key, n in (("inner_gear", "ring", 2), ("teeth_frame", "frame", 3)):
        m, i = extrusion_mass_inertia(_outline_pieces(outlines[key]))
        parts[name] = (m, i, n)
    i1 = fs.ratio
    total = i1 * (z + 1)
    if rows is None:
        # the cam about the crank axis: its bore centre (0, -e) moved to the origin
        m, i = extrusion_mass_inertia(_outline_pieces(outlines["cam"]), shift=(0.0, e))
    else:  # about its own centre (its bore concentric): it spins as the kinematics says
        m, i = extrusion_mass_inertia(_outline_pieces(outlines["cam"]))
        cam_mass, cam_own = m, i
    parts["disk_cam"] = (m, i, 2)
    m, _ = extrusion_mass_inertia(_outline_pieces(outlines["roller"]))
    parts["roller"] = (m, m * (0.5 * r * r + link * link), 2 * design.roller_count)

    zp, zw = fs.pinion.teeth, fs.wheel.teeth
    reflect = {
        "pinion": 1.0,
        "wheel": (zp / zw) ** 2,
        "wheel_bearing": (zp / zw) ** 2,
        "crank_gear": 1.0 / i1**2,
        "crankshaft": 1.0 / i1**2,
        "crank_bearing": 1.0 / i1**2,
        "disk_cam": 1.0 / i1**2,
        "roller": 1.0 / total**2,
        "teeth_frame": 1.0 / total**2,
        "inner_gear": 0.0,  # fixed
    }
    kg_m2 = 1e-6  # kg mm^2 -> kg m^2
    extra: dict = {}
    if rows is not None:
        needles, cam_speed = _needle_parts(design, rows)
        for k, (m, eq, n, speeds) in needles.items():
            parts[k] = (m, eq, n)
            reflect[k] = 1.0 / i1**2
            extra[k] = {
                "inertia_is": "equivalent at the crank's speed: orbit, cage and spin",
                "own_axis_inertia_kg_m2": speeds["own_axis"] * kg_m2,
                "cage_speed_per_crank": speeds["cage_per_crank"],
                "spin_per_crank": speeds["spin_per_crank"],
            }
        reflect["disk_cam"] = (cam_speed / i1) ** 2
        orbit = cam_mass * e * e
        extra["disk_cam"] = {
            "inertia_is": "about its own centre, spinning at 2 L / R_j times the output",
            "spin_per_crank": cam_speed,
            "orbit_inertia_kg_m2": orbit * kg_m2,
            "orbit_reflected_by": 1.0 / i1**2,
        }
    j_in = sum(n * i * kg_m2 * reflect[k] for k, (_, i, n) in parts.items())
    out = {
        "total_ratio": total,
        "mass_kg": sum(n * m for m, _, n in parts.values()),
        "input_inertia_kg_m2": j_in,
        "density_kg_m3": STEEL_DENSITY * 1e9,
        "parts": {
            k: {
                "mass_kg": m,
                "inertia_kg_m2": i * kg_m2,
                "count": n,
                "reflected_by": reflect[k],
                **extra.get(k, {}),
            }
            for k, (m, i, n) in parts.items()
        },
    }
    if rows is not None:
        j_in += 2 * orbit * kg_m2 / i1**2
        fixed = j_in - 2 * (cam_own * reflect["disk_cam"] + orbit / i1**2) * kg_m2
        out["input_inertia_kg_m2"] = j_in
        out["input_inertia_cams_fixed_kg_m2"] = fixed + 2 * (cam_own + orbit) * kg_m2 / i1**2
        out["inertia_convention"] = FLOATING_CONVENTION
    return out
