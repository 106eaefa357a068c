"""The lubricant: kinematic viscosity against temperature.

Viscosity classes (ISO 3448)
----------------------------
An ISO VG grade is the midpoint kinematic viscosity at 40 C in mm^2/s
(the class spans +-10 %). ISO 3448 says nothing of 100 C; for a grade
alone the tool takes a mineral oil of viscosity index 95 (the oil of the
viscosity-temperature diagram of the SKF rolling bearings catalogue):
its viscosity at 100 C (:data:`ISO_VG_NU100`) is the ``nu_100`` at which
ASTM D2270 (ISO 2909) gives VI = 95 for ``nu_40`` the grade, solved once
from the standard's L and H table (the test recomputes two grades from
the table's rows). Give ``viscosity_40C`` and ``viscosity_100C`` of the
oil's data sheet instead to use the oil itself.

Viscosity against temperature (ASTM D341, Walther's equation)
-------------------------------------------------------------
``log10(log10(nu + 0.7)) = A - B log10(T)``, ``T`` in kelvin, ``nu`` in
mm^2/s, through the two given points (ASTM D341's simple form, valid for
``nu >= 2`` mm^2/s). A grease is described by its base oil's viscosities
(as SKF's and ISO 281's viscosity ratio ``kappa`` use them).

Units: mm^2/s, C.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from corr_cad.errors import SolverError

__all__ = ["ISO_VG_NU100", "LUBRICANT_KINDS", "Lubricant", "walther_viscosity"]

#: ``oil`` (bath or splash) or ``grease``.
LUBRICANT_KINDS = ("oil", "grease")

#: ISO VG grade -> kinematic viscosity at 100 C (mm^2/s) of a VI 95 mineral oil
#: (ASTM D2270 solved for ``nu_100`` at ``nu_40`` = the grade, VI = 95).
ISO_VG_NU100 = {
    7: 2.104,
    10: 2.637,
    15: 3.381,
    22: 4.254,
    32: 5.289,
    46: 6.645,
    68: 8.530,
    100: 11.07,
    150: 14.55,
    220: 18.75,
    320: 23.96,
    460: 30.35,
    680: 39.06,
    1000: 49.86,
    1500: 64.22,
    2200: 81.18,
    3200: 101.6,
}

_K = 273.15


def _ww(nu: float) -> float:
    return math.log10(math.log10(nu + 0.7))


def walther_viscosity(
    nu40: float, nu100: float, temperature_C: float | np.ndarray
) -> float | np.ndarray:
    """ASTM D341 (Walther) through ``(40 C, nu40)`` and ``(100 C, nu100)``, mm^2/s."""
    t1, t2 = math.log10(40.0 + _K), math.log10(100.0 + _K)
    b = (_ww(nu40) - _ww(nu100)) / (t2 - t1)
    a = _ww(nu40) + b * t1
    t = np.log10(np.asarray(temperature_C, dtype=float) + _K)
    out = 10.0 ** (10.0 ** (a - b * t)) - 0.7
    return float(out) if np.ndim(out) == 0 else out


@dataclass(frozen=True)
class Lubricant:
    """An oil, or a grease's base oil: viscosities at 40 and 100 C (mm^2/s)."""

    nu40: float
    nu100: float
    kind: str = "oil"
    #: How the viscosities were given: ``"ISO VG 68"`` or ``"viscosity_40C/100C"``.
    source: str = ""

    def __post_init__(self):
        if not (math.isfinite(self.nu40) and math.isfinite(self.nu100)):
            raise SolverError("lubricant: viscosities must be finite numbers, e.g. 68 and 8.5")
        if not 2.0 <= self.nu100 < self.nu40:
            raise SolverError(
                f"lubricant: viscosity_100C = {self.nu100:g} mm^2/s must be at least 2 "
                f"(ASTM D341) and below viscosity_40C = {self.nu40:g}, e.g. 68 and 8.5"
            )
        if self.kind not in LUBRICANT_KINDS:
            raise SolverError(f"lubricant: kind = {self.kind!r}: one of {LUBRICANT_KINDS}")

    @classmethod
    def iso_vg(cls, grade: int, kind: str = "oil") -> Lubricant:
        """The VI 95 mineral oil of an ISO VG grade (:data:`ISO_VG_NU100`)."""
        if grade not in ISO_VG_NU100:
            raise SolverError(
                f"iso_vg = {grade!r}: one of {', '.join(map(str, ISO_VG_NU100))}, e.g. 68"
            )
        return cls(float(grade), ISO_VG_NU100[grade], kind, f"ISO VG {grade}, VI 95 mineral oil")

    def viscosity(self, temperature_C: float | np.ndarray) -> float | np.ndarray:
        """Kinematic viscosity (mm^2/s) at ``temperature_C`` (ASTM D341)."""
        return walther_viscosity(self.nu40, self.nu100, temperature_C)

    def as_dict(self) -> dict:
        return {
            "kind": self.kind,
            "viscosity_40C_mm2_per_s": self.nu40,
            "viscosity_100C_mm2_per_s": self.nu100,
            "source": self.source,
            "viscosity_temperature_model": "ASTM D341 (Walther) through the 40 and 100 C points",
        }
