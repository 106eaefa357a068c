"""The crankshaft: a Timoshenko beam on two support bearings, bent by the cams and twisted
by the crank moment (``[crankshaft]``).

Layout (axial coordinate ``z``, mm, the drive's: row A's rollers at ``0 ..
w``, row B's at ``w + t .. 2 w + t``): the shaft runs on two support
bearings at ``z_1 < z_2``; its two eccentric journals (diameter ``d_e``,
length ``l_e``) sit at ``z_A``, ``z_B``; the crank gear (the first stage's
internal gear, driven by three wheels 120 degrees apart, so a pure torque)
at ``z_g``. The shaft between is round, of diameter ``d`` (hollow: ``d_i``).

Bending (both planes alike: the section is round)
-------------------------------------------------
Each cam's bearing loads its eccentric journal by ``P_c`` (the force the
cam's needles, or a fixed cam, put on the eccentric: minus the rollers'
resultant on the cam). The two support bearings are the shaft's only radial
supports (each taken as a point at its mid-plane: no moment), so their
reactions follow from statics alone:

    R_1 = sum_c P_c (z_2 - z_c) / L,   R_2 = sum_c P_c (z_c - z_1) / L,   L = z_2 - z_1.

The deflection of eccentric ``i`` is the beam's, by the unit-load method
over the stepped shaft (Timoshenko: bending plus shear, Timoshenko & Gere,
*Mechanics of Materials*, the deflection of a simply supported beam;
Timoshenko, *Strength of Materials*, Part I, Section 39 for the shear term):

    w_i = sum_j P_j [ int M_j m_i / (E I) dz + int V_j v_i / (kappa G A) dz ]

plus the rigid-body motion of the supports' displacements ``d_1(R_1)``,
``d_2(R_2)`` (:mod:`corr_cad.mechanics.crank.support_bearing`, along each
reaction), interpolated linearly to ``z_i``. ``kappa = 6 (1 + nu) / (7 + 6
nu)`` is Cowper's shear coefficient of a solid round section (Cowper,
*J. Appl. Mech.* 33, 1966). The moment over each piece between the
supports, loads and section steps is linear, so Simpson's rule integrates
each piece exactly. An eccentric journal's section is its own circle (its
offset ``e`` from the shaft's axis is neglected in its bending).

Torsion
-------
The crank gear turns the eccentrics through the shaft: the segment between
the gear and the nearer eccentric carries the whole crank moment, the one
between the eccentrics the farther eccentric's (a gear between the
eccentrics twists each through its own segment only). The twist of eccentric
``c`` against the gear is

    theta_c = sum_c' M_c' Phi(nearer of z_c, z_c' to the gear),
    Phi(z) = int_{z_g}^{z} dz / (G J(z)),   J = pi (d^4 - d_i^4) / 32.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from corr_cad.errors import SolverError

__all__ = ["Crankshaft", "STEEL_E", "STEEL_NU"]

STEEL_E = 2.06e5
STEEL_NU = 0.3


@dataclass(frozen=True)
class Crankshaft:
    """The crankshaft's geometry and material (mm, MPa)."""

    shaft_diameter: float
    eccentric_diameter: float
    eccentric_length: float
    eccentric_positions: tuple[float, float]
    support_positions: tuple[float, float]
    gear_position: float
    bore_diameter: float = 0.0
    young_modulus: float = STEEL_E
    poisson_ratio: float = STEEL_NU

    def __post_init__(self):
        for name, works in (
            ("shaft_diameter", 60.0),
            ("eccentric_diameter", 82.4),
            ("eccentric_length", 12.0),
            ("young_modulus", STEEL_E),
        ):
            v = getattr(self, name)
            if not (isinstance(v, (int, float)) and math.isfinite(v) and v > 0):
                raise SolverError(f"{name} = {v!r}: allowed range is (0, inf), e.g. {works}")
        if not 0.0 <= self.bore_diameter < min(self.shaft_diameter, self.eccentric_diameter):
            raise SolverError(
                f"bore_diameter = {self.bore_diameter!r}: allowed range is [0, shaft_diameter) mm, "
                "e.g. 0.0"
            )
        if not 0.0 <= self.poisson_ratio < 0.5:
            raise SolverError(
                f"poisson_ratio = {self.poisson_ratio!r}: allowed range is [0, 0.5), e.g. 0.3"
            )
        z1, z2 = self.support_positions
        if not z2 > z1:
            raise SolverError(
                f"support_positions = {list(self.support_positions)}: the second must lie beyond "
                "the first, e.g. [-27.0, 59.0]"
            )

    # ------------------------------------------------------------------ sections

    @property
    def shear_modulus(self) -> float:
        return self.young_modulus / (2.0 * (1.0 + self.poisson_ratio))

    @property
    def shear_coefficient(self) -> float:
        """Cowper's ``kappa`` of a solid round section."""
        nu = self.poisson_ratio
        return 6.0 * (1.0 + nu) / (7.0 + 6.0 * nu)

    def diameter_at(self, z: np.ndarray) -> np.ndarray:
        """The section's outer diameter at ``z`` (the journal's at an eccentric)."""
        z = np.asarray(z, dtype=float)
        d = np.full(z.shape, float(self.shaft_diameter))
        h = 0.5 * self.eccentric_length
        for zc in self.eccentric_positions:
            d = np.where(np.abs(z - zc) < h, self.eccentric_diameter, d)
        return d

    def _section(self, z: np.ndarray):
        """``E I``, ``kappa G A`` and ``G J`` at ``z``."""
        d = self.diameter_at(z)
        di = self.bore_diameter
        inertia = math.pi * (d**4 - di**4) / 64.0
        area = math.pi * (d**2 - di**2) / 4.0
        return (
            self.young_modulus * inertia,
            self.shear_coefficient * self.shear_modulus * area,
            self.shear_modulus * 2.0 * inertia,
        )

    def _breaks(self, *extra: float) -> np.ndarray:
        h = 0.5 * self.eccentric_length
        pts = [*self.support_positions, *self.eccentric_positions, self.gear_position, *extra]
        for zc in self.eccentric_positions:
            pts += [zc - h, zc + h]
        return np.unique(np.asarray(pts, dtype=float))

    # ------------------------------------------------------------------ bending

    def _moment_shear(self, z: np.ndarray, a: float) -> tuple[np.ndarray, np.ndarray]:
        """Bending moment and shear at ``z`` of a unit load at ``a`` (supports pinned)."""
        z1, z2 = self.support_positions
        L = z2 - z1
        r1 = (z2 - a) / L
        m = r1 * np.maximum(z - z1, 0.0) - np.maximum(z - a, 0.0)
        m = m + (1.0 - r1) * np.maximum(z - z2, 0.0)
        v = r1 * (z > z1) - 1.0 * (z > a) + (1.0 - r1) * (z > z2)
        return m, v

    def beam_influence(self, positions: tuple[float, ...] | None = None) -> np.ndarray:
        """``c[i, j]``: deflection at ``positions[i]`` per unit load at ``positions[j]`` (mm/N),
        supports rigid (bending and shear)."""
        bend, shear = self.beam_influence_parts(positions)
        return bend + shear

    def beam_influence_parts(self, positions=None) -> tuple[np.ndarray, np.ndarray]:
        """:meth:`beam_influence`'s bending (``M m / E I``) and shear (``V v / kappa G A``)."""
        pts = tuple(self.eccentric_positions if positions is None else positions)
        n = len(pts)
        out = np.zeros((n, n))
        out_s = np.zeros((n, n))
        b = self._breaks(*pts)
        lo, hi = b[:-1], b[1:]
        mid = 0.5 * (lo + hi)
        ei, kga, _ = self._section(mid)
        for i in range(n):
            for j in range(n):
                mi = [self._moment_shear(x, pts[i]) for x in (lo, mid, hi)]
                mj = [self._moment_shear(x, pts[j]) for x in (lo, mid, hi)]
                # Simpson per piece: exact for M linear on it; V constant (mid-point).
                mm = (mi[0][0] * mj[0][0] + 4 * mi[1][0] * mj[1][0] + mi[2][0] * mj[2][0]) / 6
                out[i, j] = np.sum((hi - lo) * mm / ei)
                out_s[i, j] = np.sum((hi - lo) * mi[1][1] * mj[1][1] / kga)
        return out, out_s

    def reactions(self, loads: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Support reactions ``R_1``, ``R_2`` (..., 2) N of the loads (..., 2 eccentrics, 2)."""
        z1, z2 = self.support_positions
        L = z2 - z1
        za, zb = self.eccentric_positions
        P = np.asarray(loads, dtype=float)
        r1 = P[..., 0, :] * (z2 - za) / L + P[..., 1, :] * (z2 - zb) / L
        r2 = P[..., 0, :] * (za - z1) / L + P[..., 1, :] * (zb - z1) / L
        return r1, r2

    def support_lever(self) -> np.ndarray:
        """``s[c, i]``: eccentric ``c``'s displacement per unit displacement of support ``i``."""
        z1, z2 = self.support_positions
        L = z2 - z1
        return np.array([[(z2 - zc) / L, (zc - z1) / L] for zc in self.eccentric_positions])

    # ------------------------------------------------------------------ torsion

    def torsion_flexibility(self, z: float) -> float:
        """``Phi(z) = int dz / (G J)`` from the gear to ``z`` (rad per N*mm)."""
        zg = self.gear_position
        a, b = sorted((zg, float(z)))
        pts = self._breaks(a, b)
        pts = pts[(pts >= a) & (pts <= b)]
        if len(pts) < 2:
            return 0.0
        mid = 0.5 * (pts[:-1] + pts[1:])
        gj = self._section(mid)[2]
        return float(np.sum((pts[1:] - pts[:-1]) / gj))

    def torsion_matrix(self) -> np.ndarray:
        """``t[c, c']``: eccentric ``c``'s twist against the gear per unit moment at ``c'``."""
        zs = self.eccentric_positions
        zg = self.gear_position
        out = np.zeros((2, 2))
        for c in range(2):
            for k in range(2):
                if (zs[c] - zg) * (zs[k] - zg) < 0.0:
                    continue  # the gear between them: no segment carries both moments
                nearer = zs[c] if abs(zs[c] - zg) <= abs(zs[k] - zg) else zs[k]
                out[c, k] = self.torsion_flexibility(nearer)
        return out

    def as_dict(self) -> dict:
        return {
            "model": "Timoshenko beam (bending in both planes, shear, torsion), stepped round "
            "sections, pinned at the support bearings' mid-planes",
            "shaft_diameter_mm": float(self.shaft_diameter),
            "bore_diameter_mm": float(self.bore_diameter),
            "eccentric_diameter_mm": float(self.eccentric_diameter),
            "eccentric_length_mm": float(self.eccentric_length),
            "eccentric_positions_mm": [float(v) for v in self.eccentric_positions],
            "support_positions_mm": [float(v) for v in self.support_positions],
            "gear_position_mm": float(self.gear_position),
            "young_modulus_MPa": float(self.young_modulus),
            "poisson_ratio": float(self.poisson_ratio),
            "shear_coefficient": float(self.shear_coefficient),
        }
