"""Hysteresis loss and starting torque from friction, first order.

The bench
---------
The catalogues' hysteresis curve is measured with the input (crank) locked,
the ring fixed, the output turned by an output torque. Turning the output
by ``d theta`` carries every roller with its slot past the cam and the ring
(tangentially ``s d theta``) and moves it along the slot by the elastic
change of its cam contact, ``d u = (-(z x O1) . n - d delta_cam) / (n . u_r)``
with ``n`` the cam normal and ``delta_cam = 2 F_j / (pi l E')`` the cam
contact's approach to first order in the Hertz half-width (the sum of the
two bodies' sagittas of the solver's contact law). Each roller's spin and
its sliding contacts follow from its moment balance as in running
(:mod:`corr_cad.mechanics.losses.friction`); a floating cam's spin from its own.

Friction dissipates ``D`` per unit output rotation (N*mm per rad): the
loading branch needs ``T = T_e(theta) + D``, the unloading branch
``T = T_e(theta) - D``, with ``T_e`` the frictionless windup's torque and
``D`` evaluated on the frictionless state (first order). At zero torque the
two branches stand ``D0 / K0`` either side of the frictionless curve
(``K0 = dT/d theta`` there), so the **hysteresis loss**, the loop's width
at zero torque beyond the backlash, is ``D0(0+) / K0(0+) + D0(0-) / K0(0-)``.
Coulomb friction is proportional to the contact forces: without a preload
(no force at zero torque) ``D0 = 0`` and the loss is zero; the loop then
opens only under load (``hysteresis_width_at_rated``). Positions with free
play at zero torque (the windup's ``slack``) take ``D0 = 0`` as it stands,
with no solve at the small torques; the rest are solved alone.

Under the drive model (``[solver] model = "drive"``) the bench is the
drive's own: both rows' rollers, each row at its own crank angles, against
the drive's windup stiffness; no share or cam count is applied. A cam
floating on its bearing moves with the bearing's deflection; that motion is
not in the rollers' slide along their slots (first order).

The loop
--------
:func:`hysteresis_loop` draws the loop itself: at every torque level of the
datasheet's curve, the branch of a rising torque (-T_R to +T_R, the
loading branch above) stands ``D(T) / K(T)`` below the frictionless
windup and the branch of a falling torque as far above it (``D`` per
unit rotation at the contacts and ``K`` the contacts' stiffness, so a
compliance in series moves both branches alike and leaves the width as it
is). At zero torque each branch keeps the side it arrives from: rising
``D0(0-) / K0(0-)``, falling ``D0(0+) / K0(0+)``, whose sum is the
hysteresis loss.

Starting torque
---------------
The crank moment that starts the drive at no output load: the running
losses at zero torque per unit crank rotation, ``losses(0) / (z + 1)``
per unit output speed; the backdriving torque, the output moment that
starts it from the output, ``losses(0)``.
Without a preload (a modification that clears, no bearing preload, no seal
model) it is zero.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from corr_cad.mechanics.contact import linear_compliance
from corr_cad.mechanics.losses.efficiency import drive_friction, row_loads_from_forces
from corr_cad.mechanics.losses.friction import Friction, design_contacts, row_friction

__all__ = ["bench_dissipation", "hysteresis_figures", "hysteresis_loop"]

#: Relative torque step of the finite differences (share of T_R).
_STEP = 1e-3
#: "Zero" torque of a preloaded drive's force state (share of T_R).
_ZERO = 1e-9


def _at_zero(at_1: np.ndarray, at_2: np.ndarray) -> np.ndarray:
    """Extrapolate to zero torque from torques 1 and 2 (units of ``_ZERO``): ``2 D1 - D2``.

    A part proportional to the torque cancels; what stays is the preload's
    (about ``D1`` itself). Below 1e-3 of ``D1`` it is what that cancellation
    leaves of a part that vanishes with the torque: rounding, or a force
    share that is not exactly linear at vanishing load (the Palmgren needles
    of the drive's bearings leave a few 1e-6): zero.
    """
    d0 = 2.0 * at_1 - at_2
    return np.where(d0 > 1e-3 * np.abs(at_1), d0, 0.0)


def _preloaded(windup):
    """The positions where a contact carries a force at zero torque, bool (P,), and the
    bench at those alone (None where there are none).

    Elsewhere the drive has free play (:meth:`slack`): no force at zero torque, so
    no dissipation and no running loss there, and no solve at the tiny torques
    (where every contact law starts from zero stiffness and the cams float).
    """
    keep = ~windup.slack()
    if not np.any(keep):
        return keep, None
    return keep, (windup if np.all(keep) else windup.at(keep))


def _width_at_zero(design, windup, zero: float, step: float, friction: Friction) -> dict:
    """``D0 / K0`` on either side of zero torque (keys +1.0 and -1.0), rad (P,) each.

    ``D0`` extrapolated from two small torques (Richardson): the part
    proportional to the torque drops out, the preload's stays; zero with free play.
    """
    keep, bench = _preloaded(windup)
    out = {}
    for s in (1.0, -1.0):
        out[s] = np.zeros(len(keep))
        if bench is not None:
            D1, K = bench_dissipation(design, bench, s * zero, step, friction)
            D2, _ = bench_dissipation(design, bench, 2.0 * s * zero, step, friction)
            out[s][keep] = _at_zero(D1, D2) / K
    return out


def _rows(res) -> tuple:
    """The per-row force results: a drive result's rows, or the one row itself."""
    return tuple(getattr(res, "rows", None) or (res,))


def bench_dissipation(design, windup, torque: float, step: float, friction: Friction):
    """Friction dissipation per unit output rotation on the locked-input bench, (P,) N*mm/rad.

    Of the modelled row (the caller scales it to the drive), or of both
    rows summed for a drive model's windup (its ``forces`` give ``rows``,
    each at its own crank angles); also returns the windup's stiffness
    ``dT/d theta`` (P,) N*mm/rad there, by central differences over
    ``torque +- step`` (one-sided at a sign change of the torque).
    """
    lo, hi = torque - step, torque + step
    if torque > 0.0 and lo <= 0.0:
        lo = torque
    if torque < 0.0 and hi >= 0.0:
        hi = torque
    th_lo, th_hi = windup.contact_theta(lo), windup.contact_theta(hi)
    dth = th_hi - th_lo
    stiffness = (hi - lo) / dth
    parts = zip(
        _rows(windup.forces(torque)),
        _rows(windup.forces(lo)),
        _rows(windup.forces(hi)),
        strict=True,
    )
    total = np.zeros(len(dth))
    for res, r_lo, r_hi in parts:
        total = total + _row_dissipation(
            design, res, (r_hi.F_j - r_lo.F_j) / dth[:, None], friction
        )
    return total, stiffness


def _row_dissipation(design, res, dF: np.ndarray, friction: Friction) -> np.ndarray:
    """One row's dissipation per unit output rotation, its cam forces changing by ``dF``."""
    ddelta = dF * linear_compliance(design.roller_length, design.material.contact_modulus)
    c = design_contacts(design, res.crank_angles, res.F_s, crank_speed=0.0)
    n = -c.d[:, :, 0]  # cam centre -> roller centre
    ur = c.centre / np.linalg.norm(c.centre, axis=-1, keepdims=True)
    o1 = c.cam_centre[:, None, :]
    z_o1 = np.stack([-o1[..., 1], o1[..., 0]], axis=-1)
    du = (-np.sum(z_o1 * n, axis=-1) - ddelta) / np.sum(n * ur, axis=-1)
    z_h = np.stack([-c.centre[..., 1], c.centre[..., 0]], axis=-1)
    c = replace(c, centre_velocity=z_h + du[..., None] * ur)
    return row_friction(c, res.F_j, friction).total_loss


def hysteresis_figures(
    design, windup, rated_torque: float, friction: Friction, rows: int = 2
) -> dict:
    """Hysteresis loss, the loop's width at T_R and the starting torques, per position.

    ``windup`` the paper's one-row :class:`~corr_cad.mechanics.row.windup.Windup`
    (its row stands for ``rows`` cams, at ``load_share`` under load) or a
    drive model's windup, whose two rows are summed as they are.

    Returns arrays (P,) in rad (``loss``, ``width_at_rated``) and N*mm
    (``starting_torque`` at the input, ``backdriving_torque`` at the output).
    """
    step = _STEP * rated_torque
    zero = _ZERO * rated_torque
    out = {}
    # At zero torque the forces are the preload, alike in both cams (rows = 2); under
    # load the modelled cam carries load_share of the torque. A drive model's windup
    # (no load_share) solves both rows: its dissipation is the drive's as it is.
    share = getattr(windup, "load_share", None)
    if share is None:
        rows, share = 1, 1.0
    at_zero = _width_at_zero(design, windup, zero, step, friction)
    out["loss"] = rows * (at_zero[1.0] + at_zero[-1.0])
    w = np.zeros(len(windup.output_angles))
    for s in (1.0, -1.0):
        D, K = bench_dissipation(design, windup, s * rated_torque, step, friction)
        w = w + 2.0 * D / share / K
    out["width_at_rated"] = 0.5 * w

    # Running at no load: the preload forces, crank driving (forward) and output driving,
    # extrapolated to zero torque like D0; zero with free play.
    keep, bench = _preloaded(windup)

    def loss(T: float) -> np.ndarray:
        loads = [row_loads_from_forces(design, r) for r in _rows(bench.forces(T))]
        return sum(fr.total_loss for fr in drive_friction(design, loads, friction))

    out["starting_torque"] = np.zeros(len(keep))
    out["backdriving_torque"] = np.zeros(len(keep))
    if bench is not None:
        f0 = _at_zero(loss(-zero), loss(-2.0 * zero))
        b0 = _at_zero(loss(zero), loss(2.0 * zero))
        out["starting_torque"][keep] = rows * f0 / float(design.roller_count)
        out["backdriving_torque"][keep] = rows * b0
    return out


def hysteresis_loop(
    design, windup, torques: np.ndarray, rated_torque: float, friction: Friction, rows: int = 2
) -> dict:
    """The loop's branches about the frictionless windup at each torque level, per position.

    ``torques`` (L,) N*mm, the datasheet's levels (``-0.0`` and ``+0.0`` for
    zero torque from either side); ``windup`` as for :func:`hysteresis_figures`,
    with the same scaling to the drive. Returns ``rising`` and ``falling``
    (L, P) rad, the distances of each branch from the frictionless curve
    (the branch of a rising torque at ``theta(T) - rising``, of a falling
    torque at ``theta(T) + falling``; both zero with ``mu = 0``).
    """
    step = _STEP * rated_torque
    zero = _ZERO * rated_torque
    share = getattr(windup, "load_share", None)
    if share is None:
        rows, share = 1, 1.0
    at_zero = {s: rows * w for s, w in _width_at_zero(design, windup, zero, step, friction).items()}
    T = np.asarray(torques, dtype=float)
    P = len(windup.output_angles)
    rising, falling = np.zeros((len(T), P)), np.zeros((len(T), P))
    for i, t in enumerate(T):
        if abs(t) <= zero:
            rising[i], falling[i] = at_zero[-1.0], at_zero[1.0]
            continue
        D, K = bench_dissipation(design, windup, float(t), step, friction)
        rising[i] = falling[i] = D / share / K
    return {"rising": rising, "falling": falling}
