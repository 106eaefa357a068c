"""Measured gear profiles: validation, registration to the nominal, deviation.

A measured profile (CMM or scan points, or a contour the shop sends back)
is registered to the exact working profile by a best-fit rotation and
centre shift (least squares on the normal distances). Its normal deviation
as a function of the roller-centre polar angle ``t`` then feeds the solver
as a gear-contact gap: + means material added (interference), - material
removed (clearance). Pure numpy/scipy; reading files lives in
``corr_cad.export.measured_io``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from scipy import optimize

from corr_cad.errors import ProfileError
from corr_cad.geometry import kinematics as kin
from corr_cad.geometry.profile import ProfileCurve
from corr_cad.geometry.sampling import distance_to_curve

__all__ = [
    "SampledDeviation",
    "Registration",
    "validate_points",
    "signed_deviation",
    "register",
    "check_fit",
    "POINTS_PER_TOOTH",
    "MAX_RMS_FRACTION",
]

#: Fewest measured points in every tooth pitch.
POINTS_PER_TOOTH = 20
#: A registered contour whose RMS normal deviation passes this fraction of the
#: eccentricity ``e`` (the tooth depth is ``2 e``) is not this design's gear:
#: a plain circle through the teeth deviates about ``e / sqrt(2)`` = 0.71 e,
#: a real part microns.
MAX_RMS_FRACTION = 0.25


@dataclass(frozen=True)
class SampledDeviation:
    """Periodic piecewise-linear ``dev(t)`` from samples (picklable), mm."""

    t: tuple[float, ...]
    dev: tuple[float, ...]

    def __call__(self, t: np.ndarray) -> np.ndarray:
        return np.interp(
            np.mod(np.asarray(t, dtype=float), 2 * np.pi), self.t, self.dev, period=2 * np.pi
        )


@dataclass(frozen=True)
class Registration:
    """Best fit of measured points to the nominal working profile."""

    rotation_deg: float
    centre_mm: tuple[float, float]
    rms_mm: float
    max_abs_mm: float
    points: int
    deviation: SampledDeviation
    #: The measured points moved onto the nominal (n, 2), their normal
    #: deviation (n,) and the curve parameter of their nearest point (n,).
    placed: np.ndarray = field(repr=False, compare=False, default=None)
    point_deviation: np.ndarray = field(repr=False, compare=False, default=None)
    point_t: np.ndarray = field(repr=False, compare=False, default=None)

    def as_dict(self) -> dict:
        return {
            "rotation_deg": self.rotation_deg,
            "centre_mm": list(self.centre_mm),
            "rms_deviation_mm": self.rms_mm,
            "max_abs_deviation_mm": self.max_abs_mm,
            "points": self.points,
        }


def validate_points(points: np.ndarray, curve: ProfileCurve, source: str) -> np.ndarray:
    """Check measured points (n, 2) mm: enough, finite, all around, right units."""
    p = np.asarray(points, dtype=float)
    if p.ndim != 2 or p.shape[1] != 2:
        raise ProfileError(f"{source}: expected x, y points, got an array of shape {p.shape}")
    z = curve.tooth_count
    need = POINTS_PER_TOOTH * z
    if len(p) < need:
        raise ProfileError(
            f"{source}: {len(p)} points are too few; need at least {need} "
            f"({POINTS_PER_TOOTH} per tooth)"
        )
    if not np.all(np.isfinite(p)):
        bad = int(np.count_nonzero(~np.isfinite(p).all(axis=1)))
        raise ProfileError(f"{source}: {bad} points are NaN or infinite")
    r = np.hypot(p[:, 0], p[:, 1])
    nominal = float(np.mean(np.hypot(*curve.sample(64).T)))
    ratio = float(np.median(r)) / nominal
    if not 0.8 < ratio < 1.25:
        hint = ""
        for name, f in (("inches", 1 / 25.4), ("metres", 1e-3), ("micrometres", 1e3), ("cm", 0.1)):
            if abs(ratio / f - 1) < 0.1:
                hint = f" - it looks like {name}, not mm"
        raise ProfileError(
            f"{source}: median radius {float(np.median(r)):.4g} vs nominal {nominal:.4g} mm "
            f"(ratio {ratio:.4g}){hint}; points must be in mm about the gear axis"
        )
    ang = np.sort(np.mod(np.arctan2(p[:, 0], p[:, 1]), 2 * np.pi))
    gaps = np.diff(np.r_[ang, ang[0] + 2 * np.pi])
    if gaps.max() > 0.5 * 2 * np.pi / z:
        raise ProfileError(
            f"{source}: the points leave a gap of {math.degrees(gaps.max()):.3g} deg; "
            "they must cover the whole profile (the contour is not closed)"
        )
    # Tooth by tooth: every pitch-wide sector about the axis needs its share.
    sector = np.floor(np.mod(np.arctan2(p[:, 0], p[:, 1]), 2 * np.pi) / (2 * np.pi / z))
    counts = np.bincount(np.minimum(sector.astype(int), z - 1), minlength=z)
    worst = int(np.argmin(counts))
    if counts[worst] < POINTS_PER_TOOTH:
        raise ProfileError(
            f"{source}: tooth {worst + 1} of {z} (polar angles "
            f"{worst * 360 / z:.4g} to {(worst + 1) * 360 / z:.4g} deg from +y) has "
            f"{counts[worst]} points; need at least {POINTS_PER_TOOTH} per tooth"
        )
    return p


def signed_deviation(curve: ProfileCurve, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Normal deviation of points from ``curve`` (+ = inside the gear's hole = material added).

    Returns ``(deviation, t)`` with ``t`` the parameter of the nearest curve point.
    """
    d, t = distance_to_curve(curve, points, samples_per_tooth=400)
    n = curve.normals(t)
    outward = np.sum((points - curve.points(t)) * n, axis=1)
    return -np.sign(outward) * d, t


def _transform(points, rot, cx, cy):
    """Undo a measurement placement: shift by -centre, turn by -rot (polar angles)."""
    return kin.rotate_by_polar_angle(points - np.array([cx, cy]), -rot)


def register(curve: ProfileCurve, points: np.ndarray) -> Registration:
    """Best-fit rotation and centre of ``points`` onto ``curve`` (least squares)."""
    z = curve.tooth_count
    sub = points[:: max(1, len(points) // 4000)]
    # Coarse search of the rotation over one tooth pitch (the profile repeats).
    cands = np.linspace(-np.pi / z, np.pi / z, 25, endpoint=False)
    rms = [
        np.sqrt(np.mean(signed_deviation(curve, _transform(sub, a, 0, 0))[0] ** 2)) for a in cands
    ]
    a0 = float(cands[int(np.argmin(rms))])

    def resid(x):
        return signed_deviation(curve, _transform(sub, x[0], x[1], x[2]))[0]

    fit = optimize.least_squares(
        resid, [a0, 0.0, 0.0], x_scale=[1e-3, 1e-2, 1e-2], xtol=1e-12, ftol=1e-12
    )
    rot, cx, cy = fit.x
    placed = _transform(points, rot, cx, cy)
    dev, t = signed_deviation(curve, placed)
    order = np.argsort(np.mod(t, 2 * np.pi))
    tt = np.mod(t, 2 * np.pi)[order]
    dd = dev[order]
    keep = np.r_[True, np.diff(tt) > 1e-12]
    return Registration(
        math.degrees(rot),
        (float(cx), float(cy)),
        float(np.sqrt(np.mean(dev**2))),
        float(np.max(np.abs(dev))),
        int(len(points)),
        SampledDeviation(tuple(tt[keep].tolist()), tuple(dd[keep].tolist())),
        placed,
        dev,
        t,
    )


def check_fit(reg: Registration, eccentricity: float, source: str) -> None:
    """Refuse a contour that registration cannot bring near this design's profile."""
    limit = MAX_RMS_FRACTION * eccentricity
    if not reg.rms_mm <= limit:
        raise ProfileError(
            f"{source}: after the best fit the RMS deviation is {reg.rms_mm:.3g} mm "
            f"(max {reg.max_abs_mm:.3g} mm), more than {MAX_RMS_FRACTION:g} e = {limit:.3g} mm "
            "(the tooth depth is 2 e); this is not this design's gear"
        )
