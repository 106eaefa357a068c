"""Line contact between a roller and its mating parts (paper Eqs. 9-12, corrected).

The paper's deformation model: the Hertz half-width of a line contact is

    b^2 = 4 F R* / (pi l E'),   1/R* = k1 + k2,   1/E' = sum (1 - nu^2) / E,

and the approach is the geometric overlap of the two circles whose common
chord is ``2 b``:

    delta = (R1 - sqrt(R1^2 - b^2)) + (R2 - sqrt(R2^2 - b^2))

with signed curvatures ``k = 1/R`` (positive convex towards the contact,
negative concave, zero flat). Eq. (11) as printed uses the contact length
where the half-width belongs and orders the concave case's roots wrongly.
``R - sqrt(R^2 - b^2)`` cancels catastrophically for ``b << R``; the form
``k b^2 / (1 + sqrt(1 - k^2 b^2))`` used here does not.

For small ``b`` the approach tends to ``2 F / (pi l E')``, independent of the
radii: the *linear-contact limit*.

Where ``b`` reaches the smaller radius the model leaves its validity; the
approach is then continued along its tangent from ``b^2 = 0.99 / k_max^2``
so that it stays finite, increasing and convex, and the contact is flagged.
"""

from __future__ import annotations

import numpy as np

__all__ = [
    "PRESSURE_BOUND_MPA",
    "VALIDITY_KNEE",
    "half_width_sq_per_force",
    "knee",
    "knee_point",
    "approach",
    "approach_slope",
    "approach_and_slope",
    "linear_compliance",
    "max_pressure",
    "is_valid",
]

#: Contact pressure beyond which the numbers are flagged: 4000 MPa is above
#: the static load capacity of through-hardened bearing steel (ISO 76 takes
#: 4000 MPa as the limit for line contact of rollers), and far beyond the
#: elastic range the Hertz model assumes.
PRESSURE_BOUND_MPA = 4000.0

#: Share of the validity limit ``b = R_min`` (in ``b^2``) up to which the
#: exact overlap formula is used; beyond it the tangent continuation.
VALIDITY_KNEE = 0.99


def half_width_sq_per_force(k1, k2, length: float, modulus: float):
    """``b^2 / F`` for curvatures ``k1 + k2 > 0``, contact length and E', mm^2/N."""
    ksum = np.maximum(np.asarray(k1, dtype=float) + np.asarray(k2, dtype=float), 1e-300)
    return 4.0 / (np.pi * length * modulus * ksum)


def knee_point(k1, k2):
    """``u_k = b^2`` where the tangent continuation starts, mm^2."""
    k1 = np.asarray(k1, dtype=float)
    k2 = np.asarray(k2, dtype=float)
    return VALIDITY_KNEE / np.maximum(np.maximum(k1 * k1, k2 * k2), 1e-300)


def knee(k1, k2):
    """Where the tangent continuation starts: ``(u_k, delta(u_k), delta'(u_k))``."""
    k1 = np.asarray(k1, dtype=float)
    k2 = np.asarray(k2, dtype=float)
    uk = knee_point(k1, k2)
    q1 = np.sqrt(1.0 - k1 * k1 * uk)
    q2 = np.sqrt(1.0 - k2 * k2 * uk)
    return uk, k1 * uk / (1.0 + q1) + k2 * uk / (1.0 + q2), 0.5 * k1 / q1 + 0.5 * k2 / q2


def approach_and_slope(u, k1, k2, knee_values=None):
    """``(delta(u), d delta / d u)`` together, sharing the square roots.

    ``knee_values`` from :func:`knee` may be passed when the same contacts
    are evaluated many times (the solver's Newton loop); ``(u_k, None,
    None)`` (from :func:`knee_point`) is enough: the continuation is then
    computed only where ``u`` passes the knee, which is rare.
    """
    u = np.asarray(u, dtype=float)
    if knee_values is None:
        knee_values = (knee_point(k1, k2), None, None)
    uk, dk, sk = knee_values
    ue = np.minimum(u, uk)
    q1 = np.sqrt(1.0 - k1 * k1 * ue)
    val = k1 * ue / (1.0 + q1)
    slope = 0.5 * k1 / q1
    if not (np.ndim(k2) == 0 and k2 == 0.0):  # a flat body adds nothing
        q2 = np.sqrt(1.0 - k2 * k2 * ue)
        val = val + k2 * ue / (1.0 + q2)
        slope = slope + 0.5 * k2 / q2
    beyond = u > uk
    if not beyond.any():
        return val, slope
    if dk is None:  # the continuation, only where it is used
        shape = np.broadcast_shapes(u.shape, np.shape(k1), np.shape(k2))
        val = np.broadcast_to(val, shape).copy()
        slope = np.broadcast_to(slope, shape).copy()
        beyond = np.broadcast_to(beyond, shape)
        ub = np.broadcast_to(u, shape)[beyond]
        kb1 = np.broadcast_to(np.asarray(k1, dtype=float), shape)[beyond]
        kb2 = np.broadcast_to(np.asarray(k2, dtype=float), shape)[beyond]
        ukb, dkb, skb = knee(kb1, kb2)
        val[beyond] = dkb + skb * (ub - ukb)
        slope[beyond] = skb
        return val, slope
    return np.where(beyond, dk + sk * (u - uk), val), np.where(beyond, sk, slope)


def approach(u, k1, k2):
    """Approach ``delta(u)`` for ``u = b^2`` (mm^2), signed curvatures ``k1, k2``, mm."""
    return approach_and_slope(u, k1, k2)[0]


def approach_slope(u, k1, k2):
    """d delta / d u, continuous and non-decreasing."""
    return approach_and_slope(u, k1, k2)[1]


def linear_compliance(length: float, modulus: float) -> float:
    """Small-``b`` limit of ``delta / F = 2 / (pi l E')``, mm/N."""
    return 2.0 / (np.pi * length * modulus)


def max_pressure(force, u_per_force, length: float):
    """Maximum Hertz line-contact pressure ``2 F / (pi b l)``, MPa.

    Written as ``2 sqrt(F / (b^2/F)) / (pi l)`` so that it is exact at ``F = 0``.
    """
    force = np.maximum(np.asarray(force, dtype=float), 0.0)
    return 2.0 * np.sqrt(force / np.asarray(u_per_force, dtype=float)) / (np.pi * length)


def is_valid(u, k1, k2):
    """True where the half-width is smaller than both radii."""
    kmax2 = np.maximum(np.asarray(k1) ** 2, np.asarray(k2) ** 2)
    return np.asarray(u) * kmax2 < 1.0
