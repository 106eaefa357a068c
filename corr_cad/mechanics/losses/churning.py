"""Churning of a dip-lubricated gear: Changenet & Velex's empirical law.

A spur gear of pitch radius ``R_p`` (diameter ``D_p``) and face width ``b``
dipping to the depth ``h`` into a sump of ``V_0`` of oil (density ``rho``,
kinematic viscosity ``nu``) turning at ``omega`` resists with the torque
(C. Changenet and P. Velex, "A model for the prediction of churning losses
in geared transmissions - preliminary results", *ASME Journal of Mechanical
Design* 129 (1), 2007, pp. 128-133)::

    T_ch = 0.5 rho omega^2 S_m R_p^3 C_m

with ``S_m`` the gear's immersed surface (both faces' circular segments and
the rim: ``S_m = R_p^2 (2 theta - sin 2 theta) + 2 R_p b theta``,
``cos theta = 1 - h / R_p``), ``Fr = omega^2 R_p / g``, ``Re = omega R_p^2 /
nu`` and the critical Reynolds number ``Re_c = omega R_p b / nu``::

    C_m = 1.366 (h/D_p)^0.45 (V_0/D_p^3)^0.1 Fr^-0.6 Re^-0.21      Re_c <= 6000
    C_m = 3.644 (h/D_p)^0.1 (V_0/D_p^3)^-0.35 Fr^-0.88 (b/D_p)^0.85  Re_c >= 9000

and, a choice of this tool (the paper leaves the band open), ``C_m``
interpolated linearly in ``Re_c`` between 6000 and 9000. The torque
vanishes at standstill (``T_ch ~ omega^0.59`` in the first regime), so
churning adds nothing to the starting torque.

Units: SI inside; the public methods take mm, litres, r/min and mm^2/s
and return N*mm.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from corr_cad.errors import SolverError

__all__ = ["ChurningGear", "GRAVITY", "RE_C_LOW", "RE_C_HIGH"]

#: Standard gravity, m/s^2.
GRAVITY = 9.80665
#: Changenet & Velex's two regimes of the critical Reynolds number ``omega R_p b / nu``.
RE_C_LOW = 6000.0
RE_C_HIGH = 9000.0


@dataclass(frozen=True)
class ChurningGear:
    """``count`` alike gears dipping ``immersion`` mm at ``speed_per_crank`` x the crank."""

    name: str
    count: int
    pitch_radius: float
    face_width: float
    immersion: float
    sump_volume_l: float
    speed_per_crank: float
    #: Oil density, kg/m^3.
    density: float = 870.0
    source: str = ""

    def __post_init__(self):
        if not (self.pitch_radius > 0 and self.face_width > 0 and self.sump_volume_l > 0):
            raise SolverError(
                f"churning {self.name}: pitch radius {self.pitch_radius!r} mm, face width "
                f"{self.face_width!r} mm and [lubrication] sump_volume_l = "
                f"{self.sump_volume_l!r} must be > 0, e.g. sump_volume_l = 1.0"
            )
        if not 0.0 < self.immersion <= 2.0 * self.pitch_radius:
            raise SolverError(
                f"[lubrication] immersion_depth_mm = {self.immersion!r}: allowed range is "
                f"(0, {2.0 * self.pitch_radius:g}] (the dipping gear's pitch diameter), e.g. "
                f"immersion_depth_mm = {self.pitch_radius / 2.0:g}"
            )

    def immersed_area_m2(self) -> float:
        """``S_m``, m^2: both faces' circular segments below the oil and the wetted rim."""
        r, b = self.pitch_radius * 1e-3, self.face_width * 1e-3
        theta = math.acos(1.0 - self.immersion / self.pitch_radius)
        return r * r * (2.0 * theta - math.sin(2.0 * theta)) + 2.0 * r * b * theta

    def coefficient(self, n_rpm, nu) -> np.ndarray:
        """``C_m`` at the gear's speed ``n_rpm`` (> 0) and viscosity ``nu`` (mm^2/s)."""
        w = np.abs(np.asarray(n_rpm, dtype=float)) * 2.0 * math.pi / 60.0
        v = np.asarray(nu, dtype=float) * 1e-6
        r, b, h = self.pitch_radius * 1e-3, self.face_width * 1e-3, self.immersion * 1e-3
        d, v0 = 2.0 * r, self.sump_volume_l * 1e-3
        fr = w * w * r / GRAVITY
        re, re_c = w * r * r / v, w * r * b / v
        low = 1.366 * (h / d) ** 0.45 * (v0 / d**3) ** 0.1 * fr**-0.6 * re**-0.21
        high = 3.644 * (h / d) ** 0.1 * (v0 / d**3) ** -0.35 * fr**-0.88 * (b / d) ** 0.85
        t = np.clip((re_c - RE_C_LOW) / (RE_C_HIGH - RE_C_LOW), 0.0, 1.0)
        return (1.0 - t) * low + t * high

    def moment(self, n_rpm, nu) -> np.ndarray:
        """One gear's churning torque, N*mm, at its speed ``n_rpm`` and viscosity ``nu``."""
        n = np.abs(np.asarray(n_rpm, dtype=float))
        safe = np.where(n > 0.0, n, 1.0)
        w = safe * 2.0 * math.pi / 60.0
        r = self.pitch_radius * 1e-3
        with np.errstate(over="ignore", invalid="ignore"):
            t = 0.5 * self.density * w * w * self.immersed_area_m2() * r**3
            t = t * self.coefficient(safe, nu)
        out = np.where(n > 0.0, 1e3 * t, 0.0)
        return float(out) if np.ndim(out) == 0 else out

    def as_dict(self) -> dict:
        return {
            "name": self.name,
            "count": self.count,
            "pitch_radius_mm": self.pitch_radius,
            "face_width_mm": self.face_width,
            "immersion_depth_mm": self.immersion,
            "sump_volume_l": self.sump_volume_l,
            "speed_per_crank": self.speed_per_crank,
            "immersed_area_m2": self.immersed_area_m2(),
            "source": self.source,
        }
