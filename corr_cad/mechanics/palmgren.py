"""Palmgren's line contact: the approach of a steel roller, as bearing practice computes it.

Palmgren's empirical law for the approach of a roller to one raceway
(Harris & Kotzalas, *Rolling Bearing Analysis*, 5th ed., Vol. 2, Eq. (6.40)
with the constants of their Table; Palmgren, *Ball and Roller Bearing
Engineering*, 1959):

    delta = 3.84e-5 Q^0.9 / l^0.8        (delta mm, Q N, l mm; steel)

for steel (E = 2.06e5 MPa, nu = 0.3). For other elastic constants the
approach is scaled by ``(C / C_steel)^0.9`` with ``C = (1 - nu1^2)/E1 + (1 -
nu2^2)/E2`` (the law's ``Q^0.9`` comes with ``C^0.9``: the Hertz
half-width grows with ``Q C``).

Unlike the paper's Eqs. 9-12 (:mod:`corr_cad.mechanics.contact`) the
approach does not depend on the radii, and it is a power law: one roller's
three contacts in series, with forces ``w_i F`` (``w = 1, rho_n, |rho_s|``)
and compatibility weights ``w_i``, approach together by

    G(F) = sum_i w_i delta(w_i F) = K F^0.9,   K = c sum_i w_i^1.9,

which inverts in closed form: ``F = (h / K)^(1/0.9)``.

The slope ``d delta / d Q = 0.9 c Q^-0.1`` is infinite at ``Q = 0``. The
solvers never evaluate it there: they work with the inverse law
``F(h) = (h / K)^(10/9)``, whose slope ``(10/9) F / h`` is finite everywhere
and zero at ``h = 0`` (a contact just touching carries nothing and adds no
stiffness), and they take the compliance slope only of loaded contacts.
"""

from __future__ import annotations

import numpy as np

from corr_cad.mechanics import contact

__all__ = [
    "PALMGREN_COEFFICIENT",
    "PALMGREN_FORCE_EXPONENT",
    "PALMGREN_LENGTH_EXPONENT",
    "STEEL_COMPLIANCE",
    "coefficient",
    "approach",
    "force",
    "force_and_slope",
    "PalmgrenCompliance",
]

#: mm N^-0.9 mm^0.8: ``delta = 3.84e-5 Q^0.9 / l^0.8`` for steel on steel.
PALMGREN_COEFFICIENT = 3.84e-5
PALMGREN_FORCE_EXPONENT = 0.9
PALMGREN_LENGTH_EXPONENT = 0.8
#: ``C = 2 (1 - 0.3^2) / 2.06e5`` 1/MPa: the steel the coefficient was measured on.
STEEL_COMPLIANCE = 2.0 * (1.0 - 0.3**2) / 2.06e5


def coefficient(length: float, compliance: float = STEEL_COMPLIANCE) -> float:
    """``c`` of ``delta = c Q^0.9`` for one contact of length ``length`` (mm), mm/N^0.9.

    ``compliance`` is ``C = (1 - nu1^2)/E1 + (1 - nu2^2)/E2`` (1/MPa), i.e. ``1/E'``.
    """
    scale = (compliance / STEEL_COMPLIANCE) ** PALMGREN_FORCE_EXPONENT
    return PALMGREN_COEFFICIENT * scale / length**PALMGREN_LENGTH_EXPONENT


def approach(Q, length: float, compliance: float = STEEL_COMPLIANCE):
    """Approach of one contact under the load ``Q`` (N), mm (0 for ``Q <= 0``)."""
    Q = np.maximum(np.asarray(Q, dtype=float), 0.0)
    return coefficient(length, compliance) * Q**PALMGREN_FORCE_EXPONENT


def force(delta, c):
    """Load (N) of an approach ``delta`` (mm) of ``delta = c Q^0.9`` (0 for ``delta <= 0``)."""
    d = np.maximum(np.asarray(delta, dtype=float), 0.0)
    return (d / c) ** (1.0 / PALMGREN_FORCE_EXPONENT)


def force_and_slope(delta, c):
    """``(Q, dQ/d delta)`` of ``delta = c Q^0.9``; both 0 where ``delta <= 0``.

    The slope ``Q / (0.9 delta)`` is finite everywhere (0 at ``delta = 0``).
    """
    d = np.maximum(np.asarray(delta, dtype=float), 0.0)
    Q = (d / c) ** (1.0 / PALMGREN_FORCE_EXPONENT)
    with np.errstate(divide="ignore", invalid="ignore"):
        slope = np.where(d > 0, Q / (PALMGREN_FORCE_EXPONENT * np.where(d > 0, d, 1.0)), 0.0)
    return Q, slope


#: Force at which the secant compliance of :class:`PalmgrenCompliance` is taken
#: for the solver's linear start (the power 0.9 keeps it within a factor 1.6 of
#: the tangent from 10 N to 100 kN).
_SECANT_FORCE = 1000.0


class PalmgrenCompliance:
    """A roller's three contacts in series under Palmgren's law: ``G(F) = K F^0.9``.

    The same interface as the solver's compliance of the paper's law
    (``slope0``, ``invert``, ``value_and_slope``, ``take``, the Hertz
    half-width factors ``cj, cn, cs`` for the pressures), with the closed-form
    inverse. ``slope0`` is a secant compliance at 1 kN: only the solver's
    starting point uses it.
    """

    explicit = True
    linear = False

    def __init__(self, geo, design):
        length = design.roller_length
        modulus = design.material.contact_modulus
        c = coefficient(length, 1.0 / modulus)
        p = 1.0 + PALMGREN_FORCE_EXPONENT
        self.K = c * (1.0 + geo.rho_n**p + np.abs(geo.rho_s) ** p)
        self.slope0 = self.K * _SECANT_FORCE ** (PALMGREN_FORCE_EXPONENT - 1.0)
        k1 = geo.k_roller
        self.cj = contact.half_width_sq_per_force(k1, geo.k_cam, length, modulus)
        self.cn = contact.half_width_sq_per_force(k1, geo.k_gear, length, modulus)
        self.cs = contact.half_width_sq_per_force(k1, 0.0, length, modulus)

    def take(self, rows: np.ndarray) -> PalmgrenCompliance:
        """The compliance of a subset of positions."""
        sub = PalmgrenCompliance.__new__(PalmgrenCompliance)
        sub.K, sub.slope0 = self.K[rows], self.slope0[rows]
        sub.cj, sub.cn, sub.cs = (x[rows] if np.ndim(x) else x for x in (self.cj, self.cn, self.cs))
        return sub

    def value_and_slope(self, F: np.ndarray, sel=None):
        """``G(F)`` and ``G'(F)`` (infinite at ``F = 0``: never used there by the solvers)."""
        K = self.K if sel is None else self.K[sel]
        F = np.maximum(F, 0.0)
        g = K * F**PALMGREN_FORCE_EXPONENT
        with np.errstate(divide="ignore"):
            dg = PALMGREN_FORCE_EXPONENT * K * F ** (PALMGREN_FORCE_EXPONENT - 1.0)
        return g, dg

    def invert(self, h: np.ndarray, start=None, sel=None) -> tuple[np.ndarray, np.ndarray]:
        """``F`` with ``G(F) = h`` (0 where ``h <= 0``) and ``G'(F)`` (inf where ``F = 0``)."""
        K = self.K if sel is None else self.K[sel]
        F = force(h, K)
        with np.errstate(divide="ignore"):
            dg = np.where(
                F > 0,
                PALMGREN_FORCE_EXPONENT
                * K
                * np.where(F > 0, F, 1.0) ** (PALMGREN_FORCE_EXPONENT - 1.0),
                np.inf,
            )
        return F, dg

    def force_and_stiffness(self, h: np.ndarray, sel=None) -> tuple[np.ndarray, np.ndarray]:
        """``F(h)`` and ``dF/dh`` (finite, 0 at ``h <= 0``)."""
        K = self.K if sel is None else self.K[sel]
        return force_and_slope(h, K)
