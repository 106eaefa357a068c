"""Losses that do not depend on the load: the bearings' drag and the seals.

Bearing drag (Palmgren)
-----------------------
A rolling bearing turning at ``n`` r/min in a lubricant of kinematic
viscosity ``nu`` (mm^2/s) at the operating temperature resists with the
load-independent moment (Palmgren, *Ball and Roller Bearing Engineering*,
1959; Harris & Kotzalas, *Essential Concepts of Bearing Technology*, 5th
ed., Sec. 9.2)::

    M0 = 1e-7 f0 (nu n)^(2/3) dm^3     N*mm, for nu n >= 2000
    M0 = 160e-7 f0 dm^3                N*mm, for nu n <  2000

with ``dm`` the bearing's mean (pitch) diameter in mm and ``f0`` a factor
of the bearing type and the lubrication (Harris & Kotzalas's table of
``f0``: needle roller bearings 6 with oil mist, 12 in an oil bath, 24 with
a vertical shaft or oil jet; deep groove ball bearings 1 with oil mist, 2
in an oil bath, 4 with a vertical shaft or oil jet). The two branches meet
at ``nu n = 2000`` to 1 % (``2000^(2/3) = 158.7``). Below ``nu n = 2000``
the moment no longer falls with the speed: it is the drag at start-up.

Seals
-----
A contact lip seal is taken as Coulomb friction: a constant moment
``M_seal`` whatever the speed (the seal maker's figure for the shaft and
the lubricant; 0 without seals), so its power is ``M_seal omega``.

Reflection to the input
-----------------------
Each element ``i`` turns at ``k_i`` times the crank speed (its bearing's
relative speed); the power ``sum M_i omega_i`` is the crank's moment
``sum k_i M_i`` times the crank speed: that moment is the load-independent
input torque at the crank, finite at zero speed (the starting torque).

Units: N*mm, r/min, mm, mm^2/s.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from corr_cad.errors import SolverError
from corr_cad.mechanics.losses.churning import ChurningGear
from corr_cad.mechanics.losses.lubrication import Lubricant

__all__ = ["palmgren_m0", "DragBearing", "LoadIndependent", "PALMGREN_KNEE"]

#: ``nu n`` (mm^2/s * r/min) below which Palmgren's moment is constant.
PALMGREN_KNEE = 2000.0


def palmgren_m0(f0: float, nu: np.ndarray, n: np.ndarray, dm: float) -> np.ndarray:
    """Palmgren's load-independent moment, N*mm (``nu`` mm^2/s, ``n`` r/min, ``dm`` mm)."""
    vn = np.abs(np.asarray(nu, dtype=float) * np.asarray(n, dtype=float))
    high = 1e-7 * f0 * np.maximum(vn, PALMGREN_KNEE) ** (2.0 / 3.0) * dm**3
    low = 160e-7 * f0 * dm**3
    out = np.where(vn >= PALMGREN_KNEE, high, low)
    return float(out) if np.ndim(out) == 0 else out


@dataclass(frozen=True)
class DragBearing:
    """``count`` alike bearings of pitch diameter ``dm`` (mm) at ``speed_per_crank`` x the crank."""

    name: str
    count: int
    dm: float
    f0: float
    speed_per_crank: float
    #: Where the sizes come from, as the files state it.
    source: str = ""

    def __post_init__(self):
        if not (self.dm > 0 and self.f0 >= 0 and math.isfinite(self.speed_per_crank)):
            raise SolverError(
                f"bearing drag {self.name}: dm = {self.dm!r} mm must be > 0, f0 = {self.f0!r} "
                ">= 0, e.g. dm = 88.4, f0 = 12"
            )


@dataclass(frozen=True)
class LoadIndependent:
    """Every load-independent loss of the drive, and the lubricant's viscosity law.

    ``input_per_crank``: the input shaft's speed per crank speed (the first
    stage's ratio, 1 without one); ``output_per_crank``: ``1 / (z + 1)``.
    ``input_seal``, ``output_seal``: the seals' constant moments, N*mm.
    """

    lubricant: Lubricant
    bearings: tuple[DragBearing, ...] = field(default_factory=tuple)
    input_seal: float = 0.0
    output_seal: float = 0.0
    input_per_crank: float = 1.0
    output_per_crank: float = 1.0
    #: Dip-lubricated gears' churning (:mod:`corr_cad.mechanics.losses.churning`); none by default.
    churning: tuple[ChurningGear, ...] = field(default_factory=tuple)

    def moments(self, crank_rpm, temperature_C) -> dict[str, np.ndarray]:
        """Each element's moment reflected to the crank (``k_i M_i``), N*mm, by name."""
        n = np.abs(np.asarray(crank_rpm, dtype=float))
        nu = self.lubricant.viscosity(temperature_C)
        out: dict[str, np.ndarray] = {}
        for b in self.bearings:
            k = abs(b.speed_per_crank)
            m = palmgren_m0(b.f0, nu, k * n, b.dm) if k > 0 else 0.0 * n
            out[b.name] = b.count * k * np.asarray(m) + 0.0 * n
        for g in self.churning:
            k = abs(g.speed_per_crank)
            out[g.name] = g.count * k * np.asarray(g.moment(k * n, nu)) + 0.0 * n
        if self.input_seal:
            out["input_seal"] = self.input_seal * abs(self.input_per_crank) + 0.0 * n
        if self.output_seal:
            out["output_seal"] = self.output_seal * abs(self.output_per_crank) + 0.0 * n
        return out

    def crank_moment(self, crank_rpm, temperature_C) -> np.ndarray:
        """The load-independent moment at the crank, N*mm: the drive's drag torque."""
        m = self.moments(crank_rpm, temperature_C)
        total = sum(m.values()) if m else 0.0 * np.asarray(crank_rpm, dtype=float)
        return total + 0.0 * np.asarray(crank_rpm, dtype=float) * np.asarray(temperature_C)

    def power_W(self, crank_rpm, temperature_C) -> np.ndarray:
        """The load-independent loss, W, at the crank speed (r/min) and oil temperature."""
        w = np.abs(np.asarray(crank_rpm, dtype=float)) * 2.0 * math.pi / 60.0
        return 1e-3 * self.crank_moment(crank_rpm, temperature_C) * w

    def as_dict(self) -> dict:
        out = {
            "lubricant": self.lubricant.as_dict(),
            "bearings": [
                {
                    "name": b.name,
                    "count": b.count,
                    "pitch_diameter_mm": b.dm,
                    "f0": b.f0,
                    "speed_per_crank": b.speed_per_crank,
                    "source": b.source,
                }
                for b in self.bearings
            ],
            "input_seal_moment_Nmm": self.input_seal,
            "output_seal_moment_Nmm": self.output_seal,
            "bearing_model": "Palmgren: M0 = 1e-7 f0 (nu n)^(2/3) dm^3 N*mm for nu n >= 2000, "
            "160e-7 f0 dm^3 below (Harris & Kotzalas)",
            "seal_model": "Coulomb lip friction: a constant moment per seal",
        }
        if self.churning:
            out["churning"] = [g.as_dict() for g in self.churning]
            out["churning_model"] = (
                "Changenet & Velex (ASME J. Mech. Des. 2007): T = 0.5 rho omega^2 S_m R_p^3 "
                "C_m, C_m of Fr, Re, h/D_p, V_0/D_p^3 (and b/D_p above Re_c = 9000; linear "
                "in Re_c between 6000 and 9000)"
            )
        return out
