"""Mesh forces on every roller over the cycle (paper Section 3, corrected).

Model
-----
Roller ``i`` sits in slot ``i`` at polar angle ``theta_i = i 2 pi/(z+1)`` of
the (held) frame; the crank is at ``phi`` and ``psi_i = phi - theta_i``. Three
contact forces act on it, each along a direction fixed by the nominal
geometry:

* cam ``F_j`` along ``c = (H - O1)/L`` (through the cam centre),
* gear ``F_n`` along ``-n`` (the working-profile normal),
* slot wall ``F_s`` along the slot normal ``-u_t``.

*Equilibrium* of the roller as vectors gives, with ``W = sqrt(L^2 - e^2
sin^2 psi)`` and ``beta`` the normal's angle from the radial direction:

    F_n = F_j W / (L cos beta),     F_s = -F_j (e sin psi + W tan beta) / L
        = -F_j (z + 1) e sin(psi) / L.

``F_s`` is reported positive when the roller drives the frame forwards.

*Compatibility*: the roller moves rigidly by ``d``; the cam turns by a small
``tau``, advancing its surface at roller ``i`` by ``tau a_i`` along ``c`` with
``a_i = -e s_i sin(psi_i) / L`` (the moment arm of ``c`` about the axis).
Eliminating ``d`` with the gear and slot approaches leaves one monotone
equation per roller,

    delta_j(F_j) + rho_n delta_n(rho_n F_j) + |rho_s| delta_s(|rho_s| F_j)
        = tau a_i + g_i,

(``rho_n = F_n/F_j``, ``rho_s = F_s/F_j``, ``g_i`` the initial interference
from errors), and *moment equilibrium* of one cam (Eq. 8) closes it:
``sum_i a_i F_j,i = share M0``. Rollers whose right-hand side is not positive
are in clearance and carry nothing. Virtual work holds exactly:
``sum_i F_j,i tau a_i = share M0 tau``.

Numerics: per position a safeguarded Newton-bisection on ``tau`` (the moment
is monotone in ``tau``, so the root is bracketed); the per-roller equation is
inverted by Newton from a start to the right of the root, which converges
monotonically because the approach is convex in the force. Everything is
vectorised over positions and rollers, and a full cycle solves only one
position per class of the ``2 pi/(z+1)`` periodicity. A design without
errors takes a closed-form fast path (:mod:`corr_cad.mechanics.row.solver_nominal`);
Monte Carlo (:class:`BatchSolver`) never does.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np

from corr_cad.errors import SolverError
from corr_cad.geometry.design import GearDesign
from corr_cad.geometry.deviations import ManufacturingErrors
from corr_cad.mechanics import contact
from corr_cad.mechanics.row.solver_geometry import (  # noqa: F401  (re-exported: they lived here)
    VARIANTS,
    RollerGeometry,
    _error_gaps,
    _wrap,
    cycle_angles,
    roller_geometry,
)
from corr_cad.mechanics.row.solver_nominal import nominal_geometry, solve_nominal
from corr_cad.mechanics.row.solver_numerics import (  # noqa: F401  (re-exported: they lived here)
    _RTOL,
    _Compliance,
    _Contact,
    _linear_tau,
    _nested,
    _newton,
    _solve_positions,
    make_compliance,
)

__all__ = [
    "VARIANTS",
    "CONTACT_MODELS",
    "ForceResult",
    "RollerGeometry",
    "roller_geometry",
    "solve_forces",
    "cycle_angles",
]

#: ``nonlinear``: the paper's overlap model (Eqs. 9-12, corrected);
#: ``linear``: its small-half-width limit ``delta = 2 F / (pi l E')``;
#: ``palmgren``: Palmgren's steel line contact ``delta = 3.84e-5 Q^0.9 / l^0.8``
#: (:mod:`corr_cad.mechanics.palmgren`, ``[solver] contact_law = "palmgren"``).
CONTACT_MODELS = ("nonlinear", "linear", "palmgren")

#: A roller counts as loaded when its cam force exceeds this share of the
#: largest cam force at the same position. A roller exactly at the edge of
#: the loaded zone (psi = 0 or pi) comes out of the solve with a force of
#: ~1e-13 of the others': that is round-off, not load, and counting it made
#: the loaded-roller count depend on which positions were solved.
LOADED_SHARE = 1e-9


def loaded_mask(F_j: np.ndarray) -> np.ndarray:
    """Rollers carrying load, (P, R) bool, from cam forces (P, R), N."""
    F_j = np.asarray(F_j)
    return F_j > LOADED_SHARE * np.max(F_j, axis=-1, keepdims=True).clip(min=0.0) + 0.0


@dataclass
class ForceResult:
    """Mesh forces over crank positions, in the style of ``scipy.optimize.OptimizeResult``.

    Arrays are (P, R): P crank positions, R = z + 1 rollers (roller 0 is the
    paper's roller 1). Forces in N, pressures in MPa, angles in rad.
    """

    success: bool
    message: str
    iterations: int
    moment_residual: float
    crank_angles: np.ndarray
    psi: np.ndarray
    F_j: np.ndarray
    F_s: np.ndarray
    F_n: np.ndarray
    p_cam: np.ndarray
    p_slot: np.ndarray
    p_gear: np.ndarray
    valid_cam: np.ndarray
    valid_slot: np.ndarray
    valid_gear: np.ndarray
    cam_rotation: np.ndarray
    cam_moment: float
    positions_solved: int
    geometry: RollerGeometry = field(repr=False)
    full_cycle: bool = True

    @property
    def loaded(self) -> np.ndarray:
        """Which rollers carry load, (P, R) bool: see :func:`loaded_mask`."""
        return loaded_mask(self.F_j)

    @property
    def loaded_count(self) -> np.ndarray:
        """Rollers carrying load at each position, (P,)."""
        return np.count_nonzero(self.loaded, axis=1)

    @property
    def small_rotation(self) -> np.ndarray:
        """True where the cam's rotation stays small (< 0.01 rad) as the model assumes.

        A large value means gaps (clearances) that the cam can only close by
        turning far: the static small-displacement picture no longer holds.
        """
        return np.abs(self.cam_rotation) < 0.01

    @property
    def backlash(self) -> np.ndarray:
        """Output backlash at each position, rad (P,): the free rotation at zero torque.

        With the crank held, the frame turns freely until a roller closes its
        clearance: the cam may turn from ``max(-g/a)`` over rollers with
        ``a < 0`` to ``min(-g/a)`` over rollers with ``a > 0`` without load,
        and the output turns ``1/(z + 1)`` of that. Zero where rollers are in
        contact both ways (no clearance). Lost motion (at +-3 % of the rated
        torque, elastic windup included) is a datasheet figure:
        :mod:`corr_cad.mechanics.datasheet`.
        """
        g = self.geometry
        a = np.where(g.loadable, g.advance, 0.0)
        with np.errstate(divide="ignore", invalid="ignore"):
            t = -g.gap / a
        fwd = np.min(np.where(a > 0, t, np.inf), axis=1)
        rev = np.max(np.where(a < 0, t, -np.inf), axis=1)
        play = np.where(np.isfinite(fwd) & np.isfinite(rev), np.maximum(fwd - rev, 0.0), 0.0)
        return play / g.psi.shape[1]

    @property
    def lost_motion(self) -> np.ndarray:
        """Deprecated: the free play at zero torque, now :attr:`backlash`.

        "Lost motion" is the catalogue figure at +-3 % of the rated torque
        (:mod:`corr_cad.mechanics.datasheet`); this name kept its old value
        for scripts written before the datasheet, with a warning.
        """
        import warnings

        warnings.warn(
            "ForceResult.lost_motion is the backlash (free play at zero torque): use "
            "ForceResult.backlash; lost motion at +-3 % of the rated torque is "
            "corr_cad.mechanics.datasheet",
            DeprecationWarning,
            stacklevel=2,
        )
        return self.backlash

    @property
    def valid(self) -> np.ndarray:
        """True where all three contacts of a roller are inside the model's validity."""
        return self.valid_cam & self.valid_slot & self.valid_gear

    @property
    def output_torque(self) -> np.ndarray:
        """Torque the rollers put on the frame, sum s F_s, N*mm (P,)."""
        return np.sum(self.geometry.s * self.F_s, axis=1)

    def summary(self) -> dict:
        """Roller 0 over the solved positions (means over its loaded part)."""
        fj, fn, fs = self.F_j[:, 0], self.F_n[:, 0], self.F_s[:, 0]
        loaded = fj > 0

        def mean(x: np.ndarray) -> float:
            return float(x[loaded].mean()) if np.any(loaded) else 0.0

        p_all = np.maximum(np.maximum(self.p_cam, self.p_slot), self.p_gear)
        return {
            "F_j_mean": mean(fj),
            "F_n_mean": mean(fn),
            "F_s_mean": mean(fs),
            "F_j_peak": float(fj.max()),
            "F_n_peak": float(fn.max()),
            "F_s_peak_to_peak": float(fs.max() - fs.min()),
            "p_max": float(p_all.max()),
            "loaded_rollers_min": int(self.loaded_count.min()),
            "loaded_rollers_max": int(self.loaded_count.max()),
            "positions_beyond_small_rotation": int(np.count_nonzero(~self.small_rotation)),
        }


def solve_forces(
    design: GearDesign,
    input_torque: float,
    crank_angles: np.ndarray | None = None,
    *,
    positions: int = 3600,
    load_share: float = 0.55,
    errors: ManufacturingErrors | None = None,
    variants: tuple[str, ...] = (),
    contact_model: str = "nonlinear",
    psi_contact_limit: float = math.pi,
    rtol: float = _RTOL,
) -> ForceResult:
    """Mesh forces on every roller at each crank angle.

    Parameters
    ----------
    design : GearDesign
    input_torque : float, N*mm
        Crankshaft moment ``M0``; one cam carries ``load_share * M0``.
    crank_angles : (P,) float, rad, optional
        Positions to solve; default ``positions`` evenly over a cycle, using
        the ``2 pi/(z+1)`` periodicity to solve each class once.
    errors : ManufacturingErrors, optional
    variants : tuple of str
        Printed-paper forms to switch on (:data:`VARIANTS`).
    contact_model : {"nonlinear", "linear", "palmgren"}
        The contact law (:data:`CONTACT_MODELS`).
    psi_contact_limit : float, rad
        Rollers with ``|psi|`` beyond it (wrapped, 0 at the tooth space) find
        no gear flank and carry nothing: the trimmed tips of an allowed undercut.
    rtol : float
        Relative tolerance of the moment balance and the contact equations.
        ``success`` requires the moment residual below ``max(rtol, 1e-9)``.

    Examples
    --------
    >>> import numpy as np
    >>> from corr_cad import GearDesign, solve_forces
    >>> res = solve_forces(GearDesign(), 1.1e5, positions=360)   # M0 = 110 N*m
    >>> res.F_j.shape                       # (positions, z + 1 rollers), N
    (360, 26)
    >>> res.success, round(float(res.F_n.max()))   # peak gear force over all rollers, N
    (True, 2882)
    >>> one = solve_forces(GearDesign(), 1.1e5, np.radians([90.0]))
    >>> int(one.loaded_count[0])            # rollers carrying load at 90 deg
    13
    """
    if contact_model not in CONTACT_MODELS:
        raise SolverError(
            f"contact_model = {contact_model!r}: must be one of {', '.join(CONTACT_MODELS)}"
        )
    for name, v in (("input_torque", input_torque), ("load_share", load_share)):
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
            raise SolverError(f"{name} = {v!r}: must be a finite number")
    if not 0.0 < load_share <= 1.0:
        raise SolverError(f"load_share = {load_share!r}: allowed range is (0, 1]")
    errors = errors or ManufacturingErrors()
    R = design.roller_count
    full_cycle = crank_angles is None
    if full_cycle:
        angles = cycle_angles(positions)
        N = len(angles)
        periodic = not errors.per_roller and "eq3_printed" not in variants
        if periodic:
            cls = (np.arange(N) * R) % N
            _, first, inverse = np.unique(cls, return_index=True, return_inverse=True)
            canon = first[inverse]
            shift = ((np.arange(N) - canon) * R // N) % R
            solve_angles = angles[first]
        else:
            solve_angles = angles
    else:
        angles = np.asarray(crank_angles, dtype=float).reshape(-1)
        if angles.size == 0 or not np.all(np.isfinite(angles)):
            raise SolverError("crank_angles must be a non-empty array of finite angles (rad)")
        periodic = False
        solve_angles = angles

    target = load_share * float(input_torque)
    sign = 1.0 if input_torque >= 0 else -1.0
    # Without errors (or with the working-half switch only) the closed-form
    # fast path; a block it declines (zero moment, a position no roller can
    # carry) takes the general path, which answers or raises.
    nominal = (
        not errors.any
        and set(variants) <= {"working_half_only"}
        and target != 0.0
        and contact_model != "palmgren"
    )
    block = max(1, (_NOMINAL_BLOCK_ELEMENTS if nominal else _BLOCK_ELEMENTS) // R)
    stack = _Stack(len(solve_angles))
    for a in range(0, len(solve_angles), block):
        ang = solve_angles[a : a + block]
        piece = None
        if nominal:
            piece = _nominal_result(
                design, ang, target, sign, variants, contact_model, psi_contact_limit, rtol
            )
        if piece is None:
            geo = roller_geometry(design, ang, errors, variants, psi_contact_limit)
            if "working_half_only" in variants:
                geo = replace(geo, loadable=geo.loadable & (sign * geo.arm > 0))
            comp = make_compliance(geo, design, contact_model)
            tau, Fj, iterations, _, rel = _solve_positions(geo, comp, target, rtol)
            piece = _result(design, geo, Fj, tau, rel, iterations, ang, target, 0, comp=comp)
        stack.add(piece)
    out = stack.result()
    out.positions_solved = len(solve_angles)
    out.full_cycle = full_cycle
    if periodic:
        out = _expand(out, angles, inverse.reshape(-1), shift, design.slot_pitch_rad)
    return out


def _expand(out: ForceResult, angles, idx, shift, pitch: float) -> ForceResult:
    """The full cycle from its solved classes: position n is class ``idx[n]``, rollers turned."""
    N, R = len(angles), out.F_j.shape[1]
    turn = (np.arange(R)[None, :] - np.arange(R)[:, None]) % R  # [shift, i] = (i - shift) % R
    flat = turn.take(shift, axis=0)
    flat += (idx * R)[:, None]
    flat = flat.reshape(-1)

    def remap(v, dest=None):
        if isinstance(v, np.ndarray) and v.ndim == 2:
            if dest is None:
                dest = np.empty((N, R), dtype=v.dtype)
            # mode="clip" (the indices are valid): "raise" with out= buffers a copy.
            v.reshape(-1).take(flat, out=dest.reshape(-1), mode="clip")
            return dest
        return v

    fields = {k: v for k, v in out.__dict__.items() if k not in ("geometry", "psi")}
    floats = [k for k, v in fields.items() if isinstance(v, np.ndarray) and v.ndim == 2]
    floats = [k for k in floats if fields[k].dtype == np.float64]
    buf = _one_buffer(len(floats) + 1, (N, R))
    fields = {k: remap(v, buf[floats.index(k)] if k in floats else None) for k, v in fields.items()}
    psi = buf[-1]
    np.subtract(angles[:, None], np.arange(R)[None, :] * pitch, out=psi)
    np.add(psi, 2.0 * np.pi, out=psi, where=psi < 0.0)  # np.mod(psi, 2 pi): psi > -2 pi
    fields.update(
        geometry=_ExpandedGeometry(out.geometry, remap, psi),
        psi=psi,
        crank_angles=angles,
        cam_rotation=out.cam_rotation[idx],
    )
    return ForceResult(**fields)


def _one_buffer(count: int, shape: tuple[int, ...]) -> np.ndarray:
    """``count`` float arrays of ``shape`` in one allocation, (count, *shape).

    numpy backs an allocation of 4 MiB or more with transparent huge pages
    where the kernel allows it (the 2 MiB-aligned part of it): the buffer is
    placed on that part, so a full cycle's outputs cost a few page faults
    instead of one per 4 KiB (measured: 9 fresh (3640, 26) arrays 2.9 ms,
    the same in one buffer 0.6 ms). The fields are views of it.
    """
    size = count * math.prod(shape)
    if size * 8 < _HUGE_PAGE:
        return np.empty((count, *shape))
    pages = -(-size * 8 // _HUGE_PAGE)
    raw = np.empty((pages + 1) * _HUGE_PAGE, dtype=np.uint8)
    start = -raw.ctypes.data % _HUGE_PAGE
    return raw[start : start + size * 8].view(np.float64).reshape(count, *shape)


_HUGE_PAGE = 2 << 20


def _nominal_result(
    design, angles, target, sign, variants, contact_model, psi_contact_limit, rtol
) -> ForceResult | None:
    """The fast path without errors (:mod:`~corr_cad.mechanics.row.solver_nominal`).

    None: take the general one.
    """
    geo = nominal_geometry(design, angles, psi_contact_limit)
    if "working_half_only" in variants:
        geo = replace(geo, loadable=geo.loadable & (sign * geo.arm > 0))
    solved = solve_nominal(design, geo, angles, target, contact_model, rtol)
    if solved is None:
        return None
    tau, Fj, iterations, rel, factors = solved
    return _result(design, geo, Fj, tau, rel, iterations, angles, target, 0, comp=factors)


class _ExpandedGeometry:
    """The :class:`RollerGeometry` of a full cycle, each field expanded on first use.

    A full cycle solves one position per periodicity class; the per-position
    geometry is the class's, with the rollers turned. Expanding every field
    up front costs more than the solve, and most callers read few of them.
    """

    def __init__(self, compact: RollerGeometry, remap, psi: np.ndarray):
        self._compact = compact
        self._remap = remap
        self.psi = psi

    def __getattr__(self, name: str):
        if name.startswith("_"):
            raise AttributeError(name)
        value = self._remap(getattr(self._compact, name))
        setattr(self, name, value)
        return value

    def expanded(self) -> RollerGeometry:
        """A plain :class:`RollerGeometry` with every field expanded."""
        return RollerGeometry(**{k: getattr(self, k) for k in RollerGeometry.__dataclass_fields__})


#: Elements (positions x rollers) solved together: small enough that the
#: solver's temporaries stay in the CPU cache (about 2x faster than one large
#: batch). Each position is solved on its own, so the block size changes no bit.
_BLOCK_ELEMENTS = 6000
#: The same for the fast path without errors, which solves about half the rollers.
_NOMINAL_BLOCK_ELEMENTS = 12000


class _Stack:
    """Block results along positions, written into outputs allocated once.

    Each block's temporaries are freed before the next block runs, so the
    allocator hands the same memory back; the (positions, rollers) float
    outputs share one buffer (:func:`_one_buffer`). ``np.concatenate`` at
    the end kept every block alive and touched fresh memory for each output.
    """

    def __init__(self, total: int):
        self.total = total
        self.n = 0
        self.pieces: list[ForceResult] = []
        self.fields: dict = {}
        self.geo: dict = {}

    def _allocate(self, piece: ForceResult) -> None:
        sources = {"": piece.__dict__, "geo": piece.geometry.__dict__}
        floats = [
            (where, k)
            for where, d in sources.items()
            for k, v in d.items()
            if isinstance(v, np.ndarray) and v.ndim == 2 and v.dtype == np.float64
        ]
        buf = _one_buffer(len(floats), (self.total, piece.F_j.shape[1]))
        for i, (where, k) in enumerate(floats):
            (self.geo if where else self.fields)[k] = buf[i]
        for store, d in ((self.fields, piece.__dict__), (self.geo, piece.geometry.__dict__)):
            for k, v in d.items():
                if k in store:
                    continue
                if isinstance(v, np.ndarray) and v.ndim >= 1:
                    store[k] = np.empty((self.total, *v.shape[1:]), dtype=v.dtype)
                else:
                    store[k] = v

    def add(self, piece: ForceResult) -> None:
        self.pieces.append(piece)
        if len(piece.cam_rotation) == self.total:
            return  # one block: the piece is the result
        if not self.fields:
            self._allocate(piece)
        n, m = self.n, self.n + len(piece.cam_rotation)
        for store, d in ((self.fields, piece.__dict__), (self.geo, piece.geometry.__dict__)):
            for k, v in d.items():
                if isinstance(v, np.ndarray) and v.ndim >= 1:
                    store[k][n:m] = v
        self.n = m
        # Only the scalars are kept: the block's arrays can be freed.
        for k, v in list(piece.__dict__.items()):
            if isinstance(v, (np.ndarray, RollerGeometry)):
                setattr(piece, k, None)

    def result(self) -> ForceResult:
        if len(self.pieces) == 1:
            return self.pieces[0]
        bad = [p for p in self.pieces if not p.success]
        fields = {
            k: v
            for k, v in self.fields.items()
            if k not in ("geometry", "iterations", "moment_residual", "success", "message")
        }
        return ForceResult(
            success=not bad,
            message=bad[0].message if bad else self.pieces[0].message,
            iterations=max(p.iterations for p in self.pieces),
            moment_residual=max(p.moment_residual for p in self.pieces),
            geometry=RollerGeometry(**self.geo),
            **fields,
        )


def _result(
    design,
    geo,
    Fj,
    tau,
    rel,
    iterations,
    angles,
    target,
    solved,
    full_cycle=False,
    rtol=_RTOL,
    comp: _Compliance | None = None,
) -> ForceResult:
    """Forces, pressures and validity from the solved cam forces.

    ``comp``: the compliance the solve used; its half-width factors (the
    same expressions of the same arrays) are reused.
    """
    Fn = geo.rho_n * Fj
    Fs = geo.rho_s * Fj
    length = design.roller_length
    modulus = design.material.contact_modulus
    k1 = geo.k_roller
    if comp is not None:
        cj, cn, cs = comp.cj, comp.cn, comp.cs
    else:
        cj = contact.half_width_sq_per_force(k1, geo.k_cam, length, modulus)
        cn = contact.half_width_sq_per_force(k1, geo.k_gear, length, modulus)
        cs = contact.half_width_sq_per_force(k1, 0.0, length, modulus)
    uj, un, us = cj * Fj, cn * Fn, cs * np.abs(Fs)
    limit = max(rtol, 1e-9)
    success = bool(np.all(rel <= limit))
    worst = float(rel.max()) if rel.size else 0.0
    msg = (
        "converged"
        if success
        else f"moment balance not reached to {limit:g} (worst relative residual {worst:.3g})"
    )
    return ForceResult(
        success=success,
        message=msg,
        iterations=int(iterations),
        moment_residual=worst,
        crank_angles=angles,
        psi=geo.psi,
        F_j=Fj,
        F_s=Fs,
        F_n=Fn,
        p_cam=contact.max_pressure(Fj, cj, length),
        p_slot=contact.max_pressure(np.abs(Fs), cs, length),
        p_gear=contact.max_pressure(Fn, cn, length),
        valid_cam=contact.is_valid(uj, k1, geo.k_cam),
        valid_slot=contact.is_valid(us, k1, 0.0),
        valid_gear=contact.is_valid(un, k1, geo.k_gear),
        cam_rotation=tau,
        cam_moment=target,
        positions_solved=int(solved),
        geometry=geo,
        full_cycle=full_cycle,
    )
