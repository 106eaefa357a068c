"""Many error samples at the same crank angles, solved in one vectorised call.

The Monte Carlo's numpy path: the nominal geometry is built once and each
sample adds only its own error gaps and contact curvatures. The model and
the numerics are those of :mod:`corr_cad.mechanics.row.solver`.
"""

from __future__ import annotations

import math

import numpy as np

from corr_cad.geometry.design import GearDesign
from corr_cad.geometry.deviations import ManufacturingErrors
from corr_cad.mechanics.row.solver import ForceResult, _result
from corr_cad.mechanics.row.solver_geometry import RollerGeometry, _error_gaps, roller_geometry
from corr_cad.mechanics.row.solver_numerics import _Compliance, _solve_positions

__all__ = ["BatchSolver", "solve_forces_batch"]


class BatchSolver:
    """Many error samples at the same crank angles: the nominal geometry is built once.

    Only the gaps and the contact curvatures depend on the errors, so each
    sample costs its own :func:`_error_gaps` and the solve. Results are
    identical, bit for bit, to :func:`roller_geometry` per sample.
    """

    def __init__(
        self,
        design: GearDesign,
        crank_angles: np.ndarray,
        *,
        input_torque: float,
        load_share=0.55,
        psi_contact_limit: float = math.pi,
    ):
        self.design = design
        self.angles = np.asarray(crank_angles, dtype=float).reshape(-1)
        # The contact limit (trimmed tooth tips) only masks the nominal
        # geometry's ``loadable``, which every sample shares.
        self.nominal = roller_geometry(design, self.angles, psi_contact_limit=psi_contact_limit)
        self.target = load_share * float(input_torque)
        R = design.roller_count
        self.theta = np.arange(R) * design.slot_pitch_rad

    def geometry(self, errors_list: list[ManufacturingErrors]) -> RollerGeometry:
        """The stacked (sample-major) geometry of ``errors_list``."""
        g0 = self.nominal
        d = self.design
        n = len(errors_list)
        gaps, k_roller, k_cam = [], [], []
        r, Rj = d.roller_radius, d.cam_radius
        for err in errors_list:
            if err.any:
                gap, dr = _error_gaps(
                    d, err, self.angles, self.theta, g0.psi, g0.s, g0.rho_n, g0.rho_s
                )
            else:
                gap, dr = np.zeros_like(g0.psi), np.zeros_like(g0.psi)
            gaps.append(gap)
            k_roller.append(1.0 / (r + dr))
            k_cam.append(1.0 / (Rj + err.cam_radius_error))
        P = len(self.angles)

        def tile(a):
            return np.tile(a, (n, 1))

        return RollerGeometry(
            psi=tile(g0.psi),
            s=tile(g0.s),
            rho_n=tile(g0.rho_n),
            rho_s=tile(g0.rho_s),
            advance=tile(g0.advance),
            arm=tile(g0.arm),
            gap=np.concatenate(gaps, axis=0),
            k_roller=np.concatenate(k_roller, axis=0),
            k_cam=np.repeat(np.asarray(k_cam, dtype=float), P)[:, None],
            k_gear=tile(g0.k_gear),
            loadable=tile(g0.loadable),
        )

    def solve(self, errors_list: list[ManufacturingErrors]) -> ForceResult:
        """Rows ``k P .. (k+1) P - 1`` of the result belong to ``errors_list[k]``."""
        geo = self.geometry(errors_list)
        comp = _Compliance(geo, self.design, "nonlinear")
        tau, Fj, iterations, _, rel = _solve_positions(geo, comp, self.target)
        return _result(
            self.design,
            geo,
            Fj,
            tau,
            rel,
            iterations,
            np.tile(self.angles, len(errors_list)),
            self.target,
            len(tau),
            False,
            comp=comp,
        )


def solve_forces_batch(
    design: GearDesign,
    input_torque: float,
    crank_angles: np.ndarray,
    errors_list: list[ManufacturingErrors],
    *,
    load_share: float = 0.55,
    psi_contact_limit: float = math.pi,
) -> ForceResult:
    """Solve many error samples at the same crank angles in one vectorised call.

    Returns one :class:`ForceResult` whose rows are sample-major: rows
    ``k P .. (k+1) P - 1`` belong to ``errors_list[k]`` (``P`` angles).
    """
    solver = BatchSolver(
        design,
        crank_angles,
        input_torque=input_torque,
        load_share=load_share,
        psi_contact_limit=psi_contact_limit,
    )
    return solver.solve(errors_list)
