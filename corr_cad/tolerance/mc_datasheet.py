"""Datasheet metrics of Monte Carlo samples: lost motion, rigidity, transmission error, binding.

Each sample's windup ``theta(T, x)`` (:mod:`corr_cad.mechanics.row.windup`) is
solved by the compiled kernel (:mod:`corr_cad.mechanics.row.mc_windup_kernel`)
at the torques the figures need, at every output position of the sample's
**evaluation grid**: ``[montecarlo] datasheet_positions_per_mesh`` (4) per mesh period over
one mesh period when the parts are alike, one tooth pitch when the tolerances
(or the scene's errors) make rollers or slots differ (the drive then repeats
after a tooth pitch, so this is the whole output revolution), a full output
revolution once the ring has a profile deviation
(:func:`corr_cad.mechanics.binding.evaluation_positions`). Per sample:

============================================  =============================================
column                                        value (the datasheet's catalogue figure)
============================================  =============================================
``lost_motion_arcmin``                        max over x of ``theta(+b T_R) - theta(-b T_R)``
``torsional_rigidity_Nm_per_arcmin``          min over x and both branches of
                                              ``(T_2 - T_1) / (theta(T_2) - theta(T_1))``,
                                              with the series rigidity when given
``transmission_error_arcsec``                 the larger peak-to-peak over x of
                                              ``theta(-T_TE)`` (forward) and ``theta(+T_TE)``
``binding_pressure_MPa``                      the largest gap-only preload pressure
                                              (:mod:`corr_cad.mechanics.binding`)
``binds``                                     1 when it exceeds the pressure limit, else 0
============================================  =============================================

:func:`binding_probability` gives the share of binding samples with its
sampling error (Wilson score interval). Pure numpy around the kernel.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from corr_cad.errors import SolverError
from corr_cad.geometry.design import GearDesign
from corr_cad.geometry.deviations import ManufacturingErrors
from corr_cad.mechanics.binding import DEFAULT_PRESSURE_LIMIT_MPA
from corr_cad.mechanics.datasheet import DatasheetSpec
from corr_cad.mechanics.row.solver import _RTOL, roller_geometry
from corr_cad.mechanics.row.windup import (
    ARCMIN_PER_RAD,
    ARCSEC_PER_RAD,
    NMM_PER_NM,
    mesh_period_rad,
    series_rigidity_Nmm_per_rad,
)

__all__ = [
    "DATASHEET_MC_METRICS",
    "DEFAULT_POSITIONS_PER_MESH",
    "DatasheetMC",
    "grid_positions",
    "datasheet_chunk",
    "windup_metrics",
    "binding_probability",
]

#: Default positions per mesh period of the samples' grid: against 16, the
#: p50/p99 of lost motion, rigidity and transmission error move by 0.5 % or
#: less (docs/tolerances.md), at a quarter of the cost.
DEFAULT_POSITIONS_PER_MESH = 4

#: Columns the datasheet pass adds to the Monte Carlo's metrics.
DATASHEET_MC_METRICS = (
    "lost_motion_arcmin",
    "torsional_rigidity_Nm_per_arcmin",
    "transmission_error_arcsec",
    "binding_pressure_MPa",
    "binds",
)


@dataclass(frozen=True)
class DatasheetMC:
    """What the Monte Carlo's datasheet pass evaluates.

    ``spec``: the scene's :class:`~corr_cad.mechanics.datasheet.DatasheetSpec`
    (rated torque, bands, rigidity range, series rigidity; its
    ``positions_per_mesh`` is the datasheet curve's, not the samples').
    ``binding_pressure_MPa``: preload pressure above which a sample binds.
    ``positions_per_mesh``: the samples' grid.
    """

    spec: DatasheetSpec
    binding_pressure_MPa: float = DEFAULT_PRESSURE_LIMIT_MPA
    #: Positions per mesh period of the samples' grid (``[montecarlo]
    #: datasheet_positions_per_mesh``); coarser than the datasheet's curve.
    positions_per_mesh: int = DEFAULT_POSITIONS_PER_MESH

    def torques(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Output torques to solve (N*mm, each once), their zero signs, and the columns.

        ``zero[j]`` is ``-1``/``+1`` where torque ``j`` is ``-0``/``+0`` (an end
        of the free rotation), else 0. ``columns`` (8,) picks, for
        ``+b, -b, +te, -te, +T_1, +T_2, -T_1, -T_2`` (shares of T_R), the
        torque solved; the default bands are equal, so six solves serve eight.
        """
        sp = self.spec
        b, te = sp.lost_motion_band, sp.transmission_error_torque_band
        t1, t2 = sp.rigidity_range
        wanted = [(b, 0), (-b, 0), (te, 0), (-te, 0), (t1, 1), (t2, 1), (-t1, -1), (-t2, -1)]
        keys: list[tuple[float, int]] = []
        columns = []
        for share, side in wanted:
            key = (share, side if share == 0 else 0)
            if key not in keys:
                keys.append(key)
            columns.append(keys.index(key))
        torques = np.array([share * sp.rated_torque for share, _ in keys], dtype=float)
        zero = np.array([side for _, side in keys], dtype=np.int64)
        return torques, zero, np.array(columns)


def grid_positions(
    design: GearDesign,
    base: ManufacturingErrors,
    tolerance_kinds,
    positions_per_mesh: int,
) -> np.ndarray:
    """The samples' evaluation grid (output angles, rad); see the module docstring."""
    mesh = mesh_period_rad(design)
    if base.profile_deviation is not None:
        period = 2.0 * math.pi
    elif base.per_roller or {"roller_radius", "slot_angle"} & set(tolerance_kinds):
        period = 2.0 * math.pi / design.tooth_count
    else:
        period = mesh
    n = int(round(period / mesh)) * int(positions_per_mesh)
    return period * np.arange(n) / n


def datasheet_chunk(
    design: GearDesign,
    errors: tuple,
    n: int,
    cfg: DatasheetMC,
    grid: np.ndarray,
    load_share: float,
    psi_limit: float,
    base: ManufacturingErrors,
) -> tuple[dict[str, np.ndarray], bool]:
    """Datasheet metrics of ``n`` samples whose errors are ``(cam, ecc, phase, dr, dl)``."""
    from corr_cad.mechanics.row import mc_kernel, mc_windup_kernel

    R = design.roller_count
    angles = design.tooth_count * grid
    g = roller_geometry(design, angles, psi_contact_limit=psi_limit)
    if base.profile_deviation is not None:
        t_abs = grid[:, None] + np.arange(R)[None, :] * design.slot_pitch_rad
        pd = np.asarray(base.profile_deviation(t_abs), dtype=float) + 0.0 * g.psi
    else:
        pd = np.zeros_like(g.psi)
    cam, ecc, phase, dr, dl = errors
    torques, zero, cols = cfg.torques()
    moments = -load_share * torques / R
    P, M = len(grid), len(torques)
    theta = np.empty((n, P, M))
    backlash, pressure, inter, rel = (np.empty(n) for _ in range(4))
    c = np.ascontiguousarray
    mc_windup_kernel.windup_samples(
        *mc_kernel.kernel_inputs(g, pd, (cam, ecc, phase, dr, dl), design),
        c(moments),
        c(zero),
        _RTOL,
        theta,
        backlash,
        pressure,
        inter,
        rel,
    )
    if np.any(np.isinf(rel)):
        raise SolverError(
            f"datasheet Monte Carlo: no roller can carry the output torque in "
            f"{int(np.count_nonzero(np.isinf(rel)))} of {n} samples"
        )
    return windup_metrics(theta, cfg, pressure), bool(np.all(rel <= max(_RTOL, 1e-9)))


def windup_metrics(theta: np.ndarray, cfg: DatasheetMC, pressure: np.ndarray) -> dict:
    """The table's columns from each sample's contact windup and preload pressure.

    ``theta`` (n, P, M) rad at the torques of :meth:`DatasheetMC.torques` (the
    contacts alone: the series compliance is added here); ``pressure`` (n,) MPa.
    """
    sp = cfg.spec
    torques, _, cols = cfg.torques()
    theta = theta + torques[None, None, :] / series_rigidity_Nmm_per_rad(
        sp.series_rigidity_Nm_per_arcmin
    )
    theta = theta[:, :, cols]  # +b, -b, +te, -te, +T_1, +T_2, -T_1, -T_2
    lost = (theta[:, :, 0] - theta[:, :, 1]).max(axis=1) * ARCMIN_PER_RAD
    te_f = np.ptp(theta[:, :, 3], axis=1)  # forward: theta(-T_TE)
    te_r = np.ptp(theta[:, :, 2], axis=1)  # reverse: theta(+T_TE)
    t1, t2 = sp.rigidity_range
    dT = (t2 - t1) * sp.rated_torque / NMM_PER_NM
    k_pos = dT / ((theta[:, :, 5] - theta[:, :, 4]) * ARCMIN_PER_RAD)
    k_neg = dT / ((theta[:, :, 6] - theta[:, :, 7]) * ARCMIN_PER_RAD)
    return {
        "lost_motion_arcmin": lost,
        "torsional_rigidity_Nm_per_arcmin": np.minimum(k_pos.min(axis=1), k_neg.min(axis=1)),
        "transmission_error_arcsec": np.maximum(te_f, te_r) * ARCSEC_PER_RAD,
        "binding_pressure_MPa": pressure,
        "binds": (pressure > cfg.binding_pressure_MPa).astype(float),
    }


def binding_probability(binds: np.ndarray, confidence: float = 0.95) -> dict:
    """Share of binding samples, its binomial standard error and Wilson score interval.

    ``p = k / n``; standard error ``sqrt(p (1 - p) / n)``; the Wilson interval
    at ``confidence`` (``z`` the two-sided normal quantile, 1.96 at 95 %)::

        (p + z^2/(2n) +- z sqrt(p (1 - p)/n + z^2/(4 n^2))) / (1 + z^2/n)

    which stays inside [0, 1] and is not empty at ``k = 0`` or ``k = n``.

    >>> r = binding_probability(np.array([0, 0, 1, 0]))
    >>> r["probability"], round(r["standard_error"], 4), [round(v, 4) for v in r["wilson_interval"]]
    (0.25, 0.2165, [0.0456, 0.6994])
    """
    from scipy.special import ndtri  # scipy.stats.norm.ppf's bits, without its 0.2 s import

    b = np.asarray(binds, dtype=float)
    n = int(b.size)
    if n == 0:
        raise SolverError("binding probability of zero samples")
    k = float(b.sum())
    p = k / n
    z = float(ndtri(0.5 + 0.5 * confidence))
    centre = (p + z * z / (2 * n)) / (1 + z * z / n)
    half = z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / (1 + z * z / n)
    return {
        "probability": p,
        "binding_samples": int(k),
        "samples": n,
        "standard_error": math.sqrt(p * (1 - p) / n),
        # exactly 0 (1) when no (every) sample binds: the closed form's round-off is ~1e-18
        "wilson_interval": [
            0.0 if k == 0 else max(0.0, centre - half),
            1.0 if k == n else min(1.0, centre + half),
        ],
        "confidence": confidence,
    }
