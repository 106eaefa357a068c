"""Output windup under output torque, crank locked: the test bench's view of the drive.

A datasheet figure is read off the *windup* ``theta(T, x)``: the rotation of
the output (the slotted frame) under an output torque ``T``, with the input
(the crank) locked and the ring fixed, at output position ``x``. It is
measured from the zero-load kinematic position of the nominal design, so a
preloaded or loose drive starts away from zero.

Positions
---------
Positions are **output angles** ``x`` over one output revolution, ring
fixed, as a bench records them; ``x = 0`` is the solver's crank angle 0.
The one place where they meet the solver's crank angles (crank relative to
the frame, :func:`~corr_cad.mechanics.row.solver.solve_forces`) is
:func:`crank_angles_of`: with the ring fixed the crank's absolute angle is
``(z + 1) x`` and its angle relative to the frame ``z x``.

Torque bookkeeping
------------------
With the crank locked and the frame turned by ``w``, every contact moves as
it does when the frame is held and the cam turns by ``tau = -(z + 1) w``:
the small motion ``(d phi_abs, d x)`` of the mechanism changes the overlaps
only through its part off the rigid motion ``d phi_abs = (z + 1) d x``, i.e.
through ``d phi_abs - (z + 1) d x`` (``tau`` for the solver, ``-(z + 1) w`` on
the bench). The two states differ by a rigid motion of ``|w|`` of output,
which moves the position by that much (second order in the windup). Virtual
work then gives the output torque: ``T dw = M dtau`` for the crank moment
``M``, so ``T = -(z + 1) M``. The solver's one-cam model carries
``load_share`` of the drive's moment, so an output torque ``T`` is solved as
the cam moment ``-load_share T / (z + 1)`` and

    theta(T, x) = -tau / (z + 1).

A series compliance (bearings, crank, frame, housing), given as a rigidity
``K`` in N*m/arcmin, adds ``T / K``.

Zero torque
-----------
With clearances, ``theta`` jumps at ``T = 0``: ``theta(0+)`` and ``theta(0-)``
are the ends of the free rotation, found from the gaps alone (no force
solve, :meth:`Windup.free_ends`): the frame turns freely until a roller
touches cam, gear and slot wall. ``-0.0`` asks for ``theta(0-)``, ``+0.0``
for ``theta(0+)``. A preloaded drive has no free rotation: both ends are
the one equilibrium at zero torque.

Units: torque N*mm, angles rad (the helpers convert to N*m, arcmin, arcsec).
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from corr_cad.errors import SolverError
from corr_cad.geometry.design import GearDesign
from corr_cad.geometry.deviations import ManufacturingErrors
from corr_cad.mechanics.row.solver import CONTACT_MODELS, ForceResult, _result
from corr_cad.mechanics.row.solver_geometry import VARIANTS, roller_geometry
from corr_cad.mechanics.row.solver_numerics import _RTOL, _solve_positions, make_compliance

__all__ = [
    "ARCMIN_PER_RAD",
    "ARCSEC_PER_RAD",
    "NMM_PER_NM",
    "crank_angles_of",
    "output_angles_of",
    "mesh_period_rad",
    "result_period_rad",
    "revolution_classes",
    "series_rigidity_Nmm_per_rad",
    "Windup",
    "WindupCurve",
]

#: 1 rad in arcmin and arcsec (1 arcmin = pi/10800 rad).
ARCMIN_PER_RAD = 10800.0 / math.pi
ARCSEC_PER_RAD = 648000.0 / math.pi
#: Torque: N*mm per N*m.
NMM_PER_NM = 1000.0

#: Positions solved together (positions x rollers), as in the force solver.
_BLOCK_ELEMENTS = 6000


def crank_angles_of(output_angles: np.ndarray, design: GearDesign) -> np.ndarray:
    """Solver crank angles (crank relative to the frame) of output angles, rad.

    The one mapping between the bench's positions and the solver's: with the
    ring fixed, the frame (output) at ``x`` and the crank's absolute angle
    ``(z + 1) x``, the crank relative to the frame is at ``z x``.
    """
    return design.tooth_count * np.asarray(output_angles, dtype=float)


def output_angles_of(crank_angles: np.ndarray, design: GearDesign) -> np.ndarray:
    """Output angles of solver crank angles (relative to the frame), rad: ``phi / z``."""
    return np.asarray(crank_angles, dtype=float) / design.tooth_count


def mesh_period_rad(design: GearDesign) -> float:
    """One mesh period in output angle, rad: ``2 pi / (z (z + 1))``.

    The next roller takes the place of the one before (the solver's
    ``2 pi / (z + 1)`` of crank angle relative to the frame).
    """
    return 2.0 * math.pi / (design.tooth_count * design.roller_count)


def result_period_rad(
    design: GearDesign, errors: ManufacturingErrors | None = None, variants: tuple[str, ...] = ()
) -> float:
    """Output angle after which the windup repeats exactly, rad.

    One mesh period when all rollers and slots are alike; one tooth pitch
    ``2 pi / z`` when they differ (every roller meets every tooth alike
    while the ring's teeth are alike); a full output revolution once the
    ring has its own profile deviation (harmonics or a measured profile).
    The printed Eq. (3) (``eq3_printed``) reads the slot angle, so it also
    repeats only after a tooth pitch.
    """
    errors = errors or ManufacturingErrors()
    if not errors.tooth_periodic_profile:
        return 2.0 * math.pi
    if errors.per_roller or "eq3_printed" in variants:
        return 2.0 * math.pi / design.tooth_count
    return mesh_period_rad(design)


def revolution_classes(
    design: GearDesign,
    per_turn: int,
    errors: ManufacturingErrors | None = None,
    variants: tuple[str, ...] = (),
) -> tuple[np.ndarray, np.ndarray]:
    """Positions over one output revolution, and which of them need a solve.

    ``per_turn`` positions per crank (input) turn, ``N = per_turn (z + 1)``
    over one output revolution at ``x_k = 2 pi k / N``. A solve at ``x_k``
    equals the one at any position the periodicity (:func:`result_period_rad`)
    maps it to; in integer arithmetic the solver's crank angle ``z x_k`` is
    ``z k`` in units of ``2 pi / N``, reduced modulo the period.

    Returns
    -------
    output_angles : (M,) float, rad
        Positions to solve (each class once, as an output angle).
    index : (N,) int
        ``index[k]`` is the solved position that gives ``x_k``.
    """
    if isinstance(per_turn, bool) or not isinstance(per_turn, (int, np.integer)) or per_turn < 1:
        raise SolverError(f"per_turn = {per_turn!r}: must be an integer >= 1")
    z = design.tooth_count
    N = int(per_turn) * design.roller_count
    k = np.arange(N, dtype=np.int64)
    period = result_period_rad(design, errors, variants)
    if period == 2.0 * math.pi:
        return 2.0 * math.pi * k / N, k
    modulus = int(per_turn) if period == mesh_period_rad(design) else N
    m = (z * k) % modulus
    classes, index = np.unique(m, return_inverse=True)
    # Crank angle 2 pi m / N relative to the frame, i.e. output angle 2 pi m / (z N).
    return 2.0 * math.pi * classes / (z * N), index.reshape(-1)


def series_rigidity_Nmm_per_rad(rigidity_Nm_per_arcmin: float | None) -> float:
    """A rigidity in N*m/arcmin as N*mm/rad (``inf`` for none: no series compliance)."""
    if rigidity_Nm_per_arcmin is None:
        return math.inf
    return float(rigidity_Nm_per_arcmin) * NMM_PER_NM * ARCMIN_PER_RAD


class WindupCurve:
    """What a windup reads off its free ends and its loaded solve, shared by the paper's row
    (:class:`Windup`) and the drive (:class:`~corr_cad.mechanics.drive.drive_windup.DriveWindup`).

    A subclass gives :meth:`free_ends`, ``_loaded_theta(T)`` (the contact windup at a
    finite nonzero output torque, (P,) rad) and ``series_rigidity_Nm_per_arcmin``.
    """

    series_rigidity_Nm_per_arcmin: float | None

    def _place(self, design: GearDesign, output_angles: np.ndarray) -> None:
        """Set ``design``, the output angles (P,) rad, checked finite and not empty, and
        their crank angles (:func:`crank_angles_of`)."""
        x = np.asarray(output_angles, dtype=float).reshape(-1)
        if x.size == 0 or not np.all(np.isfinite(x)):
            raise SolverError("output_angles must be a non-empty array of finite angles (rad)")
        self.design = design
        self.output_angles = x
        self.crank_angles = crank_angles_of(x, design)

    def free_ends(self) -> tuple[np.ndarray, np.ndarray]:
        """``theta(0-)`` and ``theta(0+)``, rad (P,) each."""
        raise NotImplementedError

    def _loaded_theta(self, output_torque: float) -> np.ndarray:
        raise NotImplementedError

    def backlash(self) -> np.ndarray:
        """``theta(0+) - theta(0-)``, rad (P,): the free rotation."""
        lo, hi = self.free_ends()
        return hi - lo

    def contact_theta(self, output_torque: float) -> np.ndarray:
        """Windup of the contacts (with the drive's bearings) alone at an output torque
        (N*mm), rad (P,).

        ``+0.0`` and ``-0.0`` give the ends of the free rotation (:meth:`free_ends`).
        """
        T = float(output_torque)
        if not math.isfinite(T):
            raise SolverError(f"output torque {T!r}: must be a finite number (N*mm)")
        if T == 0.0:
            lo, hi = self.free_ends()
            return lo if math.copysign(1.0, T) < 0 else hi
        return self._loaded_theta(T)

    def theta(self, output_torque: float) -> np.ndarray:
        """Windup at an output torque (N*mm), contacts plus the series compliance, rad (P,)."""
        T = float(output_torque)
        return self.contact_theta(T) + T / series_rigidity_Nmm_per_rad(
            self.series_rigidity_Nm_per_arcmin
        )

    def curve(self, output_torques: np.ndarray) -> np.ndarray:
        """:meth:`theta` at each torque (L,), N*mm: (L, P) rad."""
        return np.stack([self.theta(T) for T in np.asarray(output_torques, dtype=float)])

    @staticmethod
    def _settled(rel: np.ndarray, rtol: float, what: str) -> None:
        """A :class:`SolverError` (``what`` not reached) where a relative residual of ``rel``
        is above ``rtol`` (at least 1e-9)."""
        limit = max(rtol, 1e-9)
        if not np.all(rel <= limit):
            raise SolverError(
                f"{what} not reached to {limit:g} (worst relative residual {float(rel.max()):.3g})"
            )

    @staticmethod
    def _forces_torque(output_torque: float) -> float:
        """``output_torque`` as a float; a :class:`SolverError` unless finite and nonzero."""
        T = float(output_torque)
        if T == 0.0 or not math.isfinite(T):
            raise SolverError(f"forces at output torque {T!r}: give a finite, nonzero torque")
        return T


class Windup(WindupCurve):
    """The windup ``theta(T, x)`` at output angles ``x`` (P,), vectorised over positions.

    The roller geometry and contact compliance are built once; each torque
    is then one force solve at every position (:meth:`theta`), and the ends
    of the free rotation need none (:meth:`free_ends`).

    Parameters
    ----------
    design : GearDesign
    output_angles : (P,) float, rad
        Output positions, ring fixed (see the module docstring).
    errors : ManufacturingErrors, optional
        The full error model of the force solver.
    load_share : float
        Share of the drive's moment on the modelled cam (``[solver] load_share``).
    contact_model : {"nonlinear", "linear"}
    variants : tuple of str
        Printed-paper forms (:data:`~corr_cad.mechanics.row.solver.VARIANTS`).
    psi_contact_limit : float, rad
        Trimmed tooth tips of an allowed undercut carry nothing.
    series_rigidity_Nm_per_arcmin : float, optional
        Rigidity of what is in series with the contacts (bearings, crank,
        frame, housing); adds ``T / K`` to the windup. Default: none.

    Examples
    --------
    >>> import numpy as np
    >>> from corr_cad import GearDesign
    >>> from corr_cad.mechanics.row.windup import ARCMIN_PER_RAD, Windup
    >>> w = Windup(GearDesign(), np.radians([0.0, 0.1]))
    >>> theta = w.theta(2.86e6)                    # T_R = 2860 N*m, rad (P,)
    >>> np.round(theta * ARCMIN_PER_RAD, 4)        # arcmin
    array([0.121, 0.121])
    >>> bool(np.all(w.backlash() == 0.0))          # the nominal drive has no free play
    True
    """

    def __init__(
        self,
        design: GearDesign,
        output_angles: np.ndarray,
        *,
        errors: ManufacturingErrors | None = None,
        load_share: float = 0.55,
        contact_model: str = "nonlinear",
        variants: tuple[str, ...] = (),
        psi_contact_limit: float = math.pi,
        series_rigidity_Nm_per_arcmin: float | None = None,
        rtol: float = _RTOL,
    ):
        if contact_model not in CONTACT_MODELS:
            raise SolverError(
                f"contact_model = {contact_model!r}: must be one of {', '.join(CONTACT_MODELS)}"
            )
        bad = [v for v in variants if v not in VARIANTS]
        if bad:
            raise SolverError(f"variant {bad[0]!r} is unknown; valid: {', '.join(VARIANTS)}")
        if not (isinstance(load_share, (int, float)) and 0.0 < load_share <= 1.0):
            raise SolverError(f"load_share = {load_share!r}: allowed range is (0, 1]")
        k = series_rigidity_Nm_per_arcmin
        if k is not None and not (isinstance(k, (int, float)) and math.isfinite(k) and k > 0):
            raise SolverError(
                f"series_rigidity_Nm_per_arcmin = {k!r}: allowed range is (0, inf), e.g. 1000"
            )
        self._place(design, output_angles)
        self.errors = errors or ManufacturingErrors()
        self.load_share = float(load_share)
        self.contact_model = contact_model
        self.variants = tuple(variants)
        self.psi_contact_limit = psi_contact_limit
        self.series_rigidity_Nm_per_arcmin = k
        self.rtol = rtol
        self._ratio = float(design.roller_count)  # z + 1
        self._blocks: dict[int, list] = {}

    # ------------------------------------------------------------------ geometry

    def _geometry(self, sign: int) -> list:
        """Per block: (slice, geometry, compliance) for torques of ``sign``."""
        key = sign if "working_half_only" in self.variants else 0
        if key not in self._blocks:
            R = self.design.roller_count
            step = max(1, _BLOCK_ELEMENTS // R)
            out = []
            for a in range(0, len(self.crank_angles), step):
                sl = slice(a, a + step)
                geo = roller_geometry(
                    self.design,
                    self.crank_angles[sl],
                    self.errors,
                    self.variants,
                    self.psi_contact_limit,
                )
                if key:
                    # Solver sign: the cam moment is -T, so -sign loads the working half.
                    geo = replace(geo, loadable=geo.loadable & (-key * geo.arm > 0))
                out.append((sl, geo, make_compliance(geo, self.design, self.contact_model)))
            self._blocks[key] = out
        return self._blocks[key]

    def cam_moment(self, output_torque: float) -> float:
        """The modelled cam's moment (solver sign) for an output torque, N*mm."""
        return -self.load_share * float(output_torque) / self._ratio

    # ------------------------------------------------------------------ windup

    def free_ends(self) -> tuple[np.ndarray, np.ndarray]:
        """``theta(0-)`` and ``theta(0+)`` of the contacts, rad (P,) each, from the gaps alone.

        Each roller with a cam advance ``a != 0`` closes its chain gap ``g``
        (interference positive) at the cam rotation ``-g / a``. With the
        crank locked, the frame turns freely between the rollers closing
        first on either side. Where no free rotation is left (a preload) both
        ends are the equilibrium at zero torque (one force solve there).
        """
        fwd = np.empty(len(self.crank_angles))
        rev = np.empty_like(fwd)
        for sl, geo, _ in self._geometry(0):
            a = np.where(geo.loadable, geo.advance, 0.0)
            with np.errstate(divide="ignore", invalid="ignore"):
                t = -geo.gap / a
            fwd[sl] = np.min(np.where(a > 0, t, np.inf), axis=1)
            rev[sl] = np.max(np.where(a < 0, t, -np.inf), axis=1)
        if not (np.all(np.isfinite(fwd)) and np.all(np.isfinite(rev))):
            raise SolverError(
                "no roller resists the output torque in one direction at "
                f"{int(np.count_nonzero(~(np.isfinite(fwd) & np.isfinite(rev))))} positions"
            )
        # T > 0 turns the cam backwards (tau < 0) until the first roller with a < 0 closes.
        lo, hi = -fwd / self._ratio, -rev / self._ratio
        tight = fwd <= rev
        if np.any(tight):
            zero = self._solve(0.0, 0)[0]
            lo = np.where(tight, zero, lo)
            hi = np.where(tight, zero, hi)
        return lo, hi

    def slack(self) -> np.ndarray:
        """Positions where no contact carries a force at zero torque, bool (P,): free play."""
        return self.backlash() > 0.0

    def at(self, mask: np.ndarray) -> Windup:
        """The same row at the positions ``mask`` (bool (P,)) selects."""
        return Windup(
            self.design,
            self.output_angles[np.asarray(mask, dtype=bool)],
            errors=self.errors,
            load_share=self.load_share,
            contact_model=self.contact_model,
            variants=self.variants,
            psi_contact_limit=self.psi_contact_limit,
            series_rigidity_Nm_per_arcmin=self.series_rigidity_Nm_per_arcmin,
            rtol=self.rtol,
        )

    def _solve(self, output_torque: float, sign: int):
        """Contact windup (P,) rad and the force results of each block."""
        target = self.cam_moment(output_torque)
        theta = np.empty(len(self.crank_angles))
        pieces = []
        for sl, geo, comp in self._geometry(sign):
            tau, Fj, iterations, _, rel = _solve_positions(geo, comp, target, self.rtol)
            what = f"windup at output torque {output_torque:g} N*mm: moment balance"
            self._settled(rel, self.rtol, what)
            theta[sl] = -tau / self._ratio
            pieces.append((sl, geo, comp, Fj, tau, rel, iterations, target))
        return theta, pieces

    def _loaded_theta(self, output_torque: float) -> np.ndarray:
        T = float(output_torque)
        return self._solve(T, 1 if T > 0 else -1)[0]

    def forces(self, output_torque: float) -> ForceResult:
        """The force result behind :meth:`contact_theta` (nonzero torque), one row per position.

        Its ``cam_rotation`` is the solver's ``tau``; the output windup is
        ``-tau / (z + 1)``; ``cam_moment`` is the modelled cam's moment.
        """
        T = self._forces_torque(output_torque)
        _, pieces = self._solve(T, 1 if T > 0 else -1)
        parts = [
            _result(self.design, geo, Fj, tau, rel, it, self.crank_angles[sl], target, len(tau))
            for sl, geo, comp, Fj, tau, rel, it, target in pieces
        ]
        if len(parts) == 1:
            return parts[0]
        return _concatenate(parts)

    def peak_pressure(self, output_torque: float) -> np.ndarray:
        """Largest Hertz pressure of any contact and roller at each position, MPa (P,)."""
        res = self.forces(output_torque)
        return np.max(np.maximum(np.maximum(res.p_cam, res.p_slot), res.p_gear), axis=1)


def _concatenate(parts: list[ForceResult]) -> ForceResult:
    """Force results of consecutive position blocks as one."""
    first = parts[0]
    fields = {}
    for name in first.__dataclass_fields__:
        v = getattr(first, name)
        if isinstance(v, np.ndarray):
            fields[name] = np.concatenate([getattr(p, name) for p in parts])
        else:
            fields[name] = v
    geo = first.geometry
    fields["geometry"] = type(geo)(
        **{
            k: (
                np.concatenate([getattr(p.geometry, k) for p in parts])
                if np.ndim(getattr(geo, k)) == 2
                else getattr(geo, k)
            )
            for k in geo.__dataclass_fields__
        }
    )
    fields["success"] = all(p.success for p in parts)
    fields["iterations"] = max(p.iterations for p in parts)
    fields["moment_residual"] = max(p.moment_residual for p in parts)
    fields["positions_solved"] = sum(p.positions_solved for p in parts)
    return ForceResult(**fields)
