"""Efficiency map and rated life of the drive from per-row, per-position loads.

The inputs are arrays any drive model can give: for each row of rollers,
its crank angles (P,), each roller's frictionless cam, slot (signed) and
ring forces (P, R) and each contact's conformity (:class:`RowLoads`). The
paper's one-row model gives one row (:func:`row_loads_from_forces`; the
other cam is taken as a copy at the modelled share for the life, which is
conservative with ``load_share`` 0.55); a drive model gives its rows.

Forward: the crank drives at positive speed against the output's load;
backdriving: the output drives at the same positive speed. Each is an
operating point with friction in every balance at the same output torque
(:mod:`corr_cad.mechanics.losses.operating`); efficiency over the cycle is the
driven member's energy over the driving member's, exactly 1 when every
coefficient is 0. A backdriving efficiency at or below 0 means the output
cannot drive the crank: the drive is **self-locking** at that torque
(reported as 0, flagged).

Friction is not fed back into the load sharing between rollers (first
order); the windup, the forces and every figure besides the efficiency and
the losses use the frictionless solution. The lives take no friction at
all: frictionless loads and the rolling kinematics' speeds
(:func:`~corr_cad.mechanics.life.rolling_speeds`), so a rating does not
hang on a friction coefficient.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field, replace

import numpy as np

from corr_cad.errors import SolverError
from corr_cad.mechanics.life import (
    BEARING_EXPONENT,
    LifeSpec,
    bearing_life_h,
    equivalent_load,
    raceway_capacity,
    raceway_life_h,
    rolling_speeds,
    system_life_h,
)
from corr_cad.mechanics.losses.friction import (
    Friction,
    RowFriction,
    design_contacts,
    row_friction,
)
from corr_cad.mechanics.losses.operating import operating_point

__all__ = [
    "RowLoads",
    "row_loads_from_forces",
    "rows_from_drive",
    "drive_friction",
    "bearing_loads",
    "drive_life",
    "torque_for_life",
]


@dataclass(frozen=True)
class RowLoads:
    """One row of rollers at P positions: frictionless forces (N) and contact conformity.

    ``crank_angles`` (P,) the eccentric's angle relative to the frame;
    ``cam_force``, ``slot_force`` (signed: ``> 0`` pushes the frame
    forwards), ``ring_force`` (P, R); ``conformity_cam``,
    ``conformity_ring`` (P, R) ``= 2 R*/D = 1 / (1 + r k)``;
    ``bearing_load`` (P,) the load a drive model solved for this row's
    eccentric bearing (None: the friction model's resultant is rated).
    """

    crank_angles: np.ndarray
    cam_force: np.ndarray
    slot_force: np.ndarray
    ring_force: np.ndarray
    conformity_cam: np.ndarray
    conformity_ring: np.ndarray
    bearing_load: np.ndarray | None = None


def row_loads_from_forces(design, res) -> RowLoads:
    """The :class:`RowLoads` of a force result of the paper's one-row model."""
    g = res.geometry
    r = design.roller_radius
    return RowLoads(
        crank_angles=np.asarray(res.crank_angles, dtype=float),
        cam_force=res.F_j,
        slot_force=res.F_s,
        ring_force=res.F_n,
        conformity_cam=np.broadcast_to(1.0 / (1.0 + r * g.k_cam), res.F_j.shape),
        conformity_ring=1.0 / (1.0 + r * g.k_gear),
    )


def rows_from_drive(design, drive) -> list[RowLoads]:
    """The :class:`RowLoads` of every row of a two-row drive result.

    ``drive`` has ``rows``, one force result per row with its own crank
    angles (row B's ``phi + pi`` and its phase) and geometry, as
    ``corr_cad.mechanics.drive.drive.DriveResult`` gives them. Each row carries
    its cam's ``bearing_load`` (the drive's frictionless ``|sum F_j n_k|``,
    as ``forces.csv`` writes it), which the bearing's life rates (a result
    without ``bearing_load``: the friction model's resultant).
    """
    loads = getattr(drive, "bearing_load", None)
    if loads is None:  # rows alone: the friction model's resultant is rated
        loads = [None] * len(drive.rows)
    return [
        replace(row_loads_from_forces(design, r), bearing_load=load)
        for r, load in zip(drive.rows, loads, strict=True)
    ]


def drive_friction(design, rows: list[RowLoads], friction: Friction) -> list[RowFriction]:
    """:func:`~corr_cad.mechanics.losses.friction.row_friction` of every row (running
    kinematics)."""
    out = []
    for row in rows:
        c = design_contacts(design, row.crank_angles, row.slot_force)
        out.append(row_friction(c, row.cam_force, friction))
    return out


def bearing_loads(design, row: RowLoads) -> np.ndarray:
    """The load on a row's eccentric bearing at each position, N (P,), without friction.

    The drive model's own ``bearing_load`` where it gives one; else the
    rollers' frictionless resultant ``|sum F_j n_k|`` (``n_k`` from the cam
    centre to roller ``k``'s centre).
    """
    if row.bearing_load is not None:
        return np.asarray(row.bearing_load, dtype=float)
    c = design_contacts(design, row.crank_angles, row.slot_force)
    push = np.einsum("pk,pkx->px", np.asarray(row.cam_force, dtype=float), -c.d[:, :, 0])
    return np.linalg.norm(push, axis=1)


def drive_life(
    design,
    rows: list[RowLoads],
    spec: LifeSpec,
    mounting: str,
    output_rpm: float,
    spec_b: LifeSpec | None = None,
) -> dict:
    """L10 in hours of every component at ``output_rpm``, and of the system.

    Per row: its eccentric bearing (ISO 281, mounting ``"bearing"`` only),
    its cam raceway and its ring raceway (Lundberg-Palmgren line contact).
    Loads without friction (:func:`bearing_loads`), speeds from the rolling
    kinematics (:func:`~corr_cad.mechanics.life.rolling_speeds`): no
    friction coefficient enters a life. ``spec_b`` rates the second row's
    bearing (default ``spec``).
    """
    ratings = [spec.rating()[0], (spec_b or spec).rating()[0]]
    R = design.roller_count
    r, L, length = design.roller_radius, design.link_length, design.roller_length
    gamma = r / L
    speeds = rolling_speeds(design, mounting)
    lives: dict[str, float] = {}
    for i, row in enumerate(rows):
        tag = f"row{i + 1}"
        if mounting == "bearing":
            load = bearing_loads(design, row)
            lives[f"bearing_{tag}"] = bearing_life_h(
                ratings[min(i, 1)], load, np.full(len(load), speeds["bearing"]), output_rpm
            )
        q_cam = raceway_capacity(row.conformity_cam, False, R, 2.0 * r, length, gamma)
        q_ring = raceway_capacity(row.conformity_ring, True, R, 2.0 * r, length, gamma)
        lives[f"cam_{tag}"] = raceway_life_h(
            row.cam_force, q_cam, speeds["cam"], output_rpm, stationary_load=mounting == "fixed"
        )
        lives[f"ring_{tag}"] = raceway_life_h(
            row.ring_force, q_ring, speeds["ring"], output_rpm, stationary_load=False
        )
    lives["system"] = system_life_h([v for v in lives.values()])
    return lives


class LifeNotBracketed(SolverError):
    """No torque within 2^60 of the start gives the target life."""


def torque_for_life(life_at: Callable[[float], float], target_h: float, start: float) -> float:
    """The torque (same units as ``start``) at which ``life_at`` equals ``target_h``.

    The life falls with the torque; root of ``log(life) - log(target)`` in
    ``log T`` by Brent's method to 1e-10, bracketed from ``start`` by factors
    of 2.
    """
    from scipy.optimize import brentq

    def f(u: float) -> float:
        L = life_at(math.exp(u))
        if not math.isfinite(L):
            return 50.0
        return math.log(L) - math.log(target_h) if L > 0.0 else -50.0  # 0: underflow

    lo = hi = math.log(start)
    f_lo = f_hi = f(lo)
    for _ in range(60):
        if f_hi <= 0.0:
            break
        hi += math.log(2.0)
        f_hi = f(hi)
    for _ in range(60):
        if f_lo >= 0.0:
            break
        lo -= math.log(2.0)
        f_lo = f(lo)
    if f_lo < 0.0 or f_hi > 0.0:
        raise LifeNotBracketed(
            f"rated torque from life: no output torque from {math.exp(lo):.3g} to "
            f"{math.exp(hi):.3g} N*mm gives an L10 of {target_h:g} h"
        )
    if f_lo == 0.0:
        return math.exp(lo)
    return math.exp(brentq(f, lo, hi, xtol=1e-12, rtol=1e-10))


@dataclass
class FrictionFigures:
    """The efficiency map and the lives of a drive (catalogue units in :meth:`figures`).

    ``shares`` (S,) output torques as shares of T_R; ``forward``,
    ``backdriving`` (S,) efficiencies over the cycle; ``losses_forward``,
    ``losses_backdriving`` (S, 4) cam, slot, ring and bearing losses per
    unit output speed (N*mm per rad); ``input_power``, ``output_power``
    (S,) the crank's and the output's forward power per unit output speed,
    of the modelled row (the files scale them to the drive's output torque);
    ``balance`` the worst power
    balance residual (relative) over every position of the map.
    """

    rated_torque: float
    shares: np.ndarray
    speeds_rpm: np.ndarray
    forward: np.ndarray
    backdriving: np.ndarray
    losses_forward: np.ndarray
    losses_backdriving: np.ndarray
    input_power: np.ndarray
    output_power: np.ndarray
    balance: float
    friction: Friction
    ratio: float
    lives: dict | None = None
    rated_torque_from_life: float | None = None
    life_spec: LifeSpec | None = None
    rating_source: str = ""
    lives_at_rated_from_life: dict | None = None
    #: :func:`corr_cad.mechanics.losses.hysteresis.hysteresis_figures`, when computed.
    hysteresis: dict | None = None
    #: ``[thermal]``: housing area m^2, heat transfer W/(m^2 K), temperature rise K.
    thermal: tuple[float, float, float] | None = None
    #: Row 1's eccentric bearing at T_R: equivalent load and relative speed.
    bearing: dict | None = None
    #: Row 2's, when a drive model gives both rows.
    bearing_b: dict | None = None
    #: Which force model the figures come from, as ``datasheet.json`` states it
    #: (``friction["forces"]``; empty: not stated, the paper's row).
    source: str = ""
    #: The part of the torque the modelled rows carry (the paper's row: load_share).
    share: float = 1.0
    #: The operating points (forward, backdriving) behind each torque.
    points: list | None = field(default=None, repr=False)

    def drive_losses(self) -> np.ndarray:
        """The drive's forward losses per radian of output at each torque, N*mm (S,).

        The modelled rows' losses over their share of the torque (as in
        ``efficiency.csv``).
        """
        return self.losses_forward.sum(axis=1) / self.share

    def self_locking_shares(self) -> list[float]:
        return [float(s) for s, e in zip(self.shares, self.backdriving, strict=True) if e <= 0.0]

    def self_locking_range_Nm(self) -> list[float] | None:
        """``[lowest, highest]`` output torque (N*m) of the map that self-locks, or None."""
        locked = self.self_locking_shares()
        if not locked:
            return None
        T = self.rated_torque / 1000.0
        return [min(locked) * T, max(locked) * T]

    def check_values(self) -> dict[str, float]:
        out = {"efficiency": float(np.min(self.forward))}
        if self.lives is not None:
            out["life_h"] = float(self.lives["system"])
        return out

    def figures(self) -> dict:
        def stats(v):
            v = np.asarray(v, dtype=float)
            return {"min": float(v.min()), "mean": float(v.mean()), "max": float(v.max())}

        fr = self.friction
        out = {
            "efficiency_forward": {
                **stats(self.forward),
                "definition": "1 - losses / crank power over one cycle, crank driving, the "
                "rollers' moment on the output (with friction) equal to the load torque",
            },
            "efficiency_backdriving": {
                **stats(self.backdriving),
                "definition": "1 - losses / output power over one cycle, output driving at the "
                "same output torque; 0 where self-locking (the load cannot turn the crank)",
                "self_locking": bool(self.self_locking_shares()),
                "self_locking_torque_shares": self.self_locking_shares(),
                "self_locking_torque_range_Nm": self.self_locking_range_Nm(),
            },
            "friction": {
                "mu_cam": fr.mu_cam,
                "mu_slot": fr.mu_slot,
                "mu_ring": fr.mu_ring,
                "mu_bearing": fr.mu_bearing,
                "cam_mounting": fr.mounting,
                "bearing_bore_mm": fr.bearing_diameter,
                "model": "Coulomb in every balance (each roller, each cam with its needle "
                "bearing's 0.5 mu P d, the crank), both directions at the same output torque "
                "(the rollers' moment on the output with friction, its mean over the cycle); "
                "the normal forces' sharing between rollers frictionless (first order); "
                "efficiency independent of speed",
                "power_balance_relative": self.balance,
                **({"forces": self.source} if self.source else {}),
            },
        }
        if self.hysteresis is not None:
            h = self.hysteresis
            arcmin = 10800.0 / math.pi
            out["hysteresis_loss_arcmin"] = float(np.max(h["loss"]) * arcmin)
            out["hysteresis_loss_note"] = (
                "computed from friction (first order): the loop's width at zero torque beyond "
                "the backlash, maximum over the positions; zero without a preload (Coulomb "
                "friction vanishes with the contact forces)"
            )
            out["hysteresis_loss_stats_arcmin"] = stats(h["loss"] * arcmin)
            out["hysteresis_width_at_rated_arcmin"] = {
                **stats(h["width_at_rated"] * arcmin),
                "definition": "loading minus unloading branch at +-T_R, mean of both signs",
            }
            out["starting_torque_Nm"] = {
                **stats(h["starting_torque"] / 1000.0),
                "definition": "input torque to turn the drive at no output load (preload "
                "and friction; no seal model)",
            }
            out["backdriving_torque_Nm"] = {
                **stats(h["backdriving_torque"] / 1000.0),
                "definition": "output torque to turn the drive from the output at no input load",
            }
        if self.thermal is not None:
            from corr_cad.mechanics.losses.thermal import thermal_speed_rpm

            area, k, rise = self.thermal
            n = thermal_speed_rpm(self.drive_losses(), self.ratio, area, k, rise)
            out["thermal_limit"] = {
                "input_speed_rpm": [_finite(v) for v in n],
                "output_torque_Nm": [float(v) for v in self.shares * self.rated_torque / 1000.0],
                "heat_dissipated_W": area * k * rise,
                "housing_area_m2": area,
                "heat_transfer_W_per_m2K": k,
                "max_temperature_rise_K": rise,
                "definition": "input speed at which the losses equal k A dT (ISO/TR 14179-1 "
                "style heat balance); load-independent losses (churning, seals) are not "
                "modelled, so it is an upper bound and no-load heating is not predicted",
            }
        if self.lives is not None:
            sp = self.life_spec
            out["life_h"] = {
                **{k: _finite(v) for k, v in self.lives.items()},
                "at_torque_Nm": self.rated_torque / 1000.0,
                "at_output_speed_rpm": sp.rated_speed_rpm,
                "definition": "L10 (90 % reliability); system: Weibull combination, slope 9/8",
            }
            out["rated_torque_from_life_Nm"] = {
                "value": None
                if self.rated_torque_from_life is None
                else self.rated_torque_from_life / 1000.0,
                "rated_life_h": sp.rated_life_h,
                "rated_speed_rpm": sp.rated_speed_rpm,
                "bearing_rating_N": sp.rating()[0],
                "bearing_at_rated_torque": self.bearing,
                **(
                    {"bearing_b_at_rated_torque": self.bearing_b}
                    if self.bearing_b is not None
                    else {}
                ),
                "bearing_rating_source": self.rating_source,
                "definition": "output torque at which the system L10 is rated_life_h at "
                "rated_speed_rpm",
            }
        return out


def _finite(v: float):
    return float(v) if math.isfinite(v) else None


def friction_figures(
    design,
    windup,
    rated_torque: float,
    friction: Friction,
    shares,
    speeds_rpm,
    life: LifeSpec | None = None,
    rows: int = 2,
    rows_at: Callable[[float], list[RowLoads]] | None = None,
    life_b: LifeSpec | None = None,
) -> FrictionFigures:
    """Efficiency map and lives at the windup's positions.

    ``windup`` a :class:`~corr_cad.mechanics.row.windup.Windup` (its positions
    and load share) of the paper's one-row model; ``rated_torque`` T_R,
    N*mm. The efficiency is one value per torque (Coulomb losses grow with
    speed as the power does); the map repeats it per speed. Lives at T_R
    and ``life.rated_speed_rpm``, with ``rows`` cams alike (the paper's
    model solves one at ``load_share``). A drive model passes ``rows_at``
    instead: the rows' loads at an output torque (N*mm, windup sign), e.g.
    :func:`rows_from_drive` of its solution; its rows are then taken as
    they are (``windup`` unused), each bearing rated on the row's
    ``bearing_load``; ``life_b`` then rates the second row's bearing.
    """
    shares = np.asarray(shares, dtype=float)
    given = rows_at is not None
    if rows_at is None:

        def rows_at(T: float) -> list[RowLoads]:
            return [row_loads_from_forces(design, windup.forces(T))]

    share = 1.0 if given else float(windup.load_share)

    def evaluate(T: float):
        rows = rows_at(T)
        return rows, drive_friction(design, rows, friction)

    points = []
    ratio = {False: None, True: None}  # |T'| / T of the last matched point: the next start
    for s in shares:
        T = s * rated_torque
        pair = []
        for b in (False, True):
            p = operating_point(evaluate, T, b, share, design.roller_count, start=ratio[b])
            if p.matched:
                ratio[b] = abs(p.frictionless_torque) / T
            pair.append(p)
        points.append(tuple(pair))
    fwd = [f.efficiency for f, _ in points]
    back = [max(b.efficiency, 0.0) for _, b in points]
    out = FrictionFigures(
        rated_torque=rated_torque,
        shares=shares,
        speeds_rpm=np.asarray(speeds_rpm, dtype=float),
        forward=np.array(fwd),
        backdriving=np.array(back),
        losses_forward=np.array([np.mean(f.losses, axis=0) for f, _ in points]),
        losses_backdriving=np.array([np.mean(b.losses, axis=0) for _, b in points]),
        input_power=np.array([np.mean(f.crank_power) for f, _ in points]),
        output_power=np.array([np.mean(f.output_torque) for f, _ in points]),
        balance=max(max(f.balance, b.balance) for f, b in points),
        friction=friction,
        ratio=float(design.roller_count),
        share=share,
        points=points,
    )
    if life is not None:

        def lives_at(T: float) -> dict:
            r = rows_at(-T) if given else rows_at(-T) * rows
            return drive_life(
                design, r, life, friction.mounting, life.rated_speed_rpm, spec_b=life_b
            )

        out.lives = lives_at(rated_torque)
        out.life_spec = life
        if friction.mounting == "bearing":
            at_rated = rows_at(-rated_torque)
            out.bearing = _bearing_figure(design, at_rated[0], life, "row 1's")
            if given and len(at_rated) > 1:
                out.bearing_b = _bearing_figure(design, at_rated[1], life, "row 2's")
        out.rating_source = life.rating()[1]
        out.rated_torque_from_life = torque_for_life(
            lambda T: lives_at(T)["system"], life.rated_life_h, rated_torque
        )
        out.lives_at_rated_from_life = lives_at(out.rated_torque_from_life)
    return out


def _bearing_figure(design, row: RowLoads, life: LifeSpec, which: str) -> dict:
    """A row's eccentric bearing at T_R: ISO 281 equivalent load and relative speed."""
    load = bearing_loads(design, row)
    speed = rolling_speeds(design, "bearing")["bearing"]
    return {
        "equivalent_load_N": equivalent_load(load, np.ones(len(load)), BEARING_EXPONENT),
        "relative_speed_rpm": speed * life.rated_speed_rpm,
        "definition": f"{which} eccentric bearing at T_R and rated_speed_rpm: "
        "ISO 281 equivalent load (exponent 10/3) without friction and the relative speed of "
        "the rolling kinematics (crank less the cam's spin 2 L / R_j, ring fixed, frame as "
        "cage); L10 = (C/P)^(10/3) 1e6 / (60 n)",
    }
