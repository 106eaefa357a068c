"""Efficiency map and rated life of the drive from per-row, per-position loads.

The inputs are arrays any drive model can give: for each row of rollers,
its crank angles (P,), each roller's frictionless cam, slot (signed) and
ring forces (P, R) and each contact's conformity (:class:`RowLoads`). The
paper's one-row model gives one row (:func:`row_loads_from_forces`; the
other cam is taken as a copy at the modelled share for the life, which is
conservative with ``load_share`` 0.55); a drive model gives its rows.

Forward: the crank drives at positive speed against the output's load
(windup convention: output torque ``-T``). Backdriving: the output drives
at the same positive speed (output torque ``+T``). Efficiency over the
cycle is ``1 - (sum of losses) / (power of the driving member)``, energies
summed over the positions, so it is exactly 1 when every coefficient is 0.
A backdriving efficiency at or below 0 means the output cannot drive the
crank: the drive is **self-locking** at that torque (reported as 0 where
the output would deliver no power at all).

Friction is not fed back into the load sharing (first order, see
:mod:`corr_cad.mechanics.friction`); the windup, the forces, the lives and
every figure besides the efficiency and the losses use the frictionless
solution.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, replace

import numpy as np

from corr_cad.errors import SolverError
from corr_cad.mechanics.friction import Friction, RowFriction, row_contacts, row_friction
from corr_cad.mechanics.life import (
    BEARING_EXPONENT,
    LifeSpec,
    bearing_life_h,
    equivalent_load,
    raceway_capacity,
    raceway_life_h,
    system_life_h,
)

__all__ = [
    "RowLoads",
    "row_loads_from_forces",
    "rows_from_drive",
    "drive_friction",
    "cycle_efficiency",
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
    ``corr_cad.mechanics.drive.DriveResult`` gives them. Each row carries
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
    """:func:`~corr_cad.mechanics.friction.row_friction` of every row (running kinematics)."""
    out = []
    for row in rows:
        c = row_contacts(
            design.tooth_count,
            design.eccentricity,
            design.cam_radius,
            design.roller_radius,
            row.crank_angles,
            row.slot_force,
        )
        out.append(row_friction(c, row.cam_force, friction))
    return out


def cycle_efficiency(rows: list[RowFriction], backdriving: bool) -> dict:
    """Efficiency over the cycle and the losses by kind (per unit output speed).

    Returns ``efficiency``, ``driver_power`` (N*mm per rad of output, summed
    over the positions and rows, divided by the positions), ``losses``
    (cam, slot, ring, bearing, same units), ``balance`` the largest
    ``|P_crank + P_frame - losses| / |P_driver|`` over the positions.
    """
    crank = sum(np.asarray(r.crank_power) for r in rows)
    frame = sum(np.asarray(r.frame_power) for r in rows)
    loss = sum(np.asarray(r.loss) for r in rows)
    driver = frame if backdriving else crank
    n = len(crank)
    total_driver = float(np.sum(driver)) / n
    losses = np.sum(loss, axis=0) / n
    if total_driver <= 0.0:
        if not backdriving:
            raise SolverError("efficiency: the crank delivers no power at this torque")
        # The output would have to be driven too: self-locking, reported as 0.
        eta = 0.0
    else:
        eta = 1.0 - float(np.sum(losses)) / total_driver
    scale = np.maximum(np.maximum(np.abs(crank), np.abs(frame)), 1e-300)
    balance = float(np.max(np.abs(crank + frame - np.sum(loss, axis=1)) / scale))
    return {
        "efficiency": eta,
        "driver_power": total_driver,
        "losses": {
            k: float(v) for k, v in zip(("cam", "slot", "ring", "bearing"), losses, strict=True)
        },
        "balance": balance,
    }


def drive_life(
    design,
    rows: list[RowLoads],
    frictions: list[RowFriction],
    spec: LifeSpec,
    mounting: str,
    output_rpm: float,
    spec_b: LifeSpec | None = None,
) -> dict:
    """L10 in hours of every component at ``output_rpm``, and of the system.

    Per row: its eccentric bearing (ISO 281, mounting ``"bearing"`` only),
    its cam raceway and its ring raceway (Lundberg-Palmgren line contact).
    The bearing's load is the row's ``bearing_load`` where the drive model
    gives it, else the friction model's resultant; ``spec_b`` rates the
    second row's bearing (default ``spec``).
    """
    ratings = [spec.rating()[0], (spec_b or spec).rating()[0]]
    R = design.roller_count
    r, L, length = design.roller_radius, design.link_length, design.roller_length
    gamma = r / L
    lives: dict[str, float] = {}
    for i, (row, fr) in enumerate(zip(rows, frictions, strict=True)):
        tag = f"row{i + 1}"
        if mounting == "bearing":
            load = fr.bearing_load if row.bearing_load is None else row.bearing_load
            lives[f"bearing_{tag}"] = bearing_life_h(
                ratings[min(i, 1)], load, fr.bearing_speed, output_rpm
            )
        q_cam = raceway_capacity(row.conformity_cam, False, R, 2.0 * r, length, gamma)
        q_ring = raceway_capacity(row.conformity_ring, True, R, 2.0 * r, length, gamma)
        cam_speed = float(np.mean(np.abs(fr.cam_spin - 1.0)))
        lives[f"cam_{tag}"] = raceway_life_h(
            row.cam_force, q_cam, cam_speed, output_rpm, stationary_load=mounting == "fixed"
        )
        lives[f"ring_{tag}"] = raceway_life_h(
            row.ring_force, q_ring, 1.0, output_rpm, stationary_load=False
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
    #: :func:`corr_cad.mechanics.hysteresis.hysteresis_figures`, when computed.
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

    def drive_losses(self) -> np.ndarray:
        """The drive's forward losses per radian of output at each torque, N*mm (S,).

        The modelled row's losses scaled so that its output power is the
        drive's ``T`` per radian (as in ``efficiency.csv``).
        """
        k = self.shares * self.rated_torque / self.output_power
        return self.losses_forward.sum(axis=1) * k

    def self_locking_shares(self) -> list[float]:
        return [float(s) for s, e in zip(self.shares, self.backdriving, strict=True) if e <= 0.0]

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
                "definition": "1 - losses / crank power over one cycle, crank driving",
            },
            "efficiency_backdriving": {
                **stats(self.backdriving),
                "definition": "1 - losses / output power over one cycle, output driving",
                "self_locking": bool(self.self_locking_shares()),
                "self_locking_torque_shares": self.self_locking_shares(),
            },
            "friction": {
                "mu_cam": fr.mu_cam,
                "mu_slot": fr.mu_slot,
                "mu_ring": fr.mu_ring,
                "mu_bearing": fr.mu_bearing,
                "cam_mounting": fr.mounting,
                "bearing_bore_mm": fr.bearing_diameter,
                "model": "Coulomb, first order: frictionless load sharing, friction in each "
                "roller's and the cam's own balance; efficiency independent of speed",
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
            from corr_cad.mechanics.thermal import thermal_speed_rpm

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

    ``windup`` a :class:`~corr_cad.mechanics.windup.Windup` (its positions
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

    fwd, back, lf, lb, pin, pout = [], [], [], [], [], []
    balance = 0.0
    for s in shares:
        T = s * rated_torque
        f_rows = rows_at(-T)
        e_f = cycle_efficiency(drive_friction(design, f_rows, friction), False)
        e_b = cycle_efficiency(drive_friction(design, rows_at(T), friction), True)
        fwd.append(e_f["efficiency"])
        back.append(e_b["efficiency"])
        lf.append(list(e_f["losses"].values()))
        lb.append(list(e_b["losses"].values()))
        pin.append(e_f["driver_power"])
        pout.append(e_f["driver_power"] - sum(e_f["losses"].values()))
        balance = max(balance, e_f["balance"], e_b["balance"])
    out = FrictionFigures(
        rated_torque=rated_torque,
        shares=shares,
        speeds_rpm=np.asarray(speeds_rpm, dtype=float),
        forward=np.array(fwd),
        backdriving=np.array(back),
        losses_forward=np.array(lf),
        losses_backdriving=np.array(lb),
        input_power=np.array(pin),
        output_power=np.array(pout),
        balance=balance,
        friction=friction,
        ratio=float(design.roller_count),
    )
    if life is not None:

        def lives_at(T: float) -> dict:
            if given:
                r = rows_at(-T)
                fr = drive_friction(design, r, friction)
            else:
                r = rows_at(-T) * rows
                fr = drive_friction(design, r[:1], friction) * rows
            return drive_life(
                design, r, fr, life, friction.mounting, life.rated_speed_rpm, spec_b=life_b
            )

        out.lives = lives_at(rated_torque)
        out.life_spec = life
        if friction.mounting == "bearing":
            at_rated = rows_at(-rated_torque)
            frs = drive_friction(design, at_rated if given else at_rated[:1], friction)
            out.bearing = _bearing_figure(frs[0], at_rated[0], life, "row 1's")
            if given and len(frs) > 1:
                out.bearing_b = _bearing_figure(frs[1], at_rated[1], life, "row 2's")
        out.rating_source = life.rating()[1]
        out.rated_torque_from_life = torque_for_life(
            lambda T: lives_at(T)["system"], life.rated_life_h, rated_torque
        )
        out.lives_at_rated_from_life = lives_at(out.rated_torque_from_life)
    return out


def _bearing_figure(fr, row: RowLoads, life: LifeSpec, which: str) -> dict:
    """A row's eccentric bearing at T_R: ISO 281 equivalent load and mean relative speed."""
    speed = np.abs(fr.bearing_speed)
    load = fr.bearing_load if row.bearing_load is None else row.bearing_load
    return {
        "equivalent_load_N": equivalent_load(load, speed, BEARING_EXPONENT),
        "relative_speed_rpm": float(np.mean(speed)) * life.rated_speed_rpm,
        "definition": f"{which} eccentric bearing at T_R and rated_speed_rpm: "
        "ISO 281 equivalent load (exponent 10/3, weighted by the revolutions at each "
        "position) and mean relative speed; L10 = (C/P)^(10/3) 1e6 / (60 n)",
    }
