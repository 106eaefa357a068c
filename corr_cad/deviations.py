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
=====================  ==============================================  =======================

The roller centre ``H`` is where the nominal gear profile puts it. The
paper's Eqs. (19) and (21)-(23) add the same error again at the gear and
slot contacts; in a chain cam -> roller -> gear an interference is one
overlap, so counting it at several contacts double-counts it.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["ManufacturingErrors"]


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
    """

    cam_radius_error: float = 0.0
    eccentricity_error: float = 0.0
    roller_radius_error: float = 0.0
    roller_radius_errors: tuple[float, ...] | None = None

    @property
    def any(self) -> bool:
        per = self.roller_radius_errors
        return bool(
            self.cam_radius_error
            or self.eccentricity_error
            or self.roller_radius_error
            or (per is not None and any(per))
        )

    @property
    def per_roller(self) -> bool:
        """True when rollers differ, so the 2 pi / (z + 1) periodicity is lost."""
        per = self.roller_radius_errors
        return per is not None and len(set(per)) > 1

    def roller_errors(self, roller_count: int) -> np.ndarray:
        """Total radius error of each roller, (z + 1,) mm."""
        out = np.full(roller_count, float(self.roller_radius_error))
        if self.roller_radius_errors is not None:
            out = out + np.asarray(self.roller_radius_errors, dtype=float)
        return out
