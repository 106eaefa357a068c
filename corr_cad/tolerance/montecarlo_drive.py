"""Monte Carlo of the two-row drive (``[solver] model = "drive"``): each row drawn on its own.

The draws of :func:`~corr_cad.tolerance.montecarlo.draw_samples` stay row
A's (and the frame's: slot angles, slot clearance; and cam B's phase against
cam A): seeded as before, so the same seed gives row A the same errors
whatever row B draws. Row B's own tolerances (cam radius, eccentricity,
roller radii) are drawn from a second generator seeded with ``[seed, 1]``.
Each sample is then solved by :class:`~corr_cad.mechanics.drive.drive.DriveSolver`
at the Monte Carlo's crank positions, and keeps the four force metrics over
both rows (the drive's free rotation for the backlash).

Samples are solved in blocks: a block's geometries are stacked sample-major
along the positions (as :mod:`corr_cad.mechanics.row.batch` does for one row) and
solved by one :class:`DriveSolver`. Every position's solve (the rigid
Newton-bisection, the bearing Newton and its line search, the free interval)
is its own, so a sample's metrics are those of solving it alone
(``tests/test_montecarlo_drive.py``); the block only shares numpy's overhead.
With the eccentrics fixed and the bodies rigid (the force pass,
:class:`~corr_cad.mechanics.drive.drive_rigid.ForcePassDriveSolver`) a block's solver
is made from what every block shares, built once a run (:func:`_block_nominal`: the
nominal rows joined and tiled, their directions, the contact law's factors of their
curvature ratios, the bearing Newton's geometry but the gaps), and each sample's
gaps and curvatures (:func:`_stacked_gaps`, one pass over the block); its metrics
are read off the forces in a few passes (:func:`_lean_metrics`). Both give the bits
the constructor and the full result give (``tests/test_drive_rigid.py``).

The load path beyond the contacts (:func:`chain_solver`): ``drive``'s ``crank``
(the crankshaft on its support bearings) and ``bodies`` (the elastic ring, frame
and cams' influence tables) are the nominal drive's objects, handed to each
chunk as built once per design; every sample is solved on them. The bodies'
tables are the nominal design's (a sample's errors move its gaps by micrometres,
not the bodies' shape: a small-perturbation choice, ``docs/physics.md``), and a
sample's influence matrices are those of the nominal positions (its geometry
differs in the gaps and curvatures only), made once a block and repeated for
each sample (``tests/test_elastic_tolerance.py``).
"""

from __future__ import annotations

import numpy as np

from corr_cad.mechanics.drive.drive import row_errors
from corr_cad.mechanics.drive.drive_numerics import roller_directions
from corr_cad.mechanics.row.solver import loaded_mask
from corr_cad.mechanics.row.solver_geometry import RollerGeometry, _error_gaps, roller_geometry
from corr_cad.tolerance.checks import ARCMIN_PER_RAD

__all__ = [
    "ROW_B_KINDS",
    "ROW_B_STREAM",
    "row_b_tolerances",
    "chain_solver",
    "drive_chunk",
    "drive_metrics",
    "stacked_geometry",
]

#: Tolerance kinds each row has of its own (drawn again for row B).
ROW_B_KINDS = ("cam_radius", "eccentricity", "roller_radius")
#: Row B's generator: ``numpy.random.default_rng([seed, ROW_B_STREAM])``.
ROW_B_STREAM = 1
#: Positions (samples x crank angles) solved together: large enough to spread numpy's
#: per-call overhead, small enough to stay in the CPU cache.
BLOCK_POSITIONS = 1000


def row_b_tolerances(tolerances: dict) -> dict:
    """The tolerances row B draws on its own."""
    return {k: v for k, v in tolerances.items() if k in ROW_B_KINDS}


def _width(fwd: np.ndarray, rev: np.ndarray) -> np.ndarray:
    """The free interval's width, 0 where none is left (``free_interval(solve=False)``
    leaves a preloaded position's ends as found)."""
    return np.where(fwd > rev, fwd - rev, 0.0)


def drive_metrics(res, interval: tuple[np.ndarray, np.ndarray], ratio: float) -> dict:
    """The four force metrics of one drive solution, over both rows (floats)."""
    p = [np.maximum(np.maximum(r.p_cam, r.p_slot), r.p_gear) for r in res.rows]
    loaded = [loaded_mask(r.F_j).sum(axis=1) for r in res.rows]
    rev, fwd = interval
    return {
        "peak_gear_force": float(res.F_n.max()),
        "peak_pressure": float(max(x.max() for x in p)),
        "min_loaded_rollers": float(min(x.min() for x in loaded)),
        "backlash_arcmin": float(np.max(_width(fwd, rev)) / ratio * ARCMIN_PER_RAD),
    }


#: The last nominal rows built (:func:`_nominal_rows`): ``[(key, (rows, directions))]``,
#: one tuple read and replaced whole (a thread never sees one key with another's rows).
_NOMINAL: list = [None]


def _nominal_rows(design, phi: np.ndarray, psi_limit: float) -> tuple[list, np.ndarray]:
    """Rows A and B of the nominal design at crank angles ``phi`` (row B at ``phi + pi``)
    and their rollers' directions (P, 2R, 2), read-only; the same for every block of a
    chunk and every chunk of a run, so built once (the last ones kept)."""
    key = (design, phi.tobytes(), float(psi_limit))
    entry = _NOMINAL[0]
    if entry is None or entry[0] != key:
        rows = [roller_geometry(design, x, None, (), psi_limit) for x in (phi, phi + np.pi)]
        n = np.concatenate([roller_directions(design, g) for g in rows], axis=1)
        for v in [n, *(v for g in rows for v in vars(g).values())]:
            if isinstance(v, np.ndarray):
                v.setflags(write=False)
        entry = (key, (rows, n))
        _NOMINAL[0] = entry
    return entry[1]


def stacked_geometry(
    design, angles: np.ndarray, pairs: list, psi_limit: float
) -> tuple[RollerGeometry, RollerGeometry]:
    """Rows A and B of the samples ``pairs`` (``(errors, errors_b)`` each), stacked
    sample-major: positions ``k P .. (k+1) P - 1`` are sample ``k``'s (``P`` angles).

    Each row is :func:`~corr_cad.mechanics.drive.drive.drive_geometry`'s, bit for bit: the
    nominal geometry (row B's at ``phi + pi``) is built once and each sample adds its
    own gaps and curvatures (as :class:`~corr_cad.mechanics.row.batch.BatchSolver` does
    for one row); a row's cam curvature becomes a (n P, 1) column.
    """
    phi = np.asarray(angles, dtype=float).reshape(-1)
    phis = (phi, phi + np.pi)
    nominal = _nominal_rows(design, phi, psi_limit)[0]
    theta = np.arange(design.roller_count) * design.slot_pitch_rad
    r, Rj = design.roller_radius, design.cam_radius
    parts: tuple[dict, dict] = (
        {"gap": [], "k_roller": [], "k_cam": []},
        {"gap": [], "k_roller": [], "k_cam": []},
    )
    for ea, eb in pairs:
        for c, err in enumerate(row_errors(ea, eb)):
            g0 = nominal[c]
            if err.any:
                gap, dr = _error_gaps(design, err, phis[c], theta, g0.psi, g0.s, g0.rho_n, g0.rho_s)
            else:
                gap, dr = np.zeros_like(g0.psi), np.zeros_like(g0.psi)
            parts[c]["gap"].append(gap)
            parts[c]["k_roller"].append(1.0 / (r + dr))
            parts[c]["k_cam"].append(1.0 / (Rj + err.cam_radius_error))
    n, P = len(pairs), len(phi)

    def stack(g0, part):
        kw = {
            k: np.tile(getattr(g0, k), (n, 1))
            for k in RollerGeometry.__dataclass_fields__
            if k not in part
        }
        kw["gap"] = np.concatenate(part["gap"], axis=0)
        kw["k_roller"] = np.concatenate(part["k_roller"], axis=0)
        kw["k_cam"] = np.repeat(np.asarray(part["k_cam"], dtype=float), P)[:, None]
        return RollerGeometry(**kw)

    return stack(nominal[0], parts[0]), stack(nominal[1], parts[1])


#: The nominal rows joined and tiled for blocks of ``n`` samples (:func:`_block_nominal`):
#: ``[(key, {n: parts})]``, read and replaced whole (as :data:`_NOMINAL`).
_TILED: list = [None]
#: The joined geometry's fields a sample's errors change (the others are the nominal's).
_OWN = ("gap", "k_roller", "k_cam")


def _block_nominal(design, phi: np.ndarray, psi_limit: float, n: int, model: str) -> dict:
    """What every block of ``n`` samples shares: the nominal rows joined
    (``drive_numerics.joined``) and tiled ``n`` times (the fields no error changes), the
    rollers' directions, each row's contiguous directions, and under Palmgren's law the
    compliance's factors ``K``, ``slope0`` of those rows (they depend on the nominal
    curvature ratios alone) with each row's ``K``; built once a run (the same bits as
    the stacked rows' own: copies, and elementwise arithmetic on the same values)."""
    from corr_cad.mechanics.drive.drive_numerics import joined
    from corr_cad.mechanics.row.solver_numerics import make_compliance

    key = (design, phi.tobytes(), float(psi_limit), model)
    entry = _TILED[0]
    if entry is None or entry[0] != key:
        entry = (key, {})
    cache = entry[1]
    if n not in cache:
        rows, directions = _nominal_rows(design, phi, psi_limit)
        nominal = joined(*rows)
        fields = {
            k: np.tile(getattr(nominal, k), (n, 1))
            for k in RollerGeometry.__dataclass_fields__
            if k not in _OWN
        }
        d = np.tile(directions, (n, 1, 1))
        R = design.roller_count
        parts = {"fields": fields, "directions": d}
        loadable = fields["loadable"]
        template = np.empty((5, *d.shape[:2]))  # the bearing Newton's geometry but the gaps
        template[0] = np.where(loadable, fields["advance"], 0.0)
        template[1] = np.where(loadable, fields["arm"], 0.0)
        template[2] = 0.0
        template[3], template[4] = d[..., 0], d[..., 1]
        parts["template"] = template
        K = None
        if model == "palmgren":
            tiled = RollerGeometry(
                **fields, **{k: np.tile(getattr(nominal, k), (n, 1)) for k in _OWN}
            )
            comp = make_compliance(tiled, design, model)
            parts["K"], parts["slope0"] = comp.K, comp.slope0
            K = np.broadcast_to(comp.K, d.shape[:2])
        parts["rows"] = [
            (
                np.ascontiguousarray(d[:, sl]),
                None if K is None else np.ascontiguousarray(K[:, sl], dtype=float),
            )
            for sl in (slice(0, R), slice(R, 2 * R))
        ]
        cache = {**cache, n: parts}  # a new dict: a reader holds the old one whole
        entry = (key, cache)
        _TILED[0] = entry
    return cache[n]


def _stacked_gaps(design, errs: list, g0: RollerGeometry) -> tuple[np.ndarray, np.ndarray]:
    """``solver_geometry._error_gaps`` of one row of each sample (``errs``, none with a
    profile deviation, each with its slots' fit: ``row_errors``'), (n, P, R) each, in one
    pass: the same elementwise arithmetic on the same values (each sample's scalars as
    Python computes them there), each sample's branch taken by selection; zeros for a
    sample without errors (as :func:`stacked_geometry` gives it)."""
    from corr_cad.geometry import kinematics as kin

    R, e, L, z = design.roller_count, design.eccentricity, design.link_length, design.tooth_count
    psi, s, rho_n, rho_s = g0.psi, g0.s, g0.rho_n, g0.rho_s

    def col(values):  # one value a sample, (n, 1, 1)
        return np.asarray(values, dtype=float)[:, None, None]

    dr = np.stack([err.roller_errors(R) for err in errs])[:, None, :] + 0.0 * psi
    delta = np.stack([err.slot_errors(R) for err in errs])[:, None, :]
    g_j = col([err.cam_radius_error for err in errs]) + dr
    slots = np.array([bool(np.any(d)) for d in delta])
    bent = np.array([bool(err.eccentricity_error or err.cam_phase_error) for err in errs]) | slots
    if bent.any():
        e_act = [e + err.eccentricity_error for err in errs]
        s_slot = s
        if slots.any():
            s_slot = np.where(slots[:, None, None], kin.centre_distance(psi + z * delta, e, L), s)
        ang = psi - delta + col([err.cam_phase_error for err in errs])
        root = np.sqrt(
            s_slot**2 + col([x**2 for x in e_act]) - 2.0 * s_slot * col(e_act) * np.cos(ang)
        )
        g_j = np.where(bent[:, None, None], g_j + L - root, g_j)
    clearance_slot = col([0.5 * err.slot_clearance for err in errs]) - dr
    gap = g_j + rho_n * dr - np.abs(rho_s) * clearance_slot
    some = np.array([err.any for err in errs])[:, None, None]
    return np.where(some, gap, 0.0), np.where(some, dr, 0.0)


def _block_solver(design, angles: np.ndarray, pairs: list, psi_limit: float, drive):
    """The force pass's solver of the samples ``pairs`` (eccentrics fixed, bodies rigid):
    :class:`~corr_cad.mechanics.drive.drive_rigid.ForcePassDriveSolver` on the joined
    geometry of :func:`stacked_geometry` (the same bits), made from the shared nominal
    parts (:func:`_block_nominal`) and each sample's gaps and curvatures."""
    from corr_cad.mechanics import contact
    from corr_cad.mechanics.drive.drive_rigid import ForcePassDriveSolver
    from corr_cad.mechanics.palmgren import PalmgrenCompliance
    from corr_cad.mechanics.row.solver_numerics import make_compliance

    model = drive.get("contact_model", "nonlinear")
    n, P, R = len(pairs), len(angles), design.roller_count
    shared = _block_nominal(design, angles, psi_limit, n, model)
    nominal = _nominal_rows(design, angles, psi_limit)[0]
    phis = (angles, angles + np.pi)
    theta = np.arange(R) * design.slot_pitch_rad
    r, Rj = design.roller_radius, design.cam_radius
    gap, k_roller, k_cam = (np.empty((n * P, 2 * R)) for _ in range(3))
    errors = [row_errors(ea, eb) for ea, eb in pairs]
    for c in range(2):
        g0, cols = nominal[c], slice(c * R, (c + 1) * R)
        errs = [x[c] for x in errors]
        if all(err.profile_deviation is None for err in errs):
            gc, dr = _stacked_gaps(design, errs, g0)
            gap[:, cols] = gc.reshape(n * P, R)
            k_roller[:, cols] = (1.0 / (r + dr)).reshape(n * P, R)
        else:  # a profile deviation is a function of each sample's own: one at a time
            for k, err in enumerate(errs):
                rows = slice(k * P, (k + 1) * P)
                if err.any:
                    gc, dr = _error_gaps(
                        design, err, phis[c], theta, g0.psi, g0.s, g0.rho_n, g0.rho_s
                    )
                else:
                    gc, dr = np.zeros_like(g0.psi), np.zeros_like(g0.psi)
                gap[rows, cols] = gc
                k_roller[rows, cols] = 1.0 / (r + dr)
        k_cam[:, cols] = np.repeat([1.0 / (Rj + err.cam_radius_error) for err in errs], P)[:, None]
    geo = RollerGeometry(**shared["fields"], gap=gap, k_roller=k_roller, k_cam=k_cam)
    if model == "palmgren":
        comp = PalmgrenCompliance.__new__(PalmgrenCompliance)
        comp.K, comp.slope0 = shared["K"], shared["slope0"]
        length, modulus = design.roller_length, design.material.contact_modulus
        comp.cj = contact.half_width_sq_per_force(k_roller, k_cam, length, modulus)
        comp.cn = contact.half_width_sq_per_force(k_roller, geo.k_gear, length, modulus)
        comp.cs = contact.half_width_sq_per_force(k_roller, 0.0, length, modulus)
        rows_of = shared["rows"]
    else:
        comp = make_compliance(geo, design, model)
        rows_of = None
    bearing = drive.get("bearing")
    bearings = (bearing, bearing if drive.get("bearing_b") is None else drive["bearing_b"])
    return ForcePassDriveSolver.on_block(
        design,
        np.tile(angles, n),
        geo,
        comp,
        bearings,
        shared["directions"],
        rows_of,
        shared["template"],
    )


def chain_solver(solver_class, design, angles: np.ndarray, pairs: list, psi_limit: float, drive):
    """The stacked drive solver of the samples ``pairs`` (:func:`stacked_geometry`) on the
    nominal drive's chain: ``drive``'s bearings, contact law, ``crank`` and ``bodies``
    (absent or None: the eccentrics fixed, the bodies rigid)."""
    angles = np.asarray(angles, dtype=float).reshape(-1)
    n = len(pairs)
    geometry = stacked_geometry(design, angles, pairs, psi_limit)
    solver = solver_class(
        design,
        np.tile(angles, n),
        geometry=geometry,
        bearing=drive.get("bearing"),
        bearing_b=drive.get("bearing_b"),
        contact_model=drive.get("contact_model", "nonlinear"),
        crank=drive.get("crank"),
    )
    if solver.crank is not None:  # each sample's cam B phase turns its eccentric B
        phases = [row_errors(ea, eb)[1].cam_phase_error for ea, eb in pairs]
        solver.cam_phases = np.repeat(np.asarray(phases, dtype=float), len(angles))
    tables = drive.get("bodies")
    if tables is not None:
        from corr_cad.mechanics.drive.coupling import Influence

        solver.bodies = Influence.repeated(tables, design, angles, geometry, n)
    return solver


def _block_metrics(res, interval, ratio: float, n: int, P: int) -> dict:
    """:func:`drive_metrics` of each of the ``n`` stacked samples, arrays (n,)."""
    p = [np.maximum(np.maximum(r.p_cam, r.p_slot), r.p_gear) for r in res.rows]
    loaded = [loaded_mask(r.F_j).sum(axis=1).reshape(n, P) for r in res.rows]
    rev, fwd = interval
    F_n = res.F_n.reshape(2, n, P, -1)
    return {
        "peak_gear_force": F_n.max(axis=(0, 2, 3)),
        "peak_pressure": np.maximum(*(x.reshape(n, -1).max(axis=1) for x in p)),
        "min_loaded_rollers": np.minimum(*(x.min(axis=1) for x in loaded)).astype(float),
        "backlash_arcmin": _width(fwd, rev).reshape(n, P).max(axis=1) / ratio * ARCMIN_PER_RAD,
    }


def _lean_metrics(solver, F: np.ndarray, interval, ratio: float, n: int, P: int) -> dict:
    """:func:`_block_metrics` of a block's forces ``F`` (n P, 2R), the same bits with fewer
    passes: a sample's peak pressure is the pressure of its largest ``F / (b^2/F)``
    (``contact.max_pressure``'s ``2 sqrt(x) / (pi l)`` is non-decreasing in ``x``, in
    floating point too, so the maximum passes through it unchanged)."""
    geo, comp, R = solver.geo_joined, solver.comp, solver.R
    Fn = geo.rho_n * F
    q = np.maximum(
        np.maximum(np.maximum(F, 0.0) / comp.cj, np.abs(geo.rho_s * F) / comp.cs),
        np.maximum(Fn, 0.0) / comp.cn,
    )
    peak = 2.0 * np.sqrt(q.reshape(n, -1).max(axis=1)) / (np.pi * solver.design.roller_length)
    loaded = [
        loaded_mask(F[:, sl]).sum(axis=1).reshape(n, P) for sl in (slice(0, R), slice(R, None))
    ]
    rev, fwd = interval
    return {
        "peak_gear_force": Fn.reshape(n, -1).max(axis=1),
        "peak_pressure": peak,
        "min_loaded_rollers": np.minimum(*(x.min(axis=1) for x in loaded)).astype(float),
        "backlash_arcmin": _width(fwd, rev).reshape(n, P).max(axis=1) / ratio * ARCMIN_PER_RAD,
    }


def drive_chunk(
    design,
    input_torque,
    angles,
    base,
    base_b,
    tolerances,
    draws,
    draws_b,
    n,
    psi_limit,
    drive,
    errors_for,
):
    """Solve ``n`` samples of the drive (runs in a worker); returns ``(metrics, ok)``.

    ``errors_for(base, tolerances, draws, k)``: sample ``k``'s errors (the Monte
    Carlo's own mapping of draws to errors).
    """
    from corr_cad.mechanics.drive.drive_kernel import CompiledDriveSolver  # numba: only when run
    from corr_cad.mechanics.drive.drive_rigid import ForcePassDriveSolver

    tol_b = row_b_tolerances(tolerances)
    angles = np.asarray(angles, dtype=float).reshape(-1)
    P = len(angles)
    block = max(1, BLOCK_POSITIONS // P)
    parts, ok = [], True
    ratio = float(design.roller_count)
    bearing, bearing_b = drive.get("bearing"), drive.get("bearing_b")
    lean = bearing is not None or bearing_b is None  # else the solver refuses the pair
    for lo in range(0, n, block):
        hi = min(lo + block, n)
        pairs = [
            (errors_for(base, tolerances, draws, k), errors_for(base_b, tol_b, draws_b, k))
            for k in range(lo, hi)
        ]
        if drive.get("crank") is not None or drive.get("bodies") is not None:
            solver = chain_solver(CompiledDriveSolver, design, angles, pairs, psi_limit, drive)
            res = solver.result(float(input_torque))
        elif lean:  # the eccentrics fixed and the bodies rigid: the compiled force pass
            solver = _block_solver(design, angles, pairs, psi_limit, drive)
            tau, F, u, Qs, rel, it = solver.solve(float(input_torque))
            ok &= bool(np.all(rel <= max(solver.rtol, 1e-9)))
            interval = solver.free_interval(solve=False)
            parts.append(_lean_metrics(solver, F, interval, ratio, hi - lo, P))
            continue
        else:  # one cam on a bearing, the other not: the solver says no
            solver = ForcePassDriveSolver(
                design,
                np.tile(angles, hi - lo),
                geometry=stacked_geometry(design, angles, pairs, psi_limit),
                bearing=drive.get("bearing"),
                bearing_b=drive.get("bearing_b"),
                contact_model=drive.get("contact_model", "nonlinear"),
            )
            res = solver.force_metrics_result(float(input_torque))
        ok &= bool(res.success)
        # The backlash is the interval's width: 0 where tight, with no zero-moment solve.
        interval = solver.free_interval(solve=False)
        parts.append(_block_metrics(res, interval, ratio, hi - lo, P))
    return {k: np.concatenate([q[k] for q in parts]) for k in parts[0]}, ok
