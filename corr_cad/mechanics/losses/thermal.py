"""Thermal limit: the input speed at which the losses heat the housing to its limit.

A steady heat balance in the manner of ISO/TR 14179-1: the losses ``P_V``
leave through the housing surface ``A`` by convection and radiation,
``P_V = k A dT``, with ``k`` the heat transfer coefficient (about 15-20
W/(m^2 K) for a housing in still air) and ``dT`` the surface's rise over
the ambient. With constant Coulomb coefficients the losses at a torque are
proportional to the speed (:mod:`corr_cad.mechanics.losses.efficiency`), so the
thermal limit is the speed ``n = k A dT_max / (P_V / n)``.

What it cannot predict: the losses that do not scale with the load
(churning of the lubricant, seals, the bearings' load-independent
moment). At no load the model has no loss, so it predicts no temperature
rise where a no-load run-in test (the paper's prototype ran one to 2,000
rpm input) measures one; the speed limit is therefore an upper bound.
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["thermal_speed_rpm"]


def thermal_speed_rpm(
    loss_per_output_rad: np.ndarray,
    ratio: float,
    area_m2: float,
    heat_transfer_W_per_m2K: float,
    max_rise_K: float,
) -> np.ndarray:
    """Input speed (rpm) at which the losses equal ``k A dT_max``, per torque.

    ``loss_per_output_rad``: the drive's losses per radian of output, N*mm
    (so that at output speed ``w`` rad/s they are ``1e-3 w`` times that in
    W); ``ratio`` input per output speed (``z + 1``). ``inf`` where there is
    no loss.
    """
    heat = area_m2 * heat_transfer_W_per_m2K * max_rise_K  # W
    per_rpm = np.asarray(loss_per_output_rad, dtype=float) * 1e-3 * 2.0 * math.pi / 60.0 / ratio
    with np.errstate(divide="ignore"):
        return np.where(per_rpm > 0.0, heat / np.where(per_rpm > 0.0, per_rpm, 1.0), math.inf)
