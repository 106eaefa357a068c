"""The running drive at a load torque with friction in every balance: one operating point.

At an output torque ``T`` the drive runs in one of two directions of power
flow, at the same positive speeds (crank ``z + 1``, output 1, ring fixed):

- **forward**: the crank drives, the load resists; the rollers' forces on
  the frame hold ``T`` against the motion;
- **backdriving**: the load drives the output with ``T``; the crank is
  driven (or, self-locking, has to help).

At each position every body is in equilibrium with friction
(:mod:`corr_cad.mechanics.losses.friction`): each roller's forces and moment with
the Coulomb forces of its cam, slot and ring contacts, each cam's moment
with its rollers' friction and its needle bearing's moment, and the crank's
moment as what the cams' bearings pass to it. The normal cam forces are the
elastic solution's (the force solver or the drive model) at a frictionless
torque ``T'`` (windup sign); friction enters the slot and ring forces, the
cam's spin and the crank's moment. ``T'`` is found (Brent's method, to
1e-13 relative) so that the **output torque with friction**, the moment of
the rollers' slot forces (normal and friction) on the frame, averaged over
the cycle, equals the load: ``share T`` on the modelled rows (the paper's
row: its ``load_share``; the drive: 1). Both directions are so solved at
the same output torque. What friction changes in the load sharing between
rollers (the compatibility with the friction-changed slot and ring forces)
is left out, first order in ``mu``.

The powers then follow from the forces alone: the crank's ``M_in (z + 1)``
with ``M_in`` the moment of the cam forces about the crank axis, the
output's ``T_out``, each contact's loss ``|f| |v_slip|`` and the bearing's
``M_b |omega_crank - omega_cam|``. Their balance at every position is a
property of the equilibrium, not of a scaling: ``tests/test_power_flow.py``
recomputes every term from the forces and its own kinematics.

Efficiency over the cycle, energies summed over the positions (constant
speed): forward ``eta = W_out / W_crank``; backdriving ``eta = W_crank,out /
W_out,in``. Forward it is in (0, 1] by the balance (losses >= 0). A
backdriving efficiency at or below 0 means the load cannot turn the crank
alone: **self-locking** at that torque. Where even the smallest
frictionless torque ``T'`` of the backdriving sense leaves the load short of
the friction (the root lies on the forward side), the point is
self-locking without a backdriving state to report. Efficiencies are
``1 - losses / driving power``, exactly 1 without friction.

Load-independent losses (bearing drag, seals, churning) enter as two
moments of the drive, ``drag = (M_in, T_out)``, resisting the crank's and
the output's rotation: the rollers then carry ``T + T_out`` forward and
``T - T_out`` backdriving, and the efficiency counts ``M_in (z + 1) +
T_out`` per unit output speed with the contacts' losses (exact with every
contact coefficient 0: forward ``T / (T + T_out + M_in (z + 1))``).

Units: N, mm; powers per unit output speed (N*mm per rad of output).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from corr_cad.errors import SolverError

__all__ = ["OperatingPoint", "operating_point", "SMALLEST_SHARE"]

#: The smallest frictionless torque the search solves at, a share of the load torque:
#: closer to zero the elastic state of a drive without preload has no stiffness.
SMALLEST_SHARE = 1e-6
#: Relative tolerance of the output torque's match.
_RTOL = 1e-13


@dataclass
class OperatingPoint:
    """One torque in one direction; arrays (P,) over the positions, per unit output speed.

    ``rows`` and ``frictions``: the rows' loads and friction states;
    ``frictionless_torque`` the ``T'`` of their elastic state (N*mm, windup
    sign); ``output_torque`` the rollers' moment on the frame along the
    motion, summed over the rows (N*mm: ``share T`` on average forward,
    ``-share T`` backdriving); ``crank_power``, ``frame_power`` the power
    the crank and the frame put in; ``losses`` (P, 4) cam, slot, ring,
    bearing; ``matched``: False where the search stopped at the smallest
    ``T'`` (self-locking backdriving); ``drag``: the load-independent
    moments ``(at the crank, at the output)`` (N*mm, the drive's, each
    resisting its member's motion) the point was solved with.
    """

    torque: float
    backdriving: bool
    share: float
    frictionless_torque: float
    rows: list
    frictions: list
    output_torque: np.ndarray
    crank_power: np.ndarray
    frame_power: np.ndarray
    losses: np.ndarray
    crank_speed: float
    matched: bool = True
    drag: tuple[float, float] = (0.0, 0.0)

    @property
    def crank_moment(self) -> np.ndarray:
        """The crank's moment on the cams (N*mm, along the crank's motion), (P,)."""
        return self.crank_power / self.crank_speed

    @property
    def efficiency(self) -> float:
        """Over the cycle, ``1 - losses / driving power`` of the drive (by the balance,
        the driven power over the driving); forward in (0, 1]; backdriving <= 0:
        self-locking. The rows' losses count ``1 / share``; the drag moments add
        ``M_in (z + 1) + T_out`` per unit output speed."""
        m_in, t_out = self.drag
        drag = m_in * self.crank_speed + t_out
        loss = float(np.sum(np.mean(self.losses, axis=0))) / self.share + drag
        if self.backdriving:
            driver = float(np.mean(self.frame_power)) / self.share + t_out
        else:
            driver = float(np.mean(self.crank_power)) / self.share + m_in * self.crank_speed
        if driver <= 0.0 or not self.matched:
            if not self.backdriving:
                raise SolverError(f"efficiency: no crank power at {self.torque:g} N*mm")
            return -math.inf
        return 1.0 - loss / driver

    @property
    def balance(self) -> float:
        """Worst ``|P_crank + P_frame - losses| / max(|P_crank|, |P_frame|)`` over the positions."""
        scale = np.maximum(np.maximum(np.abs(self.crank_power), np.abs(self.frame_power)), 1e-300)
        resid = self.crank_power + self.frame_power - np.sum(self.losses, axis=1)
        return float(np.max(np.abs(resid) / scale))


def operating_point(
    evaluate: Callable[[float], tuple[list, list]],
    torque: float,
    backdriving: bool,
    share: float,
    crank_speed: float,
    drag: tuple[float, float] = (0.0, 0.0),
    start: float | None = None,
) -> OperatingPoint:
    """The operating point at load ``torque`` (N*mm, > 0) in one direction.

    ``evaluate(T')`` gives ``(rows, frictions)``: the rows' frictionless
    loads at the windup torque ``T'`` and their friction states (running
    kinematics). ``share``: the part of the torque the rows carry;
    ``crank_speed`` per unit output speed (``z + 1``). ``drag``: load-independent
    moments of the drive ``(M_in at the crank, T_out at the output)``, N*mm,
    each resisting its member's rotation (bearings, seals, churning): the
    rollers then deliver ``T + T_out`` forward and receive ``T - T_out``
    backdriving, and the crank supplies (or loses) ``M_in`` besides.
    ``start``: the ratio ``|T'| / (T +- T_out)`` to start the search from
    (another torque's, where it is nearly the same; default 1).
    """
    T = float(torque)
    if not (math.isfinite(T) and T > 0.0):
        raise SolverError(f"operating point at torque {T!r}: give a finite torque > 0 (N*mm)")
    m_in, t_out = (float(v) for v in drag)
    if not (math.isfinite(m_in) and math.isfinite(t_out) and m_in >= 0.0 and t_out >= 0.0):
        raise SolverError(f"drag = {drag!r}: give two finite moments >= 0 (N*mm)")
    sense = 1.0 if backdriving else -1.0  # the sign of T' in the frictionless state
    drag = (m_in, t_out)
    T_r = T - t_out if backdriving else T + t_out  # what the rollers carry at the output
    if T_r <= 0.0:  # the output's own drag takes the whole load: self-locking
        x = sense * SMALLEST_SHARE * T
        rows, frs = evaluate(x)
        return _point(T, backdriving, share, crank_speed, x, (rows, frs, 0.0), False, drag)
    target = -sense * share * T_r  # mean output torque along the motion
    smallest = SMALLEST_SHARE * T
    cache: dict[float, tuple] = {}

    def state(x: float):
        if x not in cache:
            rows, frs = evaluate(x)
            frame = sum(np.asarray(f.frame_power) for f in frs)
            cache[x] = (rows, frs, float(np.mean(-frame)) - target)
        return cache[x]

    # In u = |T'| the residual g rises (frictionless: g = share (u - T)): bracket from u = T.
    def g(u: float) -> float:
        return -sense * state(sense * u)[2]

    # Secant steps from u = T_r and a Newton step on the frictionless slope: the output
    # torque is nearly linear in T', so three or four evaluations reach the tolerance.
    tol = _RTOL * share * T_r
    a0 = max(T_r * (1.0 if start is None or not start > 0.0 else float(start)), smallest)
    h0 = g(a0)
    a1 = max(a0 - h0 / share, smallest)
    h1 = g(a1) if abs(h0) > tol else h0
    for _ in range(8):
        if abs(h1) <= tol:
            return _point(
                T, backdriving, share, crank_speed, sense * a1, state(sense * a1), True, drag
            )
        if h1 == h0 or (a1 <= smallest and h1 > 0.0):
            break
        a0, h0, a1 = a1, h1, max(a1 - h1 * (a1 - a0) / (h1 - h0), smallest)
        h1 = g(a1)
    # Otherwise a bracket: a Newton step on the frictionless slope, a little long so that
    # it brackets the root; then steps doubling in the same direction, never below the
    # smallest u; then Brent's method.
    u0, g0 = T_r, g(T_r)
    u1 = max(u0 - 1.02 * g0 / share, smallest)
    g1 = g(u1) if g0 != 0.0 else 0.0
    for _ in range(60):
        if g0 == 0.0 or g1 == 0.0 or (g0 > 0.0) != (g1 > 0.0):
            break
        if u1 <= smallest and g1 > 0.0:
            break
        u0, g0, u1 = u1, g1, max(u1 + 2.0 * (u1 - u0), smallest)
        g1 = g(u1)
    if g0 != 0.0 and g1 != 0.0 and (g0 > 0.0) == (g1 > 0.0):
        if backdriving:  # the load cannot overcome the friction at any state: self-locking
            x = sense * u1
            return _point(T, backdriving, share, crank_speed, x, state(x), False, drag)
        raise SolverError(f"operating point at torque {T:g} N*mm: output torque not bracketed")
    u = u0 if g0 == 0.0 else u1
    if g0 != 0.0 and g1 != 0.0:
        from scipy.optimize import brentq

        lo, hi = sorted((u0, u1))
        u = brentq(g, lo, hi, xtol=_RTOL * T_r, rtol=1e-15, maxiter=200)
    return _point(T, backdriving, share, crank_speed, sense * u, state(sense * u), True, drag)


def _point(T, backdriving, share, crank_speed, x, st, matched, drag) -> OperatingPoint:
    rows, frs, _ = st
    crank = sum(np.asarray(f.crank_power) for f in frs)
    frame = sum(np.asarray(f.frame_power) for f in frs)
    losses = sum(np.asarray(f.loss) for f in frs)
    return OperatingPoint(
        torque=T,
        backdriving=backdriving,
        share=share,
        frictionless_torque=float(x),
        rows=rows,
        frictions=frs,
        output_torque=-frame,
        crank_power=crank,
        frame_power=frame,
        losses=losses,
        crank_speed=float(crank_speed),
        matched=matched,
        drag=drag,
    )
