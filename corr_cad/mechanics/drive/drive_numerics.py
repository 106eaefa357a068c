"""Numerics of the drive (:mod:`corr_cad.mechanics.drive.drive`): inverting the paper's contact
law inside the bearing Newton, each row's free rotation at no load, and the two rows'
geometry joined.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from corr_cad.geometry.design import GearDesign
from corr_cad.geometry.deviations import ManufacturingErrors
from corr_cad.mechanics.row.solver_geometry import RollerGeometry

__all__ = [
    "row_errors",
    "energy_search",
    "energy_step",
    "expand_drive",
    "free_row",
    "joined",
    "merge_state",
    "moved_state",
    "rest_idle_cams",
    "roller_directions",
]


def free_row(a, g, n, half_clearance: float, e: float, want_centre: bool = False):
    """One row's free crank interval ``(rev, fwd)`` (P,) at no load, rad.

    Roller ``k`` stays clear while ``a_k tau + g_k + n_k . u <= 0``; the cam's
    centre may sit anywhere with ``|u| <= half_clearance``. Since ``a_k = e
    n_k,x``, with ``v = u + e tau x`` the rollers ask ``n_k . v <= -g_k`` (a
    convex polygon of ``v``) and the bearing ``|v - e tau x| <= Pd/2``, so

        e fwd = max over the polygon of v_x + sqrt((Pd/2)^2 - v_y^2)

    (and ``e rev`` the min of ``v_x - sqrt(...)``), solved exactly over the
    polygon's horizontal slices (:mod:`corr_cad.mechanics.drive.free_play`, compiled).
    Without a clearance each roller closes at ``tau = -g_k / a_k``. An empty
    interval (``rev > fwd``): the row is preloaded (no ``v`` leaves every roller
    clear). ``want_centre``: also the least-pressed ``v`` of a preloaded row, (P,
    2), a start for its cam's own equilibrium.
    """
    if half_clearance > 0.0:
        from corr_cad.mechanics.drive.free_play import free_rows

        return free_rows(g, n, half_clearance, e, want_centre)
    up, down = a > 0, a < 0
    with np.errstate(divide="ignore", invalid="ignore"):
        t = -g / a
        fwd = np.min(np.where(up, t, np.inf), axis=1)
        rev = np.max(np.where(down, t, -np.inf), axis=1)
    return (rev, fwd, np.zeros((a.shape[0], 2))) if want_centre else (rev, fwd)


def _forces_of(comp, h):
    """Roller forces and ``dF/dh`` at overlaps ``h`` for either contact law."""
    if getattr(comp, "explicit", False):
        return comp.force_and_stiffness(h)
    return _invert_convex(comp, h, np.maximum(h, 0.0) / comp.slope0)


def _invert_convex(comp, h, start):
    """``F`` with ``G(F) = h`` (0 where ``h <= 0``) and ``dF/dh``, for the paper's law.

    Newton from ``start``, to the right of the root (``G`` is convex and
    increasing, so the iterates decrease monotonically onto it), each roller
    until its step is below ``1e-15`` of its force (a few iterations from a
    tangent predictor; the one-row solver's own inversion asks for steps below
    round-off, which a few elements never reach). Only the loaded rollers are
    evaluated, and each only until it settles (the compiled inversion's rule,
    :mod:`corr_cad.mechanics.drive.drive_kernel`): an unloaded roller or a settled
    one costs no evaluation of the law.
    """
    pos = h > 0
    F = np.zeros(h.shape)
    dg = np.ones(h.shape)
    where = np.flatnonzero(pos)  # flat indices of the rollers still iterating
    loaded = sub = comp.take(pos)  # their contacts, flat
    hs = h[pos]
    Fs = np.asarray(start, dtype=float)[pos]
    for _ in range(60):
        if where.size == 0:
            break
        g, d = sub.value_and_slope(Fs)
        step = (g - hs) / d
        Fs = np.maximum(Fs - step, 0.0)
        F.flat[where] = Fs
        going = ~(np.abs(step) <= 1e-15 * Fs + 1e-300)
        if not going.all():
            where, hs, Fs = where[going], hs[going], Fs[going]
            sub = sub.take(going)
    dg[pos] = loaded.value_and_slope(F[pos])[1]
    with np.errstate(divide="ignore", invalid="ignore"):
        return F, np.where(F > 0, 1.0 / dg, 0.0)


def cam_start(bearings, F: np.ndarray, n: np.ndarray, R: int, u0=None) -> np.ndarray:
    """The bearing Newton's start (2, P, 2): ``u0`` where given (its shape), else each cam
    displaced along its load ``sum F n`` by half its clearance and Stribeck's approach."""
    P = F.shape[0]
    if u0 is not None and np.shape(u0) == (2, P, 2):
        return np.array(u0, dtype=float)
    u = np.zeros((2, P, 2))
    for c, b in enumerate(bearings):
        sl = slice(c * R, (c + 1) * R)
        push = np.einsum("pk,pkx->px", F[:, sl], n[:, sl])  # sum F n: the needles' share
        mag = np.linalg.norm(push, axis=1)
        q = b.stribeck_max_load(1.0) * mag
        depth = 0.5 * b.diametral_clearance + b.needle_coefficient * q**0.9
        with np.errstate(divide="ignore", invalid="ignore"):
            u[c] = np.where(mag[:, None] > 0, -push / mag[:, None] * depth[:, None], 0.0)
    return u


def joined(ga: RollerGeometry, gb: RollerGeometry) -> RollerGeometry:
    """Both rows as one geometry of ``2 (z + 1)`` rollers (row A first)."""
    out = {}
    for k in RollerGeometry.__dataclass_fields__:
        a, b = getattr(ga, k), getattr(gb, k)
        if k == "k_cam":  # one per cam (a float, or (P, 1) when samples are stacked)
            out[k] = np.concatenate(
                [
                    np.broadcast_to(np.asarray(a, dtype=float), ga.psi.shape),
                    np.broadcast_to(np.asarray(b, dtype=float), gb.psi.shape),
                ],
                axis=1,
            )
        else:
            out[k] = np.concatenate([a, b], axis=1)
    return RollerGeometry(**out)


def roller_directions(design: GearDesign, geo: RollerGeometry) -> np.ndarray:
    """``n_k`` (P, R, 2): unit vector from the cam centre to roller ``k``, eccentric's frame.

    In the frame that turns with the eccentric (eccentric along +y), roller
    ``k`` sits at ``s_k (-sin psi_k, cos psi_k)`` and the cam centre at
    ``(0, e)``; their distance is ``L``.
    """
    e, L = design.eccentricity, design.link_length
    s, psi = geo.s, geo.psi
    return np.stack([-s * np.sin(psi) / L, (s * np.cos(psi) - e) / L], axis=-1)


def rest_idle_cams(at, floor, state, converged):
    """Settle each cam of the drive's bearing Newton that carries nothing
    (:meth:`~corr_cad.mechanics.drive.drive.DriveSolver._with_bearings`): ``(settled (P,),
    (u, F, kf, Qs, kqs, r, gross))``, or None.

    ``at``: ``(cand, target, tau, u, F, kf, Qs, kqs, r, gross, a_m)``, the Newton's
    state and the positions ``cand`` (P,) where it has not converged; ``floor`` (P,), N:
    the drive's round-off, ``DRIVE_RTOL`` of the forces that fix the crank;
    ``state(tau, u)``: the Newton's state function; ``converged(r, F, a_m, Qs, target,
    gross)``: its test.

    A cam whose rollers and needles carry no more than ``floor`` is located by nothing:
    its rollers touch (or keep their gaps) without load, and its needles at zero load
    have no stiffness (Palmgren's ``dQ/d delta = 0`` at ``Q = 0``). Its balance,
    relative to its own vanishing forces, is then round-off of the other row's, which
    no Newton step can reduce. Such a cam rests centred on its eccentric (``u = 0``)
    where that presses none of its rollers beyond the same round-off, otherwise where
    its rollers left it in its free play; it carries exactly nothing. The position is
    settled when the moment and the other cam are then in equilibrium to ``DRIVE_RTOL``.
    """
    cand, target, tau, u, F, kf, Qs, kqs, r, gross, a_m = at
    R = F.shape[1] // 2
    carried = [np.sum(F[:, c * R : (c + 1) * R], axis=1) + np.sum(Qs[c], axis=1) for c in (0, 1)]
    tiny = [cand & (carried[c] <= floor) for c in (0, 1)]
    if not (np.any(tiny[0]) or np.any(tiny[1])):
        return None
    centred = u.copy()
    for c in (0, 1):
        centred[c][tiny[c]] = 0.0
    with np.errstate(all="ignore"):
        F0 = state(tau, centred)[1]  # the rollers' forces with the idle cams centred
    v, G, kg, rr = u.copy(), F.copy(), kf.copy(), r.copy()
    Qv, kqv = [q.copy() for q in Qs], [k.copy() for k in kqs]
    gf, gq = gross[0].copy(), [g.copy() for g in gross[1]]
    for c in (0, 1):
        sl, t = slice(c * R, (c + 1) * R), tiny[c]
        v[c][t & (np.sum(F0[:, sl], axis=1) <= floor)] = 0.0
        for arr in (G, kg, gf):
            arr[t, sl] = 0.0
        for arr in (Qv[c], kqv[c], gq[c]):
            arr[t] = 0.0
        rr[t, 1 + 2 * c : 3 + 2 * c] = 0.0
    idle = tiny[0] | tiny[1]
    rr[idle, 0] = np.sum(a_m[idle] * G[idle], axis=1) - target
    settled = idle & converged(rr, G, a_m, Qv, target, (gf, gq))
    if not np.any(settled):
        return None
    s1, s2 = settled[:, None], settled[None, :, None]

    def pick(new, old, m=s1):
        return np.where(m, new, old)

    return settled, (
        pick(v, u, s2),
        pick(G, F),
        pick(kg, kf),
        [pick(a, b) for a, b in zip(Qv, Qs, strict=True)],
        [pick(a, b) for a, b in zip(kqv, kqs, strict=True)],
        pick(rr, r),
        (pick(gf, gross[0]), [pick(a, b) for a, b in zip(gq, gross[1], strict=True)]),
    )


def expand_drive(res, angles, idx, shift, pitch: float):
    """A :class:`~corr_cad.mechanics.drive.drive.DriveResult` over the full cycle from its solved
    classes (:func:`corr_cad.mechanics.row.solver._expand` for each row; the cams' quantities,
    in the eccentrics' frames, repeat as they are)."""
    from corr_cad.mechanics.row.solver import _expand

    rows = (
        _expand(res.rows[0], angles, idx, shift, pitch),
        _expand(res.rows[1], angles + np.pi, idx, shift, pitch),
    )
    return replace(
        res,
        crank_angles=angles,
        F_j=np.stack([r.F_j for r in rows]),
        F_n=np.stack([r.F_n for r in rows]),
        F_s=np.stack([r.F_s for r in rows]),
        row_a_share=res.row_a_share[idx],
        bearing_load=res.bearing_load[:, idx],
        needle_load_max=res.needle_load_max[:, idx],
        needle_loads=None if res.needle_loads is None else tuple(q[idx] for q in res.needle_loads),
        cam_displacement=res.cam_displacement[:, idx],
        cam_rotation=res.cam_rotation[idx],
        backlash=res.backlash[idx],
        rows=rows,
    )


def energy_search(stuck, slope0, along, iterations: int = 60):
    """The step length ``alpha`` (P,) in ``[0, 1]`` along a descent direction of the drive's
    potential energy at the positions ``stuck`` (0 elsewhere): the fallback of the bearing
    Newton where its merit line search finds no decrease.

    The residual of the bearing Newton is the gradient of the contacts' potential energy
    less the crank moment's work (``r = grad Pi``; its Jacobian is the energy's Hessian,
    positive semi-definite), so along a direction ``d`` the slope ``phi'(alpha) = r(x +
    alpha d) . d`` rises monotonically with ``alpha``. ``slope0`` (P,): ``phi'(0) < 0``;
    ``along(alpha)``: ``phi'(alpha)`` (P,). The whole step is taken where the energy still
    falls at its end; otherwise bisection on the monotone slope, to the last point where it
    is still negative (the energy falls all the way there) once it is within a tenth of
    ``|phi'(0)|`` of zero: an exact line search, which no singular or near-singular Jacobian
    (a cam free in its clearance) can stall.
    """
    P = stuck.shape[0]
    lo, hi = np.zeros(P), np.ones(P)
    whole = stuck & (along(np.where(stuck, 1.0, 0.0)) <= 0.0)
    search = stuck & ~whole
    for _ in range(iterations):
        if not np.any(search):
            break
        mid = 0.5 * (lo + hi)
        s = along(np.where(search, mid, 0.0))
        down = s < 0.0
        lo = np.where(search & down, mid, lo)
        hi = np.where(search & ~down, mid, hi)
        search &= ~(down & (s >= 0.1 * slope0))
    return np.where(whole, 1.0, np.where(stuck, lo, 0.0))


def moved_state(tau, u, alpha, step):
    """``(tau, u)`` moved by ``alpha`` (P,) times the bearing Newton's ``step`` (P, 5)."""
    P = tau.shape[0]
    t_u = u + (alpha[:, None] * step[:, 1:]).reshape(P, 2, 2).transpose(1, 0, 2)
    return tau + alpha * step[:, 0], t_u


def merge_state(take, old, new):
    """The bearing Newton's state ``(tau, u, h, F, kf, Qs, kqs, r, (gf, gq))``: ``new``
    where ``take`` (P,), ``old`` elsewhere."""
    t1, t2 = take[:, None], take[None, :, None]
    tau, u, h, F, kf, Qs, kqs, r, (gf, gq) = old
    nt, nu, nh, nF, nkf, nQ, nkq, nr, (ngf, ngq) = new

    def pick(a, b):
        return [np.where(t1, y, x) for x, y in zip(a, b, strict=True)]

    return (
        np.where(take, nt, tau),
        np.where(t2, nu, u),
        *pick((h, F, kf), (nh, nF, nkf)),
        pick(Qs, nQ),
        pick(kqs, nkq),
        np.where(t1, nr, r),
        (np.where(t1, ngf, gf), pick(gq, ngq)),
    )


def energy_step(stuck, d, x, state):
    """The bearing Newton's state ``x`` (:func:`merge_state`'s) moved along ``d`` (P, 5)
    by :func:`energy_search` at the positions ``stuck`` (kept where ``d`` is no descent
    direction or no step lowers the energy); ``state(tau, u, F_prev, h_prev, k_prev)``:
    the Newton's state function."""
    tau, u, h, F, kf, _, _, r, _ = x
    slope0 = np.sum(r * d, axis=1)
    stuck = stuck & (slope0 < 0)

    def along(a):
        with np.errstate(all="ignore"):
            rt = state(*moved_state(tau, u, a, d), F, h, kf)[5]
        return np.sum(rt * d, axis=1)

    a = energy_search(stuck, slope0, along)
    t_tau, t_u = moved_state(tau, u, a, d)
    with np.errstate(all="ignore"):
        trial = state(t_tau, t_u, F, h, kf)
    return merge_state(stuck & (a > 0), x, (t_tau, t_u) + trial)


def row_errors(
    errors: ManufacturingErrors | None, errors_b: ManufacturingErrors | None = None
) -> tuple[ManufacturingErrors, ManufacturingErrors]:
    """Row A's and row B's error models from ``[errors]`` and ``[errors.row_b]``.

    ``[errors]`` describes both rows unless ``errors_b`` is given. The slot
    errors and the slots' clearance (``slot_clearance``, 0 when None: the
    drive's slot fit) are the frame's: row B takes row A's. The cam phase
    error is cam B's against cam A: row A gets none, row B the scene's.
    """
    errors = errors or ManufacturingErrors()
    b = errors if errors_b is None else errors_b
    phase = errors.cam_phase_error
    # The slots' fit is the frame's too; the drive puts the roller error into it both ways.
    fit = 0.0 if errors.slot_clearance is None else errors.slot_clearance
    a = replace(errors, cam_phase_error=0.0, slot_clearance=fit)
    b = replace(
        b, cam_phase_error=phase, slot_angle_errors=errors.slot_angle_errors, slot_clearance=fit
    )
    return a, b
