"""The cam's eccentric bearing: a ring of needles between the eccentric and the cam bore.

Model (``[bearings.eccentric]``, the default and only bearing model)
-----------------------------------------------------------------------
``Z`` needles of diameter ``D`` and length ``l`` with a diametral clearance
``Pd``. Needle ``j`` sits at the eccentric's direction ``+ 2 pi j / Z``
(unit vector ``e_j`` in the frame that turns with the eccentric, angles from
+y towards +x as everywhere). The cam centre moves by ``u`` (two unknowns)
relative to the eccentric; the races approach at needle ``j`` by

    delta_j = -u . e_j - Pd / 2

(the cam moving towards ``-e_j`` squeezes needle ``j``), and each needle
carries ``Q_j`` from its two raceway contacts in series, each of Palmgren's
line-contact law (:mod:`corr_cad.mechanics.palmgren`):

    delta_j = 2 c Q_j^0.9,   c = 3.84e-5 / l^0.8 (steel, scaled by (C / C_steel)^0.9).

The needles push the cam by ``sum_j Q_j e_j``; at equilibrium this balances
the rollers' resultant on the cam (Harris & Kotzalas, *Rolling Bearing
Analysis*, Ch. 7, the static load distribution of a radially loaded bearing,
with the needles taken as rigid bodies between elastic line contacts). The
moment of the crank is unchanged: the needles and the rollers' cam forces
act through the cam centre.

For a bearing with zero clearance and many needles, Stribeck's closed form
for line contact gives the largest needle load ``Q_max = 4.08 F_r / Z``
(Harris & Kotzalas, Eq. (7.29); the constant 4.08 of Stribeck's 5 for balls
and the Palmgren exponent 10/9).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from corr_cad.errors import SolverError
from corr_cad.mechanics import palmgren

__all__ = ["EccentricBearing"]


@dataclass(frozen=True)
class EccentricBearing:
    """A needle bearing between the eccentric and the cam (mm; ``needles`` >= 3)."""

    needles: int
    needle_diameter: float
    needle_length: float
    diametral_clearance: float = 0.0
    #: ``C = (1 - nu1^2)/E1 + (1 - nu2^2)/E2`` of a raceway contact, 1/MPa (steel).
    compliance: float = palmgren.STEEL_COMPLIANCE

    def __post_init__(self):
        n = self.needles
        if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < 3:
            raise SolverError(f"needles = {n!r}: allowed range is integers >= 3, e.g. 40")
        for name, works in (("needle_diameter", 6.0), ("needle_length", 12.0)):
            v = getattr(self, name)
            if not (isinstance(v, (int, float)) and math.isfinite(v) and v > 0):
                raise SolverError(f"{name} = {v!r}: allowed range is (0, inf) mm, e.g. {works}")
        pd = self.diametral_clearance
        if not (
            isinstance(pd, (int, float)) and math.isfinite(pd) and 0 <= pd < self.needle_diameter
        ):
            raise SolverError(
                f"diametral_clearance = {pd!r}: allowed range is [0, needle_diameter) mm, e.g. 0.0"
            )

    @property
    def needle_coefficient(self) -> float:
        """``2 c``: a needle's approach ``delta = 2 c Q^0.9`` over both raceways, mm/N^0.9."""
        return 2.0 * palmgren.coefficient(self.needle_length, self.compliance)

    def directions(self) -> np.ndarray:
        """Unit vectors ``e_j`` (Z, 2) in the eccentric's frame (needle 0 along the eccentric)."""
        a = 2.0 * np.pi * np.arange(self.needles) / self.needles
        return np.stack([np.sin(a), np.cos(a)], axis=1)

    def loads(self, u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Needle loads ``Q`` (..., Z), N, and ``dQ/d delta``, at cam displacements ``u``."""
        ej = self.directions()
        delta = -(u @ ej.T) - 0.5 * self.diametral_clearance
        return palmgren.force_and_slope(delta, self.needle_coefficient)

    def stribeck_max_load(self, radial_load: float) -> float:
        """Stribeck's ``Q_max = 4.08 F_r / Z`` for line contact and zero clearance, N."""
        return 4.08 * float(radial_load) / self.needles

    def as_dict(self) -> dict:
        """The bearing as the files record it."""
        return {
            "model": "needle ring, Palmgren line contacts on both raceways",
            "needles": int(self.needles),
            "needle_diameter_mm": float(self.needle_diameter),
            "needle_length_mm": float(self.needle_length),
            "diametral_clearance_mm": float(self.diametral_clearance),
        }
