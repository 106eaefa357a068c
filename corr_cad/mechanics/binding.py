"""Binding: can the drive be assembled, or is it preloaded beyond a limit, at zero torque?

A pure function of the gaps and the contacts' elastic approach; no force
solve (no moment balance). Another module (a Monte Carlo, a profile
modification search) calls :func:`binding` with a design, its errors and
the output positions to look at.

Definition
----------
At output position ``x`` (crank locked, ring fixed, zero output torque) each
loadable roller ``i`` has the chain gap ``g_i`` (interference positive; the
force solver's gap, :mod:`corr_cad.mechanics.row.solver_geometry`) and the cam
advance ``a_i``; turning the cam by ``tau`` (frame held) gives it the overlap
``h_i(tau) = g_i + a_i tau``. The **free rotation** is the interval of ``tau``
over which no roller overlaps, ``[max_{a<0} -g/a, min_{a>0} -g/a]``
(:meth:`corr_cad.mechanics.row.windup.Windup.free_ends`), of output length
``(min_{a>0} - max_{a<0}) / (z + 1)``. Where it is **empty** the drive can
only be assembled by elastic deformation; the **interference** there is the
smallest largest overlap the cam can reach by turning,
``I = min_tau max_i h_i(tau)`` (at ``tau*``, where the largest overlaps of the
rollers with ``a > 0`` and ``a < 0`` are equal). Each roller's chain (cam,
gear and slot contact in series) is then compressed by ``h_i(tau*)``; the
force follows from its elastic approach ``G(F) = h`` (line-contact Hertz,
:mod:`corr_cad.mechanics.contact`) and the **preload pressure** is the
largest Hertz pressure of any of its contacts. The position **binds** when
the preload pressure exceeds ``pressure_limit_MPa`` (default 4000 MPa,
:data:`~corr_cad.mechanics.contact.PRESSURE_BOUND_MPA`: the static load
capacity of through-hardened bearing steel in line contact, ISO 76; the
parts would be brinelled on assembly). A drive binds when any position
binds.

``tau*`` is a gap-only choice: the equilibrium at zero torque balances the
moments too, which moves ``tau`` a little. ``I`` is a lower bound of the
largest overlap at any rotation, the equilibrium's included.

Units: mm, rad, MPa.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from corr_cad.errors import SolverError
from corr_cad.geometry.design import GearDesign
from corr_cad.geometry.deviations import ManufacturingErrors
from corr_cad.mechanics import contact
from corr_cad.mechanics.row.solver_geometry import roller_geometry
from corr_cad.mechanics.row.solver_numerics import _Compliance

__all__ = ["Binding", "binding", "evaluation_positions", "DEFAULT_PRESSURE_LIMIT_MPA"]

#: Default preload pressure limit, MPa (static capacity, ISO 76).
DEFAULT_PRESSURE_LIMIT_MPA = contact.PRESSURE_BOUND_MPA


def evaluation_positions(
    design: GearDesign,
    errors: ManufacturingErrors | None = None,
    positions_per_mesh: int = 16,
) -> np.ndarray:
    """Output angles (rad) over the span after which the drive repeats exactly.

    ``positions_per_mesh`` per mesh period ``2 pi/(z (z + 1))`` over one mesh
    period (alike parts), one tooth pitch (per-roller or per-slot errors:
    the whole output revolution's range) or one output revolution (a ring
    profile deviation), as the datasheet's windup curve
    (:func:`corr_cad.mechanics.row.windup.result_period_rad`).
    """
    from corr_cad.mechanics.row.windup import mesh_period_rad, result_period_rad

    if isinstance(positions_per_mesh, bool) or not isinstance(positions_per_mesh, int):
        raise SolverError(f"positions_per_mesh = {positions_per_mesh!r}: must be an integer >= 1")
    if positions_per_mesh < 1:
        raise SolverError(f"positions_per_mesh = {positions_per_mesh}: must be an integer >= 1")
    period = result_period_rad(design, errors)
    n = int(round(period / mesh_period_rad(design))) * positions_per_mesh
    return period * np.arange(n) / n


@dataclass(frozen=True)
class Binding:
    """Gap-only binding at each output position (arrays (P,)).

    Attributes
    ----------
    output_angles : numpy.ndarray
        Output positions, rad.
    free_rotation : numpy.ndarray
        Free rotation of the output, rad:
        ``(min_{a>0} - max_{a<0}) (-g/a) / (z + 1)``; negative where the
        free rotation is empty (its overlap).
    interference : numpy.ndarray
        ``min_tau max_i h_i(tau)``, mm, where the free rotation is empty, else 0.
    preload_pressure : numpy.ndarray
        Largest Hertz pressure of the rollers compressed by ``h_i(tau*)``, MPa.
    pressure_limit : float
        The limit, MPa.
    """

    output_angles: np.ndarray
    free_rotation: np.ndarray
    interference: np.ndarray
    preload_pressure: np.ndarray
    pressure_limit: float

    @property
    def binds_at(self) -> np.ndarray:
        """(P,) bool: the preload pressure exceeds the limit."""
        return self.preload_pressure > self.pressure_limit

    @property
    def binds(self) -> bool:
        """The drive binds: some position's preload pressure exceeds the limit."""
        return bool(np.any(self.binds_at))


def binding(
    design: GearDesign,
    errors: ManufacturingErrors | None = None,
    positions: np.ndarray | None = None,
    *,
    pressure_limit_MPa: float = DEFAULT_PRESSURE_LIMIT_MPA,
    positions_per_mesh: int = 16,
    psi_contact_limit: float = math.pi,
) -> Binding:
    """Whether the drive binds at zero torque, from gaps and elastic approach alone.

    Parameters
    ----------
    design : GearDesign
    errors : ManufacturingErrors, optional
        The full error model (uniform, per-roller, per-slot, cam, profile).
    positions : (P,) float, rad, optional
        Output angles, ring fixed (crank angle ``z x``, as
        :func:`corr_cad.mechanics.row.windup.crank_angles_of`). Default:
        :func:`evaluation_positions` at ``positions_per_mesh``.
    pressure_limit_MPa : float
        Preload pressure above which a position binds (default 4000 MPa).
    psi_contact_limit : float, rad
        Trimmed tooth tips of an allowed undercut carry nothing.

    Returns
    -------
    Binding
        See the module docstring for the definition.

    Examples
    --------
    >>> from corr_cad import GearDesign
    >>> from corr_cad.geometry.deviations import ManufacturingErrors
    >>> d = GearDesign()
    >>> binding(d, ManufacturingErrors(roller_radius_error=-0.002)).binds   # clearance
    False
    >>> b = binding(d, ManufacturingErrors(roller_radius_error=0.02), positions_per_mesh=2)
    >>> b.binds, round(float(b.interference.max() * 1000), 1)              # 20 um oversize
    (True, 43.4)
    """
    lim = pressure_limit_MPa
    if not (isinstance(lim, (int, float)) and math.isfinite(lim) and lim > 0):
        raise SolverError(f"pressure_limit_MPa = {lim!r}: allowed range is (0, inf), e.g. 4000")
    errors = errors or ManufacturingErrors()
    if positions is None:
        x = evaluation_positions(design, errors, positions_per_mesh)
    else:
        x = np.asarray(positions, dtype=float).reshape(-1)
        if x.size == 0 or not np.all(np.isfinite(x)):
            raise SolverError("positions must be a non-empty array of finite output angles (rad)")
    geo = roller_geometry(design, design.tooth_count * x, errors, (), psi_contact_limit)
    a = np.where(geo.loadable, geo.advance, 0.0)
    g = geo.gap
    with np.errstate(divide="ignore", invalid="ignore"):
        t = -g / a
    fwd = np.min(np.where(a > 0, t, np.inf), axis=1)
    rev = np.max(np.where(a < 0, t, -np.inf), axis=1)
    free = (fwd - rev) / design.roller_count
    tight = np.isfinite(fwd) & np.isfinite(rev) & (fwd <= rev)
    lo, hi = np.where(tight, fwd, 0.0), np.where(tight, rev, 0.0)
    up_set, down_set = a > 0, a < 0
    for _ in range(200):  # bisection of max_{a>0} h = max_{a<0} h, to round-off
        mid = 0.5 * (lo + hi)
        h = g + a * mid[:, None]
        up = np.max(np.where(up_set, h, -np.inf), axis=1)
        down = np.max(np.where(down_set, h, -np.inf), axis=1)
        lo, hi = np.where(up < down, mid, lo), np.where(up < down, hi, mid)
        if np.all(hi - lo <= 4e-16 * np.maximum(np.abs(hi), np.abs(lo))):
            break
    tau = 0.5 * (lo + hi)
    h = np.where(geo.loadable & tight[:, None], g + a * tau[:, None], 0.0)
    comp = _Compliance(geo, design, "nonlinear")
    F, _ = comp.invert(h, np.maximum(h, 0.0) / comp.slope0)
    length = design.roller_length
    p = np.maximum(
        np.maximum(
            contact.max_pressure(F, comp.cj, length),
            contact.max_pressure(geo.rho_n * F, comp.cn, length),
        ),
        contact.max_pressure(np.abs(geo.rho_s) * F, comp.cs, length),
    )
    interference = np.where(tight, np.max(h, axis=1), 0.0)
    return Binding(
        output_angles=x,
        free_rotation=free,
        interference=np.maximum(interference, 0.0),
        preload_pressure=np.max(np.where(geo.loadable, p, 0.0), axis=1),
        pressure_limit=float(lim),
    )
