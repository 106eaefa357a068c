"""ISO 281:2007's modified rating life of a roller bearing: ``L_nm = a1 a_ISO L10``.

``a_ISO`` (ISO 281:2007, 9.3.2, radial roller bearings) from the viscosity
ratio ``kappa = nu / nu1`` and ``e_C C_u / P``::

    a_ISO = 0.1 [1 - (1.5859 - x1 / kappa^x2)^0.83 (e_C C_u / P)^0.4]^(-9.185)

with ``(x1, x2) = (1.3993, 0.054381)`` for ``0.1 <= kappa < 0.4``,
``(1.2348, 0.19087)`` for ``0.4 <= kappa < 1`` and ``(1.2348, 0.071739)``
for ``1 <= kappa <= 4``; ``kappa`` above 4 is taken as 4 and below 0.1 as
0.1 (outside the standard's range; the files say so), ``a_ISO`` at most 50.

``nu1``, the rated viscosity needed for adequate lubrication (the curves
of ISO 281:2007's diagram in closed form, as the SKF rolling bearings
catalogue writes them; ``n`` r/min, ``dm`` mm)::

    nu1 = 45000 n^-0.83 dm^-0.5   (n < 1000)
    nu1 = 4500 n^-0.5 dm^-0.5     (n >= 1000)

The fatigue load limit of a roller bearing (ISO 281:2007, Annex B):
``C_u = C_0r / 8.2`` for ``dm <= 100`` mm, times ``(100 / dm)^0.3`` above;
the basic static rating of a radial roller bearing (ISO 76:2006, 6.1.1):
``C_0r = 44 (1 - D_we cos(alpha) / D_pw) i Z L_we D_we cos(alpha)``.

``e_C`` is the contamination factor of ISO 281:2007 Table 13 (for ``dm <
100`` mm: 1 extreme cleanliness, 0.8-0.6 high, 0.6-0.5 normal, 0.5-0.3
slight contamination, 0.3-0.1 typical, 0.1-0 severe, 0 very severe).

Units: N, mm, r/min, mm^2/s.
"""

from __future__ import annotations

import math

from corr_cad.errors import SolverError

__all__ = [
    "reference_viscosity",
    "static_rating_roller",
    "fatigue_load_limit",
    "a_iso_roller",
    "modified_life",
    "A_ISO_MAX",
]

#: ISO 281's cap on a_ISO.
A_ISO_MAX = 50.0


def reference_viscosity(n_rpm: float, dm: float) -> float:
    """``nu1``: the viscosity needed for adequate lubrication, mm^2/s."""
    if not (n_rpm > 0 and dm > 0):
        raise SolverError(f"nu1: speed {n_rpm!r} r/min and dm {dm!r} mm must be > 0")
    if n_rpm < 1000.0:
        return 45000.0 * n_rpm**-0.83 * dm**-0.5
    return 4500.0 * n_rpm**-0.5 * dm**-0.5


def static_rating_roller(
    rows: int, rollers: int, length: float, diameter: float, dm: float, cos_alpha: float = 1.0
) -> float:
    """ISO 76 ``C_0r = 44 (1 - D cos(alpha) / d_m) i Z L D cos(alpha)`` of a radial roller
    bearing, N (contact angle 0 unless ``cos_alpha`` is given)."""
    return 44.0 * (1.0 - diameter * cos_alpha / dm) * rows * rollers * length * diameter * cos_alpha


def fatigue_load_limit(c0: float, dm: float) -> float:
    """ISO 281 Annex B ``C_u`` of a roller bearing, N."""
    return c0 / 8.2 * (1.0 if dm <= 100.0 else (100.0 / dm) ** 0.3)


def a_iso_roller(kappa: float, ec_cu_over_p: float) -> float:
    """ISO 281:2007's ``a_ISO`` of a radial roller bearing (kappa clipped to [0.1, 4], <= 50)."""
    k = min(max(float(kappa), 0.1), 4.0)
    if k < 0.4:
        x1, x2 = 1.3993, 0.054381
    elif k < 1.0:
        x1, x2 = 1.2348, 0.19087
    else:
        x1, x2 = 1.2348, 0.071739
    inner = 1.5859 - x1 / k**x2
    base = 1.0 - max(inner, 0.0) ** 0.83 * max(float(ec_cu_over_p), 0.0) ** 0.4
    if base <= 0.0:
        return A_ISO_MAX
    return min(0.1 * base**-9.185, A_ISO_MAX)


def modified_life(
    l10_h: float | None,
    viscosity: float,
    n_rpm: float,
    dm: float,
    c0: float,
    load: float,
    contamination: float,
) -> dict:
    """``a_ISO`` and ``L_10m`` (h) of a roller bearing at one operating point."""
    nu1 = reference_viscosity(n_rpm, dm) if n_rpm > 0 else math.inf
    kappa = viscosity / nu1
    cu = fatigue_load_limit(c0, dm)
    x = contamination * cu / load if load > 0 else math.inf
    a = a_iso_roller(kappa, x) if math.isfinite(x) else A_ISO_MAX
    life = None if l10_h is None or not math.isfinite(l10_h) else a * l10_h
    return {
        "kappa": kappa,
        "nu1_mm2_per_s": nu1,
        "viscosity_mm2_per_s": viscosity,
        "fatigue_load_limit_N": cu,
        "static_rating_N": c0,
        "equivalent_load_N": load,
        "ec_Cu_over_P": x if math.isfinite(x) else None,
        "a_ISO": a,
        "L10_h": l10_h,
        "L10m_h": life,
        "kappa_outside_0.1_4": not 0.1 <= kappa <= 4.0,
    }
