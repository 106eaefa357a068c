"""Coulomb friction at the roller contacts and in the eccentric bearing: where each watt goes.

Given the normal cam force of every roller (the elastic solution of the
force solver or the drive model), friction enters each roller's own
equilibrium (force and moment: its slot and ring forces are solved with
friction) and, on a floating cam, the cam's moment balance; the load
sharing between rollers stays the elastic one (first order in ``mu``).
With every body in equilibrium the power the crank and the output put in
equals the sum of the contact and bearing losses at every position.
:mod:`corr_cad.mechanics.losses.operating` chooses the elastic state whose output
torque with friction is the load, in both directions of power flow.

Which surfaces roll and which slide
-----------------------------------
A roller has three contacts: the cam (normal through the cam centre), the
ring's tooth flank and the slot wall. Its centre moves with the frame and
along the slot; each contact's slip is ``a_i + r omega_r`` (the roller
surface against the other body, along ``t_i = z x d_i``, ``d_i`` the unit
vector from the roller centre to the contact), linear in the roller's spin
``omega_r``. The spin follows from the roller's own moment balance
``r sum f_i = 0`` with ``|f_i| <= mu_i N_i``: the friction moment
``-sum mu_i N_i sign(a_i + r omega)`` falls monotonically with ``omega``,
so the balance is reached where one contact **sticks** (rolls) and the
others **slide**: the contact whose stick speed ``-a_i / r`` is the
weighted median of the three, with weights ``mu_i N_i``. At most one
contact sticks; its friction force is whatever balances the others. When
one weight exceeds the sum of the other two, that contact sticks whatever
the speeds (a limiting case the tests pin).

Two cam arrangements (``mounting``)
-----------------------------------
``"fixed"``: the cam is one body with the crank and turns at the crank's
speed about the crank axis; the rollers slide or roll on it as their
moment balance says. No eccentric bearing.

``"bearing"``: the cam floats on its needle bearing on the eccentric. The
cam's spin follows from its own moment balance about its centre: the
rollers' friction moments against the bearing's constant-coefficient
moment ``M = 0.5 mu P d`` (SKF and Koyo rolling-bearing catalogues:
``mu`` about 0.0025 for needle roller and cage assemblies, ``P`` the radial
load, ``d`` the bore). The moment falls with the cam's spin in steps, one
where a roller's cam stick speed crosses one of its other contacts'; it is
evaluated between all steps at once and the balance sits on a step. That
roller then rolls on the cam and on that contact, and the split of its
friction between them closes the cam's balance. The bearing loss is
``M |omega_crank - omega_cam|``.

Units: N, mm, rad; speeds per unit output speed (rad/rad): multiply the
powers by the output speed in rad/s and by 1e-3 for watts.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from corr_cad.errors import SolverError

if TYPE_CHECKING:
    from corr_cad.geometry.design import GearDesign

__all__ = [
    "MOUNTINGS",
    "Friction",
    "RowContacts",
    "RowFriction",
    "design_contacts",
    "row_contacts",
    "roller_equilibrium",
    "row_friction",
]

#: Cam arrangements: on its needle bearing, or one body with the crank.
MOUNTINGS = ("bearing", "fixed")
#: Contacts in the order of the arrays' last axis.
CONTACTS = ("cam", "slot", "ring")


@dataclass(frozen=True)
class Friction:
    """Coulomb coefficients of the contacts and the bearing's constant coefficient.

    ``bearing_diameter`` (mm) is the ``d`` of the catalogue formula
    ``M = 0.5 mu P d``.
    """

    mu_cam: float = 0.0
    mu_slot: float = 0.0
    mu_ring: float = 0.0
    mu_bearing: float = 0.0
    mounting: str = "bearing"
    bearing_diameter: float = 0.0

    def __post_init__(self):
        for name in ("mu_cam", "mu_slot", "mu_ring", "mu_bearing"):
            v = getattr(self, name)
            if not (isinstance(v, (int, float)) and math.isfinite(v) and 0.0 <= v <= 1.0):
                raise SolverError(f"{name} = {v!r}: allowed range is [0, 1], e.g. 0.05")
        if self.mounting not in MOUNTINGS:
            raise SolverError(
                f"mounting = {self.mounting!r}: must be one of {', '.join(MOUNTINGS)}"
            )
        d = self.bearing_diameter
        if not (isinstance(d, (int, float)) and math.isfinite(d) and d >= 0.0):
            raise SolverError(f"bearing_diameter = {d!r}: allowed range is [0, inf) mm, e.g. 82.4")

    @property
    def mu(self) -> np.ndarray:
        """Contact coefficients in the order of :data:`CONTACTS`."""
        return np.array([self.mu_cam, self.mu_slot, self.mu_ring])


@dataclass(frozen=True)
class RowContacts:
    """One row's contact geometry and kinematics at P positions for R rollers.

    Vectors are in a frame-fixed Cartesian system (mm), counter-clockwise
    angles; velocities are absolute (ring fixed) per unit output speed.
    ``d`` is (P, R, 3, 2): unit vectors from each roller centre to its cam,
    slot and ring contact; ``centre`` (P, R, 2); ``centre_velocity`` (P, R, 2);
    ``cam_centre`` (P, 2); ``crank_speed`` the eccentric's absolute speed per
    unit output speed (``z + 1`` running, 0 on a locked-input bench);
    ``ring_speed`` the ring's (0, ring fixed).
    """

    d: np.ndarray
    centre: np.ndarray
    centre_velocity: np.ndarray
    cam_centre: np.ndarray
    roller_radius: float
    cam_radius: float
    crank_speed: float
    ring_speed: float = 0.0

    @property
    def points(self) -> np.ndarray:
        """Contact points (P, R, 3, 2), mm."""
        return self.centre[:, :, None, :] + self.roller_radius * self.d


def _cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]


def _perp(a: np.ndarray) -> np.ndarray:
    """``z x a``: the vector turned by +90 degrees."""
    return np.stack([-a[..., 1], a[..., 0]], axis=-1)


def row_contacts(
    tooth_count: int,
    eccentricity: float,
    cam_radius: float,
    roller_radius: float,
    crank_angles: np.ndarray,
    slot_side: np.ndarray,
    *,
    slot_angles: np.ndarray | None = None,
    crank_speed: float | None = None,
) -> RowContacts:
    """Contact directions and kinematics of one row from the nominal geometry.

    ``crank_angles`` (P,): the eccentric's angle relative to the frame (the
    solver's crank angle; a second row passes its own, ``+ pi`` and its
    phase). ``slot_angles`` (R,): roller polar angles in the frame (default
    ``2 pi k / (z + 1)``). ``slot_side`` (P, R): the sign of the slot force
    (``+1`` where the roller pushes the frame forwards, the solver's
    ``F_s > 0``), which says which slot wall it touches. Running kinematics:
    output speed 1, crank ``crank_speed`` (default ``z + 1``), ring 0.
    """
    z = int(tooth_count)
    R = z + 1
    e, Rj, r = float(eccentricity), float(cam_radius), float(roller_radius)
    L = Rj + r
    phi = np.asarray(crank_angles, dtype=float).reshape(-1)
    theta = (
        2.0 * np.pi * np.arange(R) / R
        if slot_angles is None
        else np.asarray(slot_angles, dtype=float)
    )
    psi = phi[:, None] - theta[None, :]
    sp, cp = np.sin(psi), np.cos(psi)
    W = np.sqrt(L * L - (e * sp) ** 2)
    s = e * cp + W
    ds = -e * sp - e * e * sp * cp / W  # ds/dpsi
    beta = np.arctan2(z * e * sp, W)
    ur = np.stack([np.cos(theta), np.sin(theta)], axis=-1)[None, :, :] * np.ones((len(phi), 1, 1))
    ut = _perp(ur)
    centre = s[..., None] * ur
    o1 = e * np.stack([np.cos(phi), np.sin(phi)], axis=-1)
    n_cam = (centre - o1[:, None, :]) / L  # cam centre -> roller centre
    n_ring = np.cos(beta)[..., None] * ur + np.sin(beta)[..., None] * ut
    side = np.where(np.asarray(slot_side) < 0, -1.0, 1.0)
    d = np.stack([-n_cam, side[..., None] * ut, n_ring], axis=2)
    # psi = phi - theta grows at z per unit output speed (crank z + 1, frame 1).
    v = _perp(centre) + (z * ds)[..., None] * ur
    return RowContacts(
        d=d,
        centre=centre,
        centre_velocity=v,
        cam_centre=o1,
        roller_radius=r,
        cam_radius=Rj,
        crank_speed=float(R if crank_speed is None else crank_speed),
    )


def design_contacts(
    design: GearDesign,
    crank_angles: np.ndarray,
    slot_side: np.ndarray,
    *,
    crank_speed: float | None = None,
) -> RowContacts:
    """:func:`row_contacts` of ``design``'s nominal row (its slot angles, ``2 pi k / (z + 1)``)."""
    return row_contacts(
        design.tooth_count,
        design.eccentricity,
        design.cam_radius,
        design.roller_radius,
        crank_angles,
        slot_side,
        crank_speed=crank_speed,
    )


def _body_velocities(c: RowContacts, cam_spin: np.ndarray) -> np.ndarray:
    """Velocity of the cam, frame and ring at each contact point, (P, R, 3, 2)."""
    p = c.points
    o1 = c.cam_centre[:, None, :]
    cam = c.crank_speed * _perp(o1) + np.asarray(cam_spin)[:, None, None] * _perp(p[:, :, 0] - o1)
    frame = _perp(p[:, :, 1])
    ring = c.ring_speed * _perp(p[:, :, 2])
    return np.stack([cam, frame, ring], axis=2)


def _slip_bases(c: RowContacts, cam_spin: np.ndarray) -> np.ndarray:
    """``a_i``: each contact's slip at zero roller spin, (P, R, 3)."""
    vb = _body_velocities(c, cam_spin)
    return np.einsum("prkx,prkx->prk", c.centre_velocity[:, :, None, :] - vb, _perp(c.d))


def _repeat(c: RowContacts, m: int) -> RowContacts:
    """The contacts with every position repeated ``m`` times (position-major)."""
    return RowContacts(
        d=np.repeat(c.d, m, axis=0),
        centre=np.repeat(c.centre, m, axis=0),
        centre_velocity=np.repeat(c.centre_velocity, m, axis=0),
        cam_centre=np.repeat(c.cam_centre, m, axis=0),
        roller_radius=c.roller_radius,
        cam_radius=c.cam_radius,
        crank_speed=c.crank_speed,
        ring_speed=c.ring_speed,
    )


def roller_equilibrium(c: RowContacts, cam_force: np.ndarray, mu: np.ndarray, cam_spin) -> dict:
    """Each roller's spin, normal and friction forces with friction, at a given cam spin.

    ``cam_force`` (P, R) is the frictionless cam force (N); the slot and
    ring normal forces are solved with friction in the roller's force and
    moment balance (a 2 x 2 linear system per roller once the sticking
    contact is known; the choice is iterated to a fixed point). Returns a
    dict of arrays: ``N``, ``f``, ``slip`` (P, R, 3), ``spin`` (P, R),
    ``stick`` (P, R) index of the sticking contact, ``power`` (P, 3) that
    the cam, the frame and the ring deliver to the rollers, ``loss``
    (P, 3) per contact kind, ``cam_force_on_rollers`` (P, 2) and
    ``cam_moment`` (P,) of the rollers' forces on the cam about its centre.
    """
    mu = np.asarray(mu, dtype=float)
    P, R = cam_force.shape
    spin_c = np.broadcast_to(np.asarray(cam_spin, dtype=float), (P,))
    d = c.d
    t = _perp(d)
    vb = _body_velocities(c, spin_c)
    a = np.einsum("prkx,prkx->prk", c.centre_velocity[:, :, None, :] - vb, t)
    r = c.roller_radius
    Nc = np.asarray(cam_force, dtype=float)
    # Frictionless slot and ring forces: N_s d_s + N_g d_g = -N_c d_c.
    N = np.zeros((P, R, 3))
    N[..., 0] = Nc
    N[..., 1:] = _solve2(d[:, :, 1], d[:, :, 2], -Nc[..., None] * d[:, :, 0])
    stick = np.zeros((P, R), dtype=np.int64)
    for _ in range(6):
        w = mu * np.abs(N)
        new = _weighted_median(-a / r, w)
        omega = np.take_along_axis(-a / r, new[..., None], axis=2)[..., 0]
        slip = a + r * omega[..., None]
        sig = np.sign(slip)
        k = new[..., None] == np.arange(3)
        # f_i = -mu_i |N_i| sign(slip_i) for the sliding ones, linear in N_i with the sign
        # of the last iterate (a roller that lifts off its slot wall keeps its friction opposed).
        coef = np.where(k, 0.0, -mu * sig * np.where(N < 0.0, -1.0, 1.0))
        # F_stick = -sum coef_i N_i (moment); total force sum N_i (-d_i + coef_i (t_i - t_k)) = 0
        tk = np.take_along_axis(t, new[..., None, None], axis=2)
        g = -d + coef[..., None] * (t - tk)
        Ns = _solve2(g[:, :, 1], g[:, :, 2], -Nc[..., None] * g[:, :, 0])
        N_new = np.concatenate([Nc[..., None], Ns], axis=-1)
        done = np.array_equal(new, stick) and np.allclose(N_new, N, rtol=1e-15, atol=0.0)
        N, stick = N_new, new
        if done:
            break
    f = coef * N
    fk = -np.sum(f, axis=2)
    f = np.where(k, fk[..., None], f)
    slip = np.where(k, 0.0, slip)
    return _finish(c, vb, {"N": N, "f": f, "slip": slip, "spin": omega, "stick": stick})


def _finish(c: RowContacts, vb: np.ndarray, out: dict) -> dict:
    """Add the powers, losses and the forces on the cam to a roller state ``out``."""
    N, f, slip, d = out["N"], out["f"], out["slip"], c.d
    force = -N[..., None] * d + f[..., None] * _perp(d)  # on the roller, (P, R, 3, 2)
    out["power"] = np.einsum("prkx,prkx->pk", force, vb)
    out["loss"] = np.sum(-f * slip, axis=1)
    out["cam_force_on_rollers"] = np.sum(force[:, :, 0], axis=1)
    # Normal forces pass through the cam centre; the friction force on the cam,
    # -f t at the arm -R_j d: moment R_j f (d x z x d = 1).
    out["cam_moment"] = c.cam_radius * np.sum(f[:, :, 0], axis=1)
    return out


def _solve2(u: np.ndarray, v: np.ndarray, rhs: np.ndarray) -> np.ndarray:
    """Solve ``x u + y v = rhs`` for (x, y) per element by Cramer's rule, (..., 2)."""
    det = _cross(u, v)
    with np.errstate(divide="ignore", invalid="ignore"):
        x = np.where(det != 0.0, _cross(rhs, v) / det, 0.0)
        y = np.where(det != 0.0, _cross(u, rhs) / det, 0.0)
    return np.stack([x, y], axis=-1)


def _weighted_median(x: np.ndarray, w: np.ndarray) -> np.ndarray:
    """Index (along the last axis) of the weighted median of ``x``: the contact that sticks.

    The first (in ``x`` order) whose cumulative weight reaches half the
    total; with no weight at all, the cam (index 0).
    """
    order = np.argsort(x, axis=-1, kind="stable")
    ws = np.take_along_axis(w, order, axis=-1)
    cum = np.cumsum(ws, axis=-1)
    total = cum[..., -1:]
    pick = np.argmax(cum >= 0.5 * total, axis=-1)
    idx = np.take_along_axis(order, pick[..., None], axis=-1)[..., 0]
    return np.where(total[..., 0] > 0.0, idx, 0)


@dataclass
class RowFriction:
    """Losses and bearing figures of one row over P positions, per unit output speed.

    Powers in N*mm per rad of output (times the output speed in rad/s:
    N*mm/s): ``crank_power`` and ``frame_power`` (P,) delivered into the
    mechanism by the crank and by the output frame (one is negative: the
    driven side); ``loss`` (P, 4) of the cam, slot and ring contacts and the
    bearing; ``bearing_load`` (P,) N, the radial load on the cam's bearing;
    ``bearing_speed`` (P,) the bearing's relative speed ``|omega_crank -
    omega_cam|``; ``cam_spin`` (P,); ``roller`` the per-roller arrays of
    :func:`roller_equilibrium`; ``cam_moment_residual`` (P,) N*mm.
    """

    crank_power: np.ndarray
    frame_power: np.ndarray
    loss: np.ndarray
    bearing_load: np.ndarray
    bearing_speed: np.ndarray
    cam_spin: np.ndarray
    roller: dict
    cam_moment_residual: np.ndarray

    @property
    def total_loss(self) -> np.ndarray:
        return np.sum(self.loss, axis=1)


def row_friction(c: RowContacts, cam_force: np.ndarray, friction: Friction) -> RowFriction:
    """Friction of one row at every position: the rollers' and, floating, the cam's balance."""
    mu = friction.mu
    P = cam_force.shape[0]
    w_in = c.crank_speed
    if friction.mounting == "fixed":
        res = roller_equilibrium(c, cam_force, mu, np.full(P, w_in))
        zero = np.zeros(P)
        return _row(
            res, np.full(P, w_in), zero, zero, np.linalg.norm(res["cam_force_on_rollers"], axis=1)
        )
    k = 0.5 * friction.mu_bearing * friction.bearing_diameter

    def moment(cc, force, spin: np.ndarray) -> tuple[np.ndarray, dict]:
        res = roller_equilibrium(cc, force, mu, spin)
        load = np.linalg.norm(res["cam_force_on_rollers"], axis=1)
        # The bearing's moment on the cam opposes its spin relative to the crank.
        return res["cam_moment"] - k * load * np.sign(spin - w_in), res

    # The cam's moment is a step function of its spin: a roller's cam friction
    # changes only where its cam stick speed crosses another contact's, at the
    # spin (a_k - a_c0) / R_j, and the bearing's at the crank's speed. Evaluate
    # the moment between those breakpoints at once; the balance sits on one.
    a = _slip_bases(c, np.zeros(P))  # (P, R, 3) at cam spin 0: a_cam = a_c0 + R_j spin
    b = (a[:, :, 1:] - a[:, :, :1]) / c.cam_radius
    loaded = (np.asarray(cam_force) > 0.0)[..., None]
    b = np.where(loaded, b, w_in).reshape(P, -1)
    allb = np.concatenate([b, np.full((P, 1), float(w_in))], axis=1)
    order = np.argsort(allb, axis=1, kind="stable")
    bps = np.take_along_axis(allb, order, axis=1)
    cands = np.concatenate(
        [bps[:, :1] - 1.0, 0.5 * (bps[:, 1:] + bps[:, :-1]), bps[:, -1:] + 1.0], axis=1
    )
    M = cands.shape[1]
    many = _repeat(c, M)
    g, _ = moment(many, np.repeat(cam_force, M, axis=0), cands.reshape(-1))
    g = g.reshape(P, M)
    # g falls with the spin: the first candidate at or below zero.
    j = np.argmax(g <= 0.0, axis=1)
    j = np.where(np.any(g <= 0.0, axis=1), j, M - 1)
    rows = np.arange(P)
    flat = g[rows, j] == 0.0
    mid = np.where(flat | (j == 0), cands[rows, j], bps[rows, np.maximum(j - 1, 0)])
    mid = np.where(np.all(g == 0.0, axis=1), w_in, mid)
    sticks = mid == w_in
    _, res = moment(c, cam_force, mid)
    # On a roller's breakpoint that roller's cam and one other contact both roll: the
    # split of friction between them is free, and takes up the cam's moment balance.
    at = np.where(sticks | flat | (j == 0), -1, order[rows, np.maximum(j - 1, 0)])
    at = np.where(at >= b.shape[1], -1, at)  # the bearing's own breakpoint: it sticks
    res = _balance_cam(c, res, mu, mid, at, k, w_in, b.reshape(P, -1, 2))
    load = np.linalg.norm(res["cam_force_on_rollers"], axis=1)
    rel = np.abs(w_in - mid)
    bearing_loss = k * load * rel
    resid = np.where(sticks, 0.0, res["cam_moment"] - k * load * np.sign(mid - w_in))
    return _row(res, mid, rel, bearing_loss, load, resid)


def _balance_cam(c: RowContacts, res: dict, mu, spin, at, k: float, w_in: float, bps) -> dict:
    """Close the cam's moment balance on the rollers whose breakpoint the spin sits on.

    ``at`` (P,): a breakpoint's flat index ``roller * 2 + (0 slot, 1 ring)``,
    or -1; ``bps`` (P, R, 2) every roller's breakpoints. The rollers whose
    breakpoint equals the spin (one, or several alike: rollers in mirror
    positions) roll on the cam and on that contact; their cam friction is
    set so that the cam's moments balance (the bearing's included), shared
    in proportion to their friction cones ``mu N``; each one's other rolling
    contact takes its moment balance, the third slides. The normal forces
    are solved again (a 2 x 2 system); three passes follow the bearing
    load's small change. A balance outside the friction cones is left as it
    is (clipped to the cones).
    """
    idx = np.flatnonzero(at >= 0)
    if idx.size == 0:
        return res
    vb = _body_velocities(c, spin)
    t = _perp(c.d)
    N, f, slip = res["N"].copy(), res["f"].copy(), res["slip"].copy()
    stick = res["stick"].copy()
    for p in idx:
        r0, m0 = divmod(int(at[p]), 2)
        tie = np.abs(bps[p] - bps[p, r0, m0]) <= 1e-12 * max(abs(bps[p, r0, m0]), 1.0)
        tie[r0] = False
        tie[r0, m0] = True
        tied = [(int(r), int(m) + 1) for r, m in zip(*np.nonzero(tie), strict=True)]
        tied = list({r: m for r, m in tied}.items())  # one contact per roller
        rs = [r for r, _ in tied]
        for _ in range(3):
            load = np.linalg.norm(
                np.sum(-N[p, :, 0, None] * c.d[p, :, 0] + f[p, :, 0, None] * t[p, :, 0], axis=0)
            )
            others = c.cam_radius * (np.sum(f[p, :, 0]) - np.sum(f[p, rs, 0]))
            bearing = k * load * np.sign(spin[p] - w_in)
            lims = np.array([mu[0] * abs(N[p, r, 0]) for r in rs])
            total = (bearing - others) / c.cam_radius
            cap = float(np.sum(lims))
            total = min(max(total, -cap), cap)
            for (r, m), lim in zip(tied, lims, strict=True):
                fc = total * lim / cap if cap > 0.0 else 0.0
                _roll_two(c, N, f, slip, t, mu, p, r, m, fc)
        for r, m in tied:
            slip[p, r, 0] = slip[p, r, m] = 0.0
            stick[p, r] = m
    out = {"N": N, "f": f, "slip": slip, "spin": res["spin"], "stick": stick}
    return _finish(c, vb, out)


def _roll_two(c: RowContacts, N, f, slip, t, mu, p: int, r: int, m: int, fc: float) -> None:
    """Roller ``r`` at position ``p`` rolls on the cam (friction ``fc``) and on contact
    ``m`` (1 slot, 2 ring), slides on the third: its forces and moment balance, in place."""
    d, tt = c.d[p, r], t[p, r]
    o = 3 - m  # the contact that slides
    co = -mu[o] * np.sign(slip[p, r, o]) * (1.0 if N[p, r, o] >= 0 else -1.0)
    g_o = -d[o] + co * (tt[o] - tt[m])
    g_m = -d[m]
    rhs = N[p, r, 0] * d[0] - fc * (tt[0] - tt[m])
    gs, gg = (g_m, g_o) if m == 1 else (g_o, g_m)
    N[p, r, 1:] = _solve2(gs[None], gg[None], rhs[None])[0]
    f[p, r, 0] = fc
    f[p, r, o] = co * N[p, r, o]
    f[p, r, m] = -fc - f[p, r, o]


def _row(res, spin, rel, bearing_loss, load, resid=None) -> RowFriction:
    loss = np.concatenate([res["loss"], np.asarray(bearing_loss)[:, None]], axis=1)
    return RowFriction(
        crank_power=res["power"][:, 0] + bearing_loss,
        frame_power=res["power"][:, 1],
        loss=loss,
        bearing_load=load,
        bearing_speed=np.asarray(rel, dtype=float),
        cam_spin=np.asarray(spin, dtype=float),
        roller=res,
        cam_moment_residual=np.zeros(len(spin)) if resid is None else resid,
    )
