"""The crankshaft's support bearings: radial stiffness from the rolling elements' contacts.

Two types (``[bearings.crank] type``), each a ring of ``Z`` rollers per row
of diameter ``D``, effective contact length ``l`` and contact angle
``alpha`` on the pitch diameter ``d_m``; roller ``j`` at ``psi_j = 2 pi j / Z``
from the load line (one roller on the load line: Harris & Kotzalas, *Rolling
Bearing Analysis*, 5th ed., Vol. 1, Ch. 7, the static load distribution of
a radially loaded bearing). The rollers are rigid bodies between two
elastic line contacts (inner and outer raceway), each of Palmgren's law
(:mod:`corr_cad.mechanics.palmgren`): a roller's normal approach is
``delta = 2 c Q^0.9``, ``c = 3.84e-5 / l^0.8`` (steel).

* ``"cylindrical"`` (one row, ``alpha = 0``) with the diametral clearance
  ``Pd`` (``clearance``; negative: a preload, the rings' interference):
  under the inner ring's radial displacement ``delta_r`` along the load,
  roller ``j`` approaches by ``delta_r cos psi_j - Pd / 2``.
* ``"tapered_pair"``: two rows of tapered rollers at ``+-alpha``, mounted as a
  pair (face to face or back to back: under a radial load alone the same),
  with the pair's axial end play ``s_a`` (``clearance``; negative: an axial
  preload). Under a radial load the induced axial forces of the two rows
  balance with the inner ring axially centred (the pair is symmetric), and
  roller ``j`` of either row approaches along its contact normal by
  ``delta_r cos(alpha) cos psi_j - (s_a / 2) sin(alpha)``; its load ``Q_j``
  carries ``Q_j cos(alpha)`` radially. The rib contacts are not modelled.

The radial load is ``F_r = sum_j Q_j cos(alpha) cos psi_j`` over both rows;
:meth:`SupportBearing.displacement` inverts it by a safeguarded Newton (it is
monotone in ``delta_r``). Its radial stiffness ``K_r = dF_r / d delta_r`` at
zero clearance follows the closed form of Harris & Kotzalas (Ch. 7):
``Q_max = F_r / (Z J_r(0.5) cos alpha)`` with ``J_r(0.5) = 0.2453`` for line
contact (Stribeck's ``Q_max = 4.08 F_r / Z``), ``delta_r cos(alpha) = 2 c
Q_max^0.9``, ``K_r = F_r / (0.9 delta_r)``.

Rating life (ISO 281:2007): ``C_r = b_m f_c (i l cos alpha)^(7/9) Z^(3/4)
D^(29/27)`` with ``b_m = 1.1`` (ISO 281 Table 1, cylindrical and tapered
roller bearings), ``f_c`` of :func:`corr_cad.mechanics.life.iso281_fc` at
``gamma = D cos(alpha) / d_m``, ``i`` rows (a pair counted as one
two-row bearing); ``L10 = (C_r / P)^(10/3)`` million revolutions with ``P``
the radial load (a pair under a radial load alone: ``X = 1``, ``Y = 0``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from corr_cad.errors import SolverError
from corr_cad.mechanics import palmgren
from corr_cad.mechanics.life import iso281_fc

__all__ = ["SUPPORT_TYPES", "SupportBearing", "J_R_LINE"]

#: The support bearing types.
SUPPORT_TYPES = ("cylindrical", "tapered_pair")
#: Harris & Kotzalas's radial integral ``J_r(0.5)`` for line contact (load exponent 1.1).
J_R_LINE = 0.2453
#: ISO 281 Table 1: ``b_m`` of cylindrical and tapered roller bearings.
B_M_ROLLER = 1.1


@dataclass(frozen=True)
class SupportBearing:
    """One support bearing of the crankshaft (mm; angles in degrees)."""

    type: str
    rollers: int
    roller_diameter: float
    roller_length: float
    pitch_diameter: float
    #: Cylindrical: diametral clearance; tapered pair: axial end play. Negative: a preload.
    clearance: float = 0.0
    contact_angle_deg: float = 0.0
    width: float = 0.0
    #: ``C_r``, N (None: ISO 281's formula from the geometry).
    dynamic_load_rating: float | None = None
    #: ``C = (1 - nu1^2)/E1 + (1 - nu2^2)/E2`` of a raceway contact, 1/MPa (steel).
    compliance: float = palmgren.STEEL_COMPLIANCE

    def __post_init__(self):
        if self.type not in SUPPORT_TYPES:
            raise SolverError(
                f"type = {self.type!r}: allowed values are {', '.join(SUPPORT_TYPES)}, "
                "e.g. cylindrical"
            )
        n = self.rollers
        if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < 3:
            raise SolverError(f"rollers = {n!r}: allowed range is integers >= 3, e.g. 16")
        for name, works in (("roller_diameter", 12.0), ("roller_length", 12.0)):
            v = getattr(self, name)
            if not (isinstance(v, (int, float)) and math.isfinite(v) and v > 0):
                raise SolverError(f"{name} = {v!r}: allowed range is (0, inf) mm, e.g. {works}")
        dm = self.pitch_diameter
        if not (isinstance(dm, (int, float)) and math.isfinite(dm) and dm > self.roller_diameter):
            raise SolverError(
                f"pitch_diameter = {dm!r}: allowed range is (roller_diameter, inf) mm, e.g. 85.0"
            )
        a = self.contact_angle_deg
        if self.type == "cylindrical" and a != 0.0:
            raise SolverError(
                f"contact_angle_deg = {a!r}: a cylindrical roller bearing has 0; "
                'use type = "tapered_pair" for an angle'
            )
        if self.type == "tapered_pair" and not (5.0 <= a <= 45.0):
            raise SolverError(f"contact_angle_deg = {a!r}: allowed range is [5, 45], e.g. 15")
        c = self.clearance
        if not (isinstance(c, (int, float)) and math.isfinite(c) and abs(c) < self.roller_diameter):
            raise SolverError(
                f"clearance = {c!r}: allowed range is (-roller_diameter, roller_diameter) mm, "
                "e.g. 0.0"
            )

    # ------------------------------------------------------------------ geometry

    @property
    def rows(self) -> int:
        """Rows of rollers: 1 (cylindrical) or 2 (a tapered pair)."""
        return 2 if self.type == "tapered_pair" else 1

    @property
    def cos_alpha(self) -> float:
        return math.cos(math.radians(self.contact_angle_deg))

    @property
    def roller_coefficient(self) -> float:
        """``2 c``: a roller's approach ``2 c Q^0.9`` over both raceways, mm/N^0.9."""
        return 2.0 * palmgren.coefficient(self.roller_length, self.compliance)

    @property
    def offset(self) -> float:
        """A roller's normal approach at ``delta_r = 0`` (negative: a gap), mm."""
        if self.type == "cylindrical":
            return -0.5 * self.clearance
        return -0.5 * self.clearance * math.sin(math.radians(self.contact_angle_deg))

    def _cos_psi(self) -> np.ndarray:
        return np.cos(2.0 * np.pi * np.arange(self.rollers) / self.rollers)

    # ------------------------------------------------------------------ load law

    def roller_loads(self, delta_r) -> np.ndarray:
        """Each roller's normal load (..., Z), N, of one row at the radial displacement
        ``delta_r`` (mm)."""
        d = np.asarray(delta_r, dtype=float)[..., None]
        approach = d * self.cos_alpha * self._cos_psi() + self.offset
        return palmgren.force(approach, self.roller_coefficient)

    def radial_load_and_stiffness(self, delta_r) -> tuple[np.ndarray, np.ndarray]:
        """``F_r`` (N) and ``K_r = dF_r/d delta_r`` (N/mm) at ``delta_r`` (mm)."""
        d = np.asarray(delta_r, dtype=float)[..., None]
        cp, ca = self._cos_psi(), self.cos_alpha
        Q, k = palmgren.force_and_slope(d * ca * cp + self.offset, self.roller_coefficient)
        F = self.rows * ca * np.sum(Q * cp, axis=-1)
        K = self.rows * ca * ca * np.sum(k * cp * cp, axis=-1)
        return F, K

    def displacement(self, radial_load) -> np.ndarray:
        """The inner ring's radial displacement along the load, mm, at ``F_r`` (N, >= 0).

        Zero at zero load (where a shaft in its clearance sits is not fixed by
        anything; the first newton of load takes the clearance up).
        """
        F = np.abs(np.asarray(radial_load, dtype=float))
        ca = self.cos_alpha
        # Start above the root: every loaded roller at the largest roller's load.
        q = F / (J_R_LINE * self.rollers * self.rows * ca)
        hi = (np.maximum(-self.offset, 0.0) + self.roller_coefficient * q**0.9) / (ca * 0.5)
        hi = np.maximum(hi, 1e-12)
        lo = np.zeros_like(F) + (np.maximum(-self.offset, 0.0) / ca)
        x = hi.copy()
        for _ in range(200):
            f, k = self.radial_load_and_stiffness(x)
            r = f - F
            lo = np.where(r < 0, np.maximum(lo, x), lo)
            hi = np.where(r > 0, np.minimum(hi, x), hi)
            with np.errstate(divide="ignore", invalid="ignore"):
                step = np.where(k > 0, r / k, np.inf)
            nxt = x - step
            bad = ~np.isfinite(nxt) | (nxt <= lo) | (nxt >= hi)
            nxt = np.where(bad, 0.5 * (lo + hi), nxt)
            if np.all(np.abs(nxt - x) <= 1e-15 * np.abs(x) + 1e-300):
                x = nxt
                break
            x = nxt
        return np.where(F > 0, x, 0.0)

    def stiffness(self, radial_load) -> np.ndarray:
        """Tangent radial stiffness ``K_r`` (N/mm) at the load ``F_r`` (N)."""
        return self.radial_load_and_stiffness(self.displacement(radial_load))[1]

    def closed_form_displacement(self, radial_load) -> np.ndarray:
        """Harris & Kotzalas's zero-clearance ``delta_r`` (mm) of ``F_r`` (N): ``Q_max = F_r /
        (Z J_r(0.5) cos alpha)`` per row, ``delta_r = 2 c Q_max^0.9 / cos alpha``."""
        F = np.asarray(radial_load, dtype=float)
        q = F / (self.rows * self.rollers * J_R_LINE * self.cos_alpha)
        return self.roller_coefficient * q**0.9 / self.cos_alpha

    # ------------------------------------------------------------------ life

    @property
    def rating(self) -> float:
        """``C_r``, N: given, or ISO 281's formula for radial roller bearings."""
        if self.dynamic_load_rating is not None:
            return float(self.dynamic_load_rating)
        ca = self.cos_alpha
        fc = iso281_fc(self.roller_diameter * ca / self.pitch_diameter)
        return (
            B_M_ROLLER
            * fc
            * (self.rows * self.roller_length * ca) ** (7.0 / 9.0)
            * self.rollers**0.75
            * self.roller_diameter ** (29.0 / 27.0)
        )

    def life_mrev(self, equivalent_load: float) -> float:
        """``L10`` in million revolutions at the equivalent radial load ``P`` (N)."""
        if equivalent_load <= 0:
            return math.inf
        return (self.rating / equivalent_load) ** (10.0 / 3.0)

    def as_dict(self) -> dict:
        return {
            "type": self.type,
            "model": "rollers between two Palmgren line contacts, one roller on the load line",
            "rollers_per_row": int(self.rollers),
            "rows": self.rows,
            "roller_diameter_mm": float(self.roller_diameter),
            "roller_length_mm": float(self.roller_length),
            "pitch_diameter_mm": float(self.pitch_diameter),
            "contact_angle_deg": float(self.contact_angle_deg),
            "clearance_mm": float(self.clearance),
            "clearance_meaning": "diametral clearance"
            if self.type == "cylindrical"
            else "axial end play of the pair",
            "dynamic_load_rating_N": float(self.rating),
            "dynamic_load_rating_source": "given"
            if self.dynamic_load_rating is not None
            else "ISO 281 formula",
        }
