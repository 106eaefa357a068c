"""The first stage's meshes in the whole drive: sliding loss, mesh stiffness, play at the output.

Sliding loss (ISO/TR 14179-2, Ohlendorf's gear loss factor)
-----------------------------------------------------------
A mesh loses ``P_V = mu_mz H_V P`` of the power ``P`` it passes, with the
mean coefficient of friction of the mesh ``mu_mz`` and the gear loss factor
of spur gears::

    H_V = pi (u + 1) / (z_1 u) (1 - eps_a + eps_1^2 + eps_2^2)

(the closed form for tip shares ``eps_1, eps_2 <= 1``; the crank gear's
mesh, with a contact ratio near 1.8, has one above 1 and takes the same
integral in general form, :func:`gear_loss_factor`)

``u = z_2 / z_1`` (negative for the internal crank gear, whose teeth turn
the same way: the sliding speed is ``|omega_1 - omega_2|`` times the
distance from the pitch point), ``eps_1`` and ``eps_2`` the addendum
contact ratios of the two tips and ``eps_a`` their sum. It is the sliding
speed integrated along the path of contact with the load shared equally by
two pairs in contact (``tests/test_first_stage_mesh.py`` integrates it on
its own). Each wheel's power passes the pinion mesh and then the crank
gear's mesh: ``eta1 = (1 - mu_mz H_V1)(1 - mu_mz H_V2)``, the same in both
directions of power flow (Coulomb sliding, first order).

Stiffness (ISO 6336-1 mesh stiffness)
-------------------------------------
Each mesh deflects along its line of action by ``F / (c_gamma b)`` with the
mean mesh stiffness ``c_gamma = 20 N/(mm um)`` of steel spur gears (ISO
6336-1's value in the absence of a better one). With the pinion held, a
crank moment ``M`` loads each of the three wheels' meshes with ``F = M / (3
r_bc)`` (``r_bc`` the crank gear's base radius); the wheel passes it at its
one base radius to the pinion mesh, so both deflections add along the
crank gear's line of action and the crank turns ``M (1/k_1 + 1/k_2) / (3
r_bc^2)``. At the output, through the second stage's ratio ``z + 1``: ``K1 =
(z + 1)^2 3 r_bc^2 / (1/k_1 + 1/k_2)``; the bearings, shafts and housing of
the first stage are not in it.

At the output
-------------
The first stage's backlash (pinion held) turns the output by ``b1 / (z +
1)``; its lost motion at ``+-band T_R`` is that plus ``2 band T_R / K1``.
The whole drive's figures add the first stage's to the second stage's:
backlash and lost motion add, compliances add (``1/K = 1/K2 + 1/K1``),
efficiencies multiply.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from corr_cad.geometry.first_stage import FirstStageGeometry

__all__ = [
    "MESH_STIFFNESS_N_PER_MM_UM",
    "FirstStageMesh",
    "first_stage_mesh",
    "gear_loss_factor",
    "addendum_contact_ratios",
]

#: ISO 6336-1 mean mesh stiffness of steel spur gears, N/(mm um).
MESH_STIFFNESS_N_PER_MM_UM = 20.0


def gear_loss_factor(z1: int, u: float, eps1: float, eps2: float) -> float:
    """Ohlendorf's ``H_V`` of a spur mesh (ISO/TR 14179-2); ``u < 0`` for an internal gear.

    ``2 pi (u + 1) / (z_1 u)`` times the integral of ``|x|`` (in base pitches
    from the pitch point) along the path of contact, halved where two pairs
    mesh (``eps_a < 2``). With both tip shares at most 1 it is the closed
    form ``1/2 (1 - eps_a + eps_1^2 + eps_2^2)``; a share above 1 puts the
    pitch point inside a two-pair zone, which the integral follows.
    """

    def F(x: float) -> float:  # an antiderivative of |x|
        return 0.5 * x * abs(x)

    whole = F(eps1) - F(-eps2)
    double = F(eps1 - 1.0) - F(-eps2) + F(eps1) - F(1.0 - eps2)
    return 2.0 * math.pi * (u + 1.0) / (z1 * u) * (whole - 0.5 * double)


def addendum_contact_ratios(fs: FirstStageGeometry) -> tuple[tuple[float, float], ...]:
    """``((eps_pinion, eps_wheel), (eps_wheel, eps_crank_gear))``: each tip's share of the
    path of contact from the pitch point, over the base pitch."""
    s = fs.stage
    pb = math.pi * s.module * math.cos(math.radians(s.pressure_angle_deg))
    a1, a2 = (math.radians(a) for a in fs.working_pressure_angle_deg)

    def length(g) -> float:
        return math.sqrt(g.tip**2 - g.base_radius**2)

    def pitch(g, aw) -> float:  # base tangency point to the pitch point
        return g.base_radius * math.tan(aw)

    pin, whl, crk = fs.pinion, fs.wheel, fs.crank_gear
    first = ((length(pin) - pitch(pin, a1)) / pb, (length(whl) - pitch(whl, a1)) / pb)
    second = ((length(whl) - pitch(whl, a2)) / pb, (pitch(crk, a2) - length(crk)) / pb)
    return first, second


@dataclass(frozen=True)
class FirstStageMesh:
    """The first stage's loss factors, efficiency, stiffness and play (rad, N*mm)."""

    mu_mesh: float
    loss_factors: tuple[float, float]
    efficiency: float
    crank_stiffness: float  # N*mm/rad at the crank, pinion held
    output_stiffness: float  # N*mm/rad reflected to the output
    output_backlash: float  # rad at the output

    def lost_motion(self, rated_torque: float, band: float) -> float:
        """Lost motion at the output at ``+-band`` of ``rated_torque`` (N*mm), rad."""
        return self.output_backlash + 2.0 * band * rated_torque / self.output_stiffness

    def as_dict(self) -> dict:
        return {
            "efficiency": self.efficiency,
            "mu_mesh": self.mu_mesh,
            "gear_loss_factor_H_V": {
                "pinion_wheel": self.loss_factors[0],
                "wheel_crank_gear": self.loss_factors[1],
            },
            "efficiency_method": "ISO/TR 14179-2 sliding loss, Ohlendorf's H_V, eta1 = "
            "(1 - mu H_V1)(1 - mu H_V2), both directions",
            "torsional_rigidity_at_output_Nm_per_arcmin": self.output_stiffness
            * math.pi
            / 10800.0
            / 1000.0,
            "rigidity_method": "ISO 6336-1 mesh stiffness c_gamma = 20 N/(mm um), three "
            "wheels, both meshes in series, pinion held; reflected by (z + 1)^2",
        }


def first_stage_mesh(fs: FirstStageGeometry, roller_count: int, mu_mesh: float) -> FirstStageMesh:
    """The first stage's figures behind a second stage of ratio ``roller_count`` (z + 1)."""
    s = fs.stage
    (e1p, e1w), (e2w, e2c) = addendum_contact_ratios(fs)
    h1 = gear_loss_factor(s.pinion_teeth, s.wheel_teeth / s.pinion_teeth, e1p, e1w)
    h2 = gear_loss_factor(s.wheel_teeth, -s.crank_gear_teeth / s.wheel_teeth, e2w, e2c)
    eta = (1.0 - mu_mesh * h1) * (1.0 - mu_mesh * h2)
    k = MESH_STIFFNESS_N_PER_MM_UM * 1000.0 * s.face_width  # N/mm along the line of action
    r_bc = fs.crank_gear.base_radius
    k_crank = 3.0 * r_bc**2 / (1.0 / k + 1.0 / k)
    return FirstStageMesh(
        mu_mesh=float(mu_mesh),
        loss_factors=(h1, h2),
        efficiency=eta,
        crank_stiffness=k_crank,
        output_stiffness=roller_count**2 * k_crank,
        output_backlash=fs.crank_backlash_rad / roller_count,
    )
