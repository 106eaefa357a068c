"""Theoretical and working profiles of the inner gear, undercut detection.

The working profile is the outer offset of the roller-centre locus by the
roller radius (Eq. 2). Where the locus is concave with a radius of curvature
smaller than ``r`` the offset runs backwards (swallowtail): the tooth is
undercut. That happens exactly where ``1 + r k < 0`` (``k`` the signed locus
curvature), so the test is closed-form; the largest admissible roller radius
is the root of ``min_psi (1 + r k(psi; L = Rj + r)) = 0``.

A profile is described per tooth: one *piece* of the curve, ``psi`` in
``[-psi_end, psi_end]`` around the tooth space, repeated ``z`` times by
rotation. Without undercut ``psi_end = pi`` and the curve is smooth; with an
allowed undercut the swallowtails are cut off at their self-intersection and
``psi_end < pi`` (a sharp tooth tip, as the union of roller discs has).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache

import numpy as np
from scipy import optimize

from corr_cad.errors import UndercutError
from corr_cad.geometry import kinematics as kin
from corr_cad.geometry.design import GearDesign

__all__ = [
    "ProfileCurve",
    "UndercutInfo",
    "theoretical_profile",
    "working_profile",
    "undercut_analysis",
    "admissible_roller_radius",
    "min_speed_factor",
]

_GL_NODES, _GL_WEIGHTS = np.polynomial.legendre.leggauss(48)


@dataclass(frozen=True)
class ProfileCurve:
    """An exact closed profile: the locus offset outwards by ``offset``.

    Attributes
    ----------
    tooth_count, eccentricity, link_length : design values (``z``, ``e``, ``L``)
    offset : float, mm
        0 for the theoretical profile (roller-centre locus), ``r`` for the
        working profile.
    psi_end : float, rad
        Each tooth's piece spans ``psi`` in ``[-psi_end, psi_end]``.
    """

    tooth_count: int
    eccentricity: float
    link_length: float
    offset: float
    psi_end: float = math.pi

    @property
    def has_corners(self) -> bool:
        """True when the pieces meet at sharp corners (trimmed undercut)."""
        return self.psi_end < math.pi

    @property
    def tooth_pitch_rad(self) -> float:
        return 2.0 * math.pi / self.tooth_count

    @property
    def piece_t_range(self) -> tuple[float, float]:
        """Polar-angle range ``(t_a, t_b)`` of tooth 0's piece."""
        z = self.tooth_count
        return -self.psi_end / z, self.psi_end / z

    # -- evaluation ---------------------------------------------------------
    def points(self, t: np.ndarray) -> np.ndarray:
        """Curve points at polar parameter ``t``, (n, 2) mm."""
        z, e, L = self.tooth_count, self.eccentricity, self.link_length
        p = kin.locus_points(t, z, e, L)
        if self.offset:
            p = p + self.offset * kin.locus_normals(t, z, e, L)
        return p

    def derivative(self, t: np.ndarray) -> np.ndarray:
        """dC/dt = (1 + offset k) dP/dt, (n, 2) mm/rad."""
        z, e, L = self.tooth_count, self.eccentricity, self.link_length
        t = np.asarray(t, dtype=float)
        d = kin.locus_derivative(t, z, e, L)
        if self.offset:
            d = d * kin.profile_speed_factor(z * t, z, e, L, self.offset)[..., None]
        return d

    def curvature(self, t: np.ndarray) -> np.ndarray:
        """Signed curvature of this curve (positive: centre towards the axis), 1/mm."""
        z, e, L = self.tooth_count, self.eccentricity, self.link_length
        k = kin.locus_curvature(z * np.asarray(t, dtype=float), z, e, L)
        return k / (1.0 + self.offset * k)

    def normals(self, t: np.ndarray) -> np.ndarray:
        """Outward unit normals (same as the locus normals), (n, 2)."""
        return kin.locus_normals(t, self.tooth_count, self.eccentricity, self.link_length)

    def area(self) -> float:
        """Enclosed area, mm^2 (Green's theorem, Gauss-Legendre per piece)."""
        t_a, t_b = self.piece_t_range
        # Split the piece in 64 panels of 48-point Gauss-Legendre: exact to
        # round-off for this smooth integrand.
        edges = np.linspace(t_a, t_b, 65)
        half = 0.5 * np.diff(edges)
        mid = 0.5 * (edges[1:] + edges[:-1])
        t = (mid[:, None] + half[:, None] * _GL_NODES[None, :]).ravel()
        w = (half[:, None] * _GL_WEIGHTS[None, :]).ravel()
        p = self.points(t)
        d = self.derivative(t)
        # Curve runs clockwise for growing t; area = -1/2 oint (x dy - y dx).
        integrand = p[:, 0] * d[:, 1] - p[:, 1] * d[:, 0]
        piece = -0.5 * float(np.sum(w * integrand))
        # Corner pieces: the two straight "rays" closing the sector cancel
        # between neighbours, so the z pieces add up to the enclosed area.
        return self.tooth_count * piece

    def sample(self, n_per_tooth: int) -> np.ndarray:
        """Closed polygon with ``n_per_tooth`` points per tooth (no repeated end), (n, 2)."""
        t_a, t_b = self.piece_t_range
        t = np.linspace(t_a, t_b, n_per_tooth + 1)[:-1]
        piece = self.points(t)
        return replicate_teeth(piece, self.tooth_count)


def replicate_teeth(piece: np.ndarray, z: int) -> np.ndarray:
    """Copy tooth 0's points (m, 2) to all ``z`` teeth, in order of growing polar angle."""
    pitch = 2.0 * math.pi / z
    return np.concatenate([kin.rotate_by_polar_angle(piece, m * pitch) for m in range(z)])


def min_speed_factor(z: int, e: float, L: float, offset: float) -> tuple[float, float]:
    """Minimum over psi of ``1 + offset k(psi)`` and where it occurs (psi in [0, pi])."""
    psi = np.linspace(0.0, math.pi, 2049)
    f = kin.profile_speed_factor(psi, z, e, L, offset)
    i = int(np.argmin(f))
    lo, hi = psi[max(i - 1, 0)], psi[min(i + 1, psi.size - 1)]
    if hi - lo > 0:
        res = optimize.minimize_scalar(
            lambda p: float(kin.profile_speed_factor(p, z, e, L, offset)),
            bounds=(lo, hi),
            method="bounded",
            options={"xatol": 1e-13},
        )
        if res.fun < f[i]:
            return float(res.fun), float(res.x)
    return float(f[i]), float(psi[i])


def admissible_roller_radius(
    design: GearDesign | int, e: float | None = None, cam_radius: float | None = None
) -> float:
    """Largest roller radius without undercut for a design's ``z``, ``e`` and ``Rj``, mm.

    Takes a :class:`GearDesign` (its roller radius is ignored), or, as
    before, the scalars ``(z, e, cam_radius)``. Root in ``r`` of
    ``min_psi (1 + r k(psi; L = Rj + r)) = 0``; ``inf`` if the locus stays
    convex for every radius tried (up to 1e6 mm).

    >>> round(admissible_roller_radius(GearDesign()), 4)
    10.053
    >>> admissible_roller_radius(25, 3.5, 135.0) == admissible_roller_radius(GearDesign())
    True
    """
    if isinstance(design, GearDesign):
        if e is not None or cam_radius is not None:
            raise TypeError("admissible_roller_radius(design) takes no further arguments")
        z, e, cam_radius = design.tooth_count, design.eccentricity, design.cam_radius
    else:
        if e is None or cam_radius is None:
            raise TypeError("admissible_roller_radius(z, e, cam_radius) needs all three")
        z = design
    return _admissible_roller_radius(int(z), float(e), float(cam_radius))


@lru_cache(maxsize=256)
def _admissible_roller_radius(z: int, e: float, cam_radius: float) -> float:
    # A sweep asks this of the same (z, e, Rj) at each of its points (a pure function: cached).
    def h(r: float) -> float:
        return min_speed_factor(z, e, cam_radius + r, r)[0]

    r_hi = max(cam_radius, 1.0) * 1e-3
    r_lo = 0.0
    while h(r_hi) > 0.0:
        r_lo = r_hi
        r_hi *= 2.0
        if r_hi > 1e6:
            return math.inf
    return float(optimize.brentq(h, r_lo, r_hi, xtol=1e-13, rtol=1e-14))


@dataclass(frozen=True)
class UndercutInfo:
    """Result of the closed-form undercut test.

    Attributes
    ----------
    undercut : bool
        True when the working profile self-intersects.
    min_speed_factor : float
        ``min (1 + r k)``; negative means undercut, near 0 a pointed tooth.
    min_working_radius : float, mm
        Smallest |radius of curvature| of the working profile (inf if never
        concave); 0 in undercut.
    admissible_roller_radius : float, mm
    psi_range_deg : tuple of float or None
        Range of ``psi`` (around the tooth tip, 180 deg) where the offset runs
        backwards.
    trimmed_psi_deg : float or None
        With an allowed undercut, each tooth's piece ends at this ``psi`` (the
        swallowtail's self-intersection).
    """

    undercut: bool
    min_speed_factor: float
    min_working_radius: float
    admissible_roller_radius: float
    psi_range_deg: tuple[float, float] | None = None
    trimmed_psi_deg: float | None = None

    def as_dict(self) -> dict:
        return {
            "undercut": self.undercut,
            "min_speed_factor": self.min_speed_factor,
            "min_working_radius_mm": self.min_working_radius,
            "admissible_roller_radius_mm": self.admissible_roller_radius,
            "psi_range_deg": list(self.psi_range_deg) if self.psi_range_deg else None,
            "trimmed_psi_deg": self.trimmed_psi_deg,
        }


def _working_radius_min(z: int, e: float, L: float, r: float) -> float:
    psi = np.linspace(0.0, math.pi, 4097)
    k = kin.locus_curvature(psi, z, e, L)
    f = 1.0 + r * k
    kw = k / f
    if np.any(f <= 0):
        return 0.0
    return float(1.0 / np.max(np.abs(kw)))


def undercut_analysis(design: GearDesign) -> UndercutInfo:
    """Closed-form undercut test of the working profile of ``design``."""
    z, e, L, r = design.tooth_count, design.eccentricity, design.link_length, design.roller_radius
    fmin, psi_at = min_speed_factor(z, e, L, r)
    r_adm = admissible_roller_radius(z, e, design.cam_radius)
    if fmin >= 0.0:
        return UndercutInfo(False, fmin, _working_radius_min(z, e, L, r), r_adm)

    def f(p: float) -> float:
        return float(kin.profile_speed_factor(p, z, e, L, r))

    # Backward-running range: from the minimum towards the tooth space.
    psi_u = optimize.brentq(f, 0.0, psi_at, xtol=1e-14) if f(0.0) > 0 else 0.0
    hi_end = 2.0 * math.pi - psi_u if psi_at >= math.pi - 1e-12 else None
    if hi_end is None:
        psi_v = optimize.brentq(f, psi_at, math.pi, xtol=1e-14) if f(math.pi) > 0 else math.pi
        rng = (math.degrees(psi_u), math.degrees(psi_v))
    else:
        rng = (math.degrees(psi_u), math.degrees(hi_end))

    # Self-intersection: where the branch before the cusp crosses the tip's
    # symmetry line (polar angle pi/z).
    curve = ProfileCurve(z, e, L, r)
    t_tip = math.pi / z

    def crossing(p: float) -> float:
        q = curve.points(np.array([p / z]))[0]
        return math.atan2(q[0], q[1]) - t_tip

    psi_x = None
    if crossing(psi_u) > 0.0:
        psi_x = optimize.brentq(crossing, 0.0, psi_u, xtol=1e-15)
    return UndercutInfo(
        True,
        fmin,
        0.0,
        r_adm,
        rng,
        math.degrees(psi_x) if psi_x is not None else None,
    )


def theoretical_profile(design: GearDesign) -> ProfileCurve:
    """The roller-centre locus (theoretical profile, Eq. 1 corrected)."""
    return ProfileCurve(design.tooth_count, design.eccentricity, design.link_length, 0.0)


def working_profile(design: GearDesign, info: UndercutInfo | None = None) -> ProfileCurve:
    """The working profile (Eq. 2): outer offset of the locus by ``r``.

    Raises :class:`UndercutError` for an undercut design unless
    ``design.allow_undercut``; then the swallowtails are trimmed and the curve
    is the boundary of the union of roller discs.

    >>> from corr_cad import GearDesign, working_profile
    >>> prof = working_profile(GearDesign())
    >>> x, y = prof.points([0.0])[0]        # t = 0: the tooth space on +y, mm
    >>> round(float(x), 9), round(float(y), 6)   # e + Rj + 2r
    (0.0, 154.5)
    """
    info = info if info is not None else undercut_analysis(design)
    z, e, L, r = design.tooth_count, design.eccentricity, design.link_length, design.roller_radius
    if not info.undercut:
        return ProfileCurve(z, e, L, r)
    if not design.allow_undercut:
        raise UndercutError(
            f"roller_radius = {r:g}: the working profile is undercut "
            f"(min 1 + r*k = {info.min_speed_factor:.4g} < 0); the largest admissible roller "
            f"radius for this design is {info.admissible_roller_radius:.6g} mm "
            "(or set allow_undercut = true)"
        )
    if info.trimmed_psi_deg is None:
        raise UndercutError(
            f"roller_radius = {r:g}: undercut too deep to trim tooth by tooth; "
            f"admissible roller radius is {info.admissible_roller_radius:.6g} mm"
        )
    return ProfileCurve(z, e, L, r, psi_end=math.radians(info.trimmed_psi_deg))
