"""Exact clearance of every roller over the cycle (pure numpy).

Every part is a prismatic extrusion of closed-form curves, so each contact's
clearance is a 2D distance, computed exactly (no tessellation):

* roller to cam: ``|H - O1'| - (Rj + dRj) - (r + dr_i)``, the cam a circle
  whose centre ``O1'`` sits at ``e + de`` in the direction of the crank
  (turned by the cam phase error);
* roller to gear ring: the signed distance from the roller centre to the
  exact working profile (the outer offset by ``r`` of the roller-centre locus,
  found by a converged projection onto the closed-form locus), less the
  profile deviation at the foot point and the roller radius ``r + dr_i``;
* roller to its slot: the smaller distance from the roller centre to the two
  walls of its (possibly turned) slot of width ``2 r``, less ``r + dr_i``;
* roller to its neighbours: the smaller of ``|H_i - H_j| - (r_i + r_j)`` over
  the two adjacent rollers.

Negative values are interference. The error model is the solver's
(:mod:`corr_cad.geometry.deviations`): roller ``i`` sits where its slot, turned by
``delta_i``, meets the gear's roller-centre locus; the cam centre moves with
the eccentricity and phase errors; a gear profile deviation ``dev(t)`` (+ =
material added) moves the flank towards the roller. With those definitions
``-cam`` is the solver's initial cam interference ``g_j``, ``-ring`` its
``g_n`` and ``max(slot, 0)`` its slot clearance.

Positions are crank angles relative to the frame (as in ``forces.csv``); one
row of rollers (row A, the cam the solver loads) is reported: row B is the
same geometry half a cycle later.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from corr_cad.geometry.design import GearDesign
from corr_cad.geometry.deviations import ManufacturingErrors

__all__ = [
    "Clearance",
    "clearance",
    "locus_foot",
    "distance_to_working_profile",
    "COLUMNS",
    "INTERFERENCE_EPS",
    "merge_summaries",
]

#: clearance.csv columns (an interface: the names do not change).
COLUMNS = (
    "crank_angle_deg",
    "roller",
    "cam_clearance_mm",
    "ring_clearance_mm",
    "slot_clearance_mm",
    "neighbour_clearance_mm",
)

_NEWTON_STEPS = 12

#: Clearances above ``-INTERFERENCE_EPS`` count as contact, not interference:
#: the round-off of the closed forms at ~150 mm is ~1e-13 mm.
INTERFERENCE_EPS = 1e-9


def _locus(t: np.ndarray, z: int, e: float, L: float, order: int = 2):
    """Locus point and its first ``order`` derivatives in ``t``, as (x, y) pairs."""
    psi = z * t
    sp, cp = np.sin(psi), np.cos(psi)
    W = np.sqrt(L * L - (e * sp) ** 2)
    s = e * cp + W
    st, ct = np.sin(t), np.cos(t)
    out = [(s * st, s * ct)]
    if order >= 1:
        # ds/dpsi = -e sin(psi) s / W; second derivative by the quotient rule.
        s1 = -e * sp * s / W
        ds = z * s1
        # p' = s' u + s v, u = (sin t, cos t), v = (cos t, -sin t)
        out.append((ds * st + s * ct, ds * ct - s * st))
    if order >= 2:
        dW = -e * e * sp * cp / W
        s2 = -e * cp * s / W - e * sp * s1 / W + e * sp * s * dW / (W * W)
        a, b = z * z * s2 - s, 2.0 * ds
        # p'' = (s'' - s) u + 2 s' v
        out.append((a * st + b * ct, a * ct - b * st))
    return out


def locus_foot(
    design: GearDesign, points: np.ndarray, t_start: np.ndarray | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """Foot point on the roller-centre locus of each point, and the signed offset.

    Parameters
    ----------
    points : (..., 2) float, mm
        In the gear's frame (angles from +y towards +x).
    t_start : (...,) float, rad, optional
        Start of the projection; default the points' polar angles.

    Returns
    -------
    t : (...,) float, rad
        Polar angle of the foot point: ``(q - p(t)) . p'(t) = 0``, converged by
        a Newton iteration kept inside a bracket of a quarter tooth pitch
        (bisection where a step leaves it), until the step is below 1e-15 rad.
    offset : (...,) float, mm
        ``(q - p(t)) . n(t)``, positive outwards (into the ring).
    """
    z, e, L = design.tooth_count, design.eccentricity, design.link_length
    q = np.asarray(points, dtype=float)
    qx, qy = q[..., 0], q[..., 1]
    t = np.arctan2(qx, qy) if t_start is None else np.array(t_start, dtype=float)
    half = 0.25 * math.pi / z
    lo, hi = t - half, t + half
    for _ in range(_NEWTON_STEPS):
        (px, py), (dx, dy), (ax, ay) = _locus(t, z, e, L)
        ux, uy = px - qx, py - qy
        f = ux * dx + uy * dy
        df = dx * dx + dy * dy + ux * ax + uy * ay
        lo = np.where(f < 0, t, lo)
        hi = np.where(f > 0, t, hi)
        with np.errstate(divide="ignore", invalid="ignore"):
            tn = t - f / df
        ok = (df > 0) & (tn >= lo) & (tn <= hi)
        tn = np.where(ok, tn, 0.5 * (lo + hi))
        step = np.max(np.abs(tn - t), initial=0.0)
        t = tn
        if step <= 1e-15:
            break
    (px, py), (dx, dy) = _locus(t, z, e, L, order=1)
    norm = np.hypot(dx, dy)
    # outward normal: the tangent turned counter-clockwise in (x, y) = (-dy, dx)
    off = ((qx - px) * -dy + (qy - py) * dx) / norm
    return t, off


def distance_to_working_profile(
    design: GearDesign, points: np.ndarray, psi_end: float | None = None
) -> np.ndarray:
    """Signed distance from points to the exact working profile, mm (+ = free space).

    The working profile is the outer offset of the locus by ``r``; the foot
    point of a point on the offset curve is its foot on the locus, so the
    distance is ``r - offset``. With an allowed undercut, each tooth's piece
    ends at ``psi_end`` (rad); a foot beyond it is replaced by that corner.
    """
    z, e, L, r = design.tooth_count, design.eccentricity, design.link_length, design.roller_radius
    q = np.asarray(points, dtype=float)
    t, off = locus_foot(design, q)
    dist = r - off
    if psi_end is not None and psi_end < math.pi:
        psi = np.mod(z * t + math.pi, 2 * math.pi) - math.pi
        cut = np.abs(psi) > psi_end
        if np.any(cut):
            tc = t[cut] - (psi[cut] - np.sign(psi[cut]) * psi_end) / z
            (px, py), (dx, dy) = _locus(tc, z, e, L, order=1)
            norm = np.hypot(dx, dy)
            wx, wy = px - r * dy / norm, py + r * dx / norm
            dist[cut] = np.hypot(wx - q[cut][..., 0], wy - q[cut][..., 1])
    return dist


@dataclass
class Clearance:
    """Signed clearances (P, R), mm, at crank angles (P,) rad; negative = interference."""

    crank_angles: np.ndarray
    cam: np.ndarray
    ring: np.ndarray
    slot: np.ndarray
    neighbour: np.ndarray
    roller_radii: np.ndarray  # (R,)

    def columns(self) -> dict[str, np.ndarray]:
        """The clearance.csv columns, position-major (P R,)."""
        P, R = self.cam.shape
        return {
            "crank_angle_deg": np.repeat(np.degrees(self.crank_angles), R),
            "roller": np.tile(np.arange(1, R + 1), P),
            "cam_clearance_mm": self.cam.ravel(),
            "ring_clearance_mm": self.ring.ravel(),
            "slot_clearance_mm": self.slot.ravel(),
            "neighbour_clearance_mm": self.neighbour.ravel(),
        }

    def summary(self) -> dict:
        """Extremes of each contact and where they occur (roller numbers from 1)."""
        ang = np.degrees(self.crank_angles)
        out: dict = {"positions": int(self.cam.shape[0]), "rollers": int(self.cam.shape[1])}
        for name in ("cam", "ring", "slot", "neighbour"):
            a = getattr(self, name)
            k_min = np.unravel_index(np.argmin(a), a.shape)
            k_max = np.unravel_index(np.argmax(a), a.shape)
            out[name] = {
                "min_mm": float(a[k_min]),
                "min_at_crank_angle_deg": float(ang[k_min[0]]),
                "min_roller": int(k_min[1]) + 1,
                "max_mm": float(a[k_max]),
                "max_at_crank_angle_deg": float(ang[k_max[0]]),
                "max_roller": int(k_max[1]) + 1,
                "interference_count": int(np.count_nonzero(a < -INTERFERENCE_EPS)),
            }
        work = np.maximum(np.abs(self.cam), np.abs(self.ring))
        out["working_contacts_max_abs_mm"] = float(work.max())
        out["min_clearance_mm"] = float(
            min(self.cam.min(), self.ring.min(), self.slot.min(), self.neighbour.min())
        )
        return out

    def envelope(self) -> Clearance:
        """Per position, the smallest and the largest over the rollers: (P, 2) arrays.

        What the clearance plot draws, in 32 bytes a position and contact
        whatever the roller count (``roller_radii`` kept).
        """

        def mm(a: np.ndarray) -> np.ndarray:
            return np.stack([a.min(axis=1), a.max(axis=1)], axis=1)

        return Clearance(
            self.crank_angles,
            mm(self.cam),
            mm(self.ring),
            mm(self.slot),
            mm(self.neighbour),
            self.roller_radii,
        )

    @staticmethod
    def concatenate(parts: list[Clearance]) -> Clearance:
        """Consecutive position chunks joined (the same rollers)."""
        return Clearance(
            *(np.concatenate([getattr(p, f) for p in parts]) for f in _FIELDS),
            parts[0].roller_radii,
        )


_FIELDS = ("crank_angles", "cam", "ring", "slot", "neighbour")


def merge_summaries(parts: list[dict]) -> dict:
    """The :meth:`Clearance.summary` of a whole cycle from those of consecutive position chunks.

    The same values as one summary over every position: an extreme found in
    an earlier chunk wins a tie, as ``argmin``/``argmax`` take the first.
    """
    out = {"positions": sum(p["positions"] for p in parts), "rollers": parts[0]["rollers"]}
    for name in ("cam", "ring", "slot", "neighbour"):
        best = dict(parts[0][name])
        best["interference_count"] = 0
        for p in parts:
            q = p[name]
            if q["min_mm"] < best["min_mm"]:
                for k in ("min_mm", "min_at_crank_angle_deg", "min_roller"):
                    best[k] = q[k]
            if q["max_mm"] > best["max_mm"]:
                for k in ("max_mm", "max_at_crank_angle_deg", "max_roller"):
                    best[k] = q[k]
            best["interference_count"] += q["interference_count"]
        out[name] = best
    out["working_contacts_max_abs_mm"] = max(p["working_contacts_max_abs_mm"] for p in parts)
    out["min_clearance_mm"] = min(p["min_clearance_mm"] for p in parts)
    return out


def clearance(
    design: GearDesign,
    crank_angles: np.ndarray,
    errors: ManufacturingErrors | None = None,
    psi_end: float | None = None,
    profile=None,
) -> Clearance:
    """Signed clearances of every roller at crank angles (P,) rad (relative to the frame).

    ``psi_end`` (rad): the trimmed tip of an allowed undercut, see
    :func:`distance_to_working_profile`. ``profile``: a modified working
    profile (:mod:`corr_cad.geometry.modification`); the ring clearance is
    then the exact distance to it (a converged projection), not to the
    conjugate profile.
    """
    errors = errors or ManufacturingErrors()
    z, R = design.tooth_count, design.roller_count
    e, Rj, r, L = design.eccentricity, design.cam_radius, design.roller_radius, design.link_length
    phi = np.asarray(crank_angles, dtype=float).reshape(-1)
    theta = np.arange(R) * design.slot_pitch_rad
    delta = errors.slot_errors(R)
    dr = errors.roller_errors(R)
    radii = r + dr
    # Roller centre: where the turned slot meets the locus (polar angle
    # phi/z + theta + delta on the gear, i.e. psi = phi - theta + z delta).
    a = theta + delta  # slot direction in the frame
    psi = phi[:, None] - theta[None, :] + z * delta[None, :]
    W = np.sqrt(L * L - (e * np.sin(psi)) ** 2)
    s = e * np.cos(psi) + W
    hx, hy = s * np.sin(a), s * np.cos(a)
    # Cam: centre at e + de towards the crank (plus the phase error).
    ec = e + errors.eccentricity_error
    cang = phi + errors.cam_phase_error
    ox, oy = ec * np.sin(cang)[:, None], ec * np.cos(cang)[:, None]
    cam = np.hypot(hx - ox, hy - oy) - (Rj + errors.cam_radius_error) - radii
    # Ring: the centre in the gear's frame is at polar angle phi/z + a.
    t_gear = phi[:, None] / z + a[None, :]
    q = np.stack([s * np.sin(t_gear), s * np.cos(t_gear)], axis=-1)
    t_foot, off = locus_foot(design, q, t_gear)
    dist = r - off
    if psi_end is not None and psi_end < math.pi:
        dist = distance_to_working_profile(design, q, psi_end)
    if profile is not None:
        from corr_cad.geometry.projection import signed_normal_distance

        sd, t_flat = signed_normal_distance(profile, q.reshape(-1, 2), t_gear.reshape(-1))
        dist, t_foot = -sd.reshape(t_gear.shape), t_flat.reshape(t_gear.shape)
    if errors.profile_deviation is not None:
        dist = dist - np.asarray(errors.profile_deviation(t_foot), dtype=float)
    ring = dist - radii
    # Slot: walls at +-r from the slot's centre line through the axis.
    lateral = hx * np.cos(a) - hy * np.sin(a)
    slot = r - np.abs(lateral) - radii
    # Neighbours (cyclic).
    nx, ny = np.roll(hx, -1, axis=1), np.roll(hy, -1, axis=1)
    nxt = np.hypot(hx - nx, hy - ny) - radii - np.roll(radii, -1)
    neighbour = np.minimum(nxt, np.roll(nxt, 1, axis=1))
    return Clearance(phi, cam, ring, slot, neighbour, radii)
