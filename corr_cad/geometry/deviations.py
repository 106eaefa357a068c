"""Manufacturing and installation errors, mapped to initial gaps at the contacts.

Sign convention: a positive gap is an *interference* (the parts overlap
before any load), a negative one a clearance. The mapping (first order in the
error, exact for the eccentricity):

=====================  ==============================================  =======================
error                  cam contact ``g_j``                              gear ``g_n`` / slot
=====================  ==============================================  =======================
cam radius ``dRj``     ``+dRj``                                         --
eccentricity ``de``    ``L - |H - O1'|``, ``O1'`` at ``e + de``         --
roller radius ``dr``   ``+dr``                                          ``g_n = +dr``; slot
                                                                        clearance ``max(-dr, 0)``
                                                                        each side
slot angle ``d_i``     ``L - |H' - O1|``, ``H'`` on the locus at the     --
                       slot's true angle
cam phase ``dphi``     ``L - |H - O1'|``, ``O1'`` turned by ``dphi``    --
gear profile ``dev``   --                                               ``g_n = +dev(t)``
=====================  ==============================================  =======================

The roller centre ``H`` is where the nominal gear profile puts it. A slot
turned by ``d_i`` holds its roller where that slot line meets the gear's
roller-centre locus; the cam then overlaps it by ``L - |H' - O1|``. A cam
phase error is taken relative to the other cam, which positions the frame.
A gear profile deviation ``dev(t)`` (mm along the outward normal, positive
= material added into the tooth space) at the roller's polar angle ``t`` is
an interference at the gear contact. The
paper's Eqs. (19) and (21)-(23) add the same error again at the gear and
slot contacts; in a chain cam -> roller -> gear an interference is one
overlap, so counting it at several contacts double-counts it.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

__all__ = ["ManufacturingErrors", "HarmonicDeviation", "harmonic_deviation"]


@dataclass(frozen=True)
class ManufacturingErrors:
    """Errors in mm (all zero: the nominal design).

    Attributes
    ----------
    cam_radius_error : float
    eccentricity_error : float
    roller_radius_error : float
        Applied to every roller.
    roller_radius_errors : tuple of float or None
        Per-roller errors (z + 1 values), added to ``roller_radius_error``.
    slot_angle_errors : tuple of float or None, rad
        Angular position error of each slot (z + 1 values).
    cam_phase_error : float, rad
    profile_deviation : callable or None
        ``dev(t)``: normal deviation of the gear's working profile at polar
        angle ``t`` (rad, vectorised), mm; + = material added.
    slot_clearance : float or None, mm
        The slots' diametral clearance (``[design] slot_clearance``, the drive
        model): each flank of a centred roller's slot opens by
        ``slot_clearance / 2 - dr`` (negative: interference on both flanks,
        the paper's Eq. 26 for 0). None: the one-row convention, an oversize
        roller taken up by its slot and an undersize one opening ``|dr|``.
    """

    cam_radius_error: float = 0.0
    eccentricity_error: float = 0.0
    roller_radius_error: float = 0.0
    roller_radius_errors: tuple[float, ...] | None = None
    slot_angle_errors: tuple[float, ...] | None = None
    cam_phase_error: float = 0.0
    profile_deviation: Callable[[np.ndarray], np.ndarray] | None = None
    slot_clearance: float | None = None

    @property
    def any(self) -> bool:
        per = self.roller_radius_errors
        slots = self.slot_angle_errors
        return bool(
            self.cam_radius_error
            or self.eccentricity_error
            or self.roller_radius_error
            or self.cam_phase_error
            or (per is not None and any(per))
            or (slots is not None and any(slots))
            or self.profile_deviation is not None
            or bool(self.slot_clearance)
        )

    @property
    def per_roller(self) -> bool:
        """True when rollers differ, so the 2 pi / (z + 1) periodicity is lost."""
        per = self.roller_radius_errors
        slots = self.slot_angle_errors
        return (
            (per is not None and len(set(per)) > 1)
            or (slots is not None and len(set(slots)) > 1)
            or not self.tooth_periodic_profile
        )

    @property
    def tooth_periodic_profile(self) -> bool:
        """True without a profile deviation, or with one alike on every tooth
        (a designed modification, ``tooth_periodic``)."""
        dev = self.profile_deviation
        return dev is None or bool(getattr(dev, "tooth_periodic", False))

    def slot_errors(self, roller_count: int) -> np.ndarray:
        """Angular error of each slot, (z + 1,) rad."""
        if self.slot_angle_errors is None:
            return np.zeros(roller_count)
        return np.asarray(self.slot_angle_errors, dtype=float)

    def roller_errors(self, roller_count: int) -> np.ndarray:
        """Total radius error of each roller, (z + 1,) mm."""
        out = np.full(roller_count, float(self.roller_radius_error))
        if self.roller_radius_errors is not None:
            out = out + np.asarray(self.roller_radius_errors, dtype=float)
        return out


@dataclass(frozen=True)
class HarmonicDeviation:
    """``dev(t) = sum a_k cos(k t - phase_k)``: a gear profile deviation, mm (picklable)."""

    harmonics: tuple[tuple[float, float, float], ...]  # (k, a_k mm, phase_k rad)

    def __call__(self, t: np.ndarray) -> np.ndarray:
        t = np.asarray(t, dtype=float)
        out = np.zeros_like(t)
        for k, a, p in self.harmonics:
            out = out + a * np.cos(k * t - p)
        return out


def harmonic_deviation(harmonics) -> HarmonicDeviation:
    """From rows ``(k, amplitude mm, phase deg)``."""
    return HarmonicDeviation(
        tuple((float(k), float(a), math.radians(float(p))) for k, a, p in harmonics)
    )
