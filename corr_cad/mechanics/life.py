"""Rating life of the eccentric bearings and the roller contacts, and of the whole drive.

Eccentric needle bearings (ISO 281:2007, basic rating life)
-----------------------------------------------------------
``L10 = (C / P)^(10/3)`` million revolutions of the bearing's inner ring
relative to its outer ring. ``P`` is the equivalent load over the crank
revolution, the mean of exponent 10/3 weighted by the revolutions made at
each load (ISO 281 section 7, variable load): ``P = (sum P_k^(10/3) n_k /
sum n_k)^(3/10)``. The basic dynamic load rating is given (the maker's
catalogue) or computed from the needle geometry by ISO 281's formula for
radial roller bearings, ``C_r = b_m f_c (i L_we cos alpha)^(7/9) Z^(3/4)
D_we^(29/27)`` with ``b_m = 1.1`` (ISO 281 Table 1, needle roller bearings
with machined rings) and ``f_c`` from the closed form of ISO/TR 1281-1
behind ISO 281 Table 7 (:func:`iso281_fc`, ``lambda nu = 0.83``).

Roller contacts (Lundberg-Palmgren line contact)
------------------------------------------------
The rollers around the cam form a roller bearing whose inner raceway is
the cam and whose outer raceway is the ring: ``Z = z + 1`` rollers of
diameter ``D = 2 r`` and length ``l`` on the pitch diameter ``2 L``
(``gamma = r / L``). Each raceway's basic dynamic capacity is
Lundberg-Palmgren's line-contact formula (Harris & Kotzalas, *Rolling
Bearing Analysis*; ISO/TS 16281 uses it per lamina)::

    Q_c = 552 lambda nu c^(29/27) (1 -+ gamma)^(-1/4) gamma^(2/9) D^(29/27) l^(7/9) Z^(-1/4)

with the conformity factor ``c = 2 R* / D = 1 / (1 + r k)`` of the actual
contact at each position and roller (``k`` the other body's signed
curvature, convex positive: ``c = 1 - gamma`` on a cam of radius ``L - r``,
``1 + gamma`` in a ring of radius ``L + r``). The raceway's life is
``L = (Q_c / Q_e)^4`` million revolutions relative to the roller set (the
frame), with the equivalent roller load of exponent 4 for a raceway that
turns relative to its load and 4.5 for one that stands still relative to
it (a cam fixed on the crank), averaged over the positions (the load
history the solver gives). The roller's own fatigue is folded into the
raceway capacities, as in Lundberg-Palmgren. The slot wall is not rated:
the roller slides along it at nearly every position (wear, not rolling
contact fatigue).

System
------
Lives at 90 % reliability combine by the Weibull rule with the slope of
line contact, ``L = (sum L_i^(-9/8))^(-8/9)`` (Lundberg-Palmgren; ISO 281's
``e = 9/8`` for roller bearings).

Units: N, mm; speeds in rpm; lives in hours.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from corr_cad.errors import SolverError
from corr_cad.geometry.kinematics import floating_cam_spin

__all__ = [
    "BEARING_EXPONENT",
    "WEIBULL_SLOPE",
    "iso281_fc",
    "needle_dynamic_rating",
    "equivalent_load",
    "bearing_life_h",
    "raceway_capacity",
    "raceway_life_h",
    "system_life_h",
    "rolling_speeds",
]

#: ISO 281 life exponent of roller bearings.
BEARING_EXPONENT = 10.0 / 3.0
#: Weibull slope of line contact (Lundberg-Palmgren), for the system life.
WEIBULL_SLOPE = 9.0 / 8.0
#: ISO 281 b_m of needle roller bearings with machined rings (Table 1).
B_M_NEEDLE = 1.1
#: Reduction factor lambda*nu of ISO/TR 1281-1 for line contact.
LAMBDA_NU = 0.83


def iso281_fc(gamma: float) -> float:
    """ISO 281's ``f_c`` of radial roller bearings at ``gamma = D_we cos(alpha) / D_pw``.

    The closed form of ISO/TR 1281-1 from which ISO 281:2007 Table 7 is
    tabulated: ``207.9 lambda nu gamma^(2/9) (1 - gamma)^(29/27) /
    (1 + gamma)^(1/4) [1 + (1.04 ((1 - gamma)/(1 + gamma))^(143/108))^(9/2)]^(-2/9)``.
    """
    g = float(gamma)
    if not 0.0 < g < 1.0:
        raise SolverError(f"gamma = {g!r}: allowed range is (0, 1), e.g. 0.07")
    ratio = 1.04 * ((1.0 - g) / (1.0 + g)) ** (143.0 / 108.0)
    return (
        207.9
        * LAMBDA_NU
        * g ** (2.0 / 9.0)
        * (1.0 - g) ** (29.0 / 27.0)
        / (1.0 + g) ** 0.25
        * (1.0 + ratio**4.5) ** (-2.0 / 9.0)
    )


def needle_dynamic_rating(
    needles: int, needle_diameter: float, needle_length: float, pitch_diameter: float
) -> float:
    """ISO 281 basic dynamic radial load rating of one row of needles, N (mm in)."""
    g = needle_diameter / pitch_diameter
    return (
        B_M_NEEDLE
        * iso281_fc(g)
        * needle_length ** (7.0 / 9.0)
        * needles**0.75
        * needle_diameter ** (29.0 / 27.0)
    )


def equivalent_load(loads: np.ndarray, revolutions: np.ndarray, exponent: float) -> float:
    """``(sum P^p n / sum n)^(1/p)``: the mean load of exponent ``p`` weighted by revolutions."""
    P = np.abs(np.asarray(loads, dtype=float)).reshape(-1)
    n = np.abs(np.asarray(revolutions, dtype=float)).reshape(-1)
    if n.sum() == 0.0:
        return 0.0
    return float((np.sum(P**exponent * n) / np.sum(n)) ** (1.0 / exponent))


def bearing_life_h(
    rating: float, loads: np.ndarray, relative_speed: np.ndarray, output_rpm: float
) -> float:
    """ISO 281 L10 of a bearing in hours, ``inf`` if it never turns or carries nothing.

    ``loads`` (P,) N and ``relative_speed`` (P,) per unit output speed over
    the positions of one cycle (equally spaced in time); ``output_rpm``
    the output speed.
    """
    speed = np.abs(np.asarray(relative_speed, dtype=float))
    P = equivalent_load(loads, speed, BEARING_EXPONENT)
    rpm = float(np.mean(speed)) * output_rpm
    if P == 0.0 or rpm == 0.0:
        return math.inf
    return (rating / P) ** BEARING_EXPONENT * 1e6 / (60.0 * rpm)


def raceway_capacity(
    conformity: np.ndarray,
    outer: bool,
    rollers: int,
    roller_diameter: float,
    roller_length: float,
    gamma: float,
) -> np.ndarray:
    """Lundberg-Palmgren line-contact capacity ``Q_c`` of a raceway, N (per contact)."""
    speed = (1.0 - gamma) if outer else (1.0 + gamma)
    return (
        552.0
        * LAMBDA_NU
        * np.asarray(conformity, dtype=float) ** (29.0 / 27.0)
        * speed**-0.25
        * gamma ** (2.0 / 9.0)
        * roller_diameter ** (29.0 / 27.0)
        * roller_length ** (7.0 / 9.0)
        * rollers**-0.25
    )


def raceway_life_h(
    loads: np.ndarray,
    capacity: np.ndarray,
    relative_speed: float,
    output_rpm: float,
    stationary_load: bool,
) -> float:
    """Lundberg-Palmgren L10 of a raceway in hours from the roller loads (P, Z).

    ``capacity`` (P, Z) or scalar: ``Q_c`` of each contact; the equivalent
    load ratio is averaged over the positions with exponent 4 (the raceway
    turns relative to its load) or 4.5 (it stands still relative to it);
    ``relative_speed`` the raceway's speed relative to the roller set per
    unit output speed.
    """
    w = 4.5 if stationary_load else 4.0
    q = np.abs(np.asarray(loads, dtype=float)) / np.asarray(capacity, dtype=float)
    mean = float(np.mean(np.mean(q**w, axis=1)))
    rpm = abs(relative_speed) * output_rpm
    if mean == 0.0 or rpm == 0.0:
        return math.inf
    return mean ** (-4.0 / w) * 1e6 / (60.0 * rpm)


def rolling_speeds(design, mounting: str) -> dict[str, float]:
    """Relative speeds per unit output speed from the rolling kinematics, for the lives.

    The rollers about the cam as a roller bearing (module docstring): the
    frame is the cage (speed 1), the ring the outer race (fixed), the cam
    the inner race. With rolling at both races the cage turns at
    ``omega_i (1 - gamma) / 2 + omega_o (1 + gamma) / 2`` (Harris &
    Kotzalas, *Rolling Bearing Analysis*, rolling element and cage speeds),
    so a cam floating on its bearing spins at ``omega_cam = 2 / (1 - gamma)
    = 2 L / R_j``, whatever the friction coefficients. Returns ``bearing``:
    the eccentric bearing's ``|omega_crank - omega_cam|`` (``z + 1 - 2 L /
    R_j``; 0 with the cam fixed on the crank), ``cam``: the cam raceway's
    speed relative to the rollers (``2 L / R_j - 1``; fixed: ``z``),
    ``ring``: the ring's (1).
    """
    crank = float(design.roller_count)
    cam = floating_cam_spin(design) if mounting == "bearing" else crank
    return {"bearing": abs(crank - cam), "cam": abs(cam - 1.0), "ring": 1.0}


def system_life_h(lives: list[float] | np.ndarray) -> float:
    """Weibull combination ``(sum L_i^(-e))^(-1/e)``, ``e = 9/8``: the life of the whole."""
    L = np.asarray(lives, dtype=float)
    s = float(np.sum(L ** (-WEIBULL_SLOPE)))
    return math.inf if s == 0.0 else s ** (-1.0 / WEIBULL_SLOPE)


@dataclass(frozen=True)
class LifeSpec:
    """``[life]``: the rated point and the eccentric bearing's rating.

    ``dynamic_load_rating`` (N) given, or computed from ``needles``,
    ``needle_diameter``, ``needle_length`` and ``pitch_diameter`` (mm).
    """

    rated_life_h: float = 6000.0
    rated_speed_rpm: float = 15.0
    dynamic_load_rating: float | None = None
    needles: int = 40
    needle_diameter: float = 6.0
    needle_length: float = 12.0
    pitch_diameter: float = 88.4

    def rating(self) -> tuple[float, str]:
        """The bearing's C_r, N, and where it comes from."""
        if self.dynamic_load_rating is not None:
            return float(self.dynamic_load_rating), "given ([life] dynamic_load_rating_N)"
        C = needle_dynamic_rating(
            self.needles, self.needle_diameter, self.needle_length, self.pitch_diameter
        )
        return C, "ISO 281 from the needle geometry (b_m = 1.1, f_c of ISO/TR 1281-1)"
