"""Profile modification of the gear ring: equidistant, shift and a normal table.

Nobody machines the exact conjugate profile. The ring is cut with a designed
clearance (``+`` = clearance, material removed from the ring):

* ``equidistant_mm`` ``d_eq``: the working profile is the offset of the locus
  by ``r + d_eq`` instead of ``r``: a uniform normal clearance ``d_eq``.
* ``shift_mm`` ``d_sh``: the locus is generated with ``L + d_sh``. The locus
  point at ``psi`` moves radially by ``s(L + d_sh) - s(L)``, to first order
  ``d_sh L / W``; its normal component, the clearance, is to first order
  ``d_sh (L / W) cos(beta)`` (``beta`` the normal's angle from the radial,
  :func:`~corr_cad.geometry.kinematics.normal_offset_angle`): largest in the
  tooth space and at the tip, smaller on the flank.
* ``normal_table``: an extra normal offset ``n(psi)`` (mm) along the tooth
  space, ``psi`` the roll angle (0 tooth space, +-180 deg tooth tip),
  interpolated by a periodic cubic spline (:class:`NormalTable`).

The modified working profile is ``C(t) = P(t; L + d_sh) + (r + d_eq + n(z t))
N(t; L + d_sh)``. The families add. Without a table it is an ordinary
:class:`~corr_cad.geometry.profile.ProfileCurve` (``link_length = L + d_sh``,
``offset = r + d_eq``), so every consumer of the profile (DXF, EDM, CMM, STEP,
meshes, inspection) follows it unchanged; with a table it is a
:class:`ModifiedProfileCurve`.

The clearance a modification gives along the flank is exact geometry: the
distance from the nominal roller centre (on the locus of ``L``) at ``psi``
to the modified curve, less ``r`` (:func:`flank_clearance`, a converged
projection). The solver takes it as an initial gap at the gear contact
(:class:`ModificationGap`: a periodic spline through the exact values on a
dense grid, + = clearance, entered as a profile deviation of the opposite
sign).
"""

from __future__ import annotations

import hashlib
import math
import re
from dataclasses import dataclass, field, replace

import numpy as np
from scipy.interpolate import CubicSpline

from corr_cad.errors import ProfileError, UndercutError
from corr_cad.geometry import kinematics as kin
from corr_cad.geometry.design import GearDesign
from corr_cad.geometry.deviations import ManufacturingErrors
from corr_cad.geometry.profile import ProfileCurve, working_profile
from corr_cad.geometry.projection import signed_normal_distance

__all__ = [
    "NormalTable",
    "Modification",
    "ModifiedProfileCurve",
    "ModificationGap",
    "CombinedDeviation",
    "modified_profile",
    "flank_clearance",
    "family_clearances",
    "modification_gap",
    "with_modification",
    "FAMILIES",
    "describe_profile",
    "amounts_text",
    "profile_record",
]

#: The families, in the order the plot and the manifest list them.
FAMILIES = ("equidistant", "shift", "normal_table")

#: Grid of the solver's gap spline over one tooth space (psi in [-pi, pi]).
GAP_GRID = 1025


@dataclass(frozen=True, eq=False)
class NormalTable:
    """Extra normal modification ``n(psi)`` (mm, + = clearance) along the tooth space.

    ``psi_deg`` strictly increasing. Given on ``[0, 180]`` only, the table is
    symmetric (mirrored to ``[-180, 0]``); given on ``[-180, 180]``, both ends
    must hold the same value (the tooth tip is shared by two tooth spaces).
    Interpolation: :class:`scipy.interpolate.CubicSpline` with
    ``bc_type="periodic"``. Periodic, because consecutive tooth spaces meet at
    the tip: the modification and its first two derivatives then agree
    there, so the profile's curvature stays continuous (C2) everywhere,
    across the tooth tip included; a natural or not-a-knot spline would
    leave a curvature jump at every tip.
    """

    psi_deg: tuple[float, ...]
    normal_mm: tuple[float, ...]
    source: str = "normal_table"
    _spline: CubicSpline = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        psi, n = validate_table(self.psi_deg, self.normal_mm, self.source)
        if psi[0] >= 0.0:  # symmetric: mirror [0, 180] to [-180, 180]
            psi, n = np.r_[-psi[:0:-1], psi], np.r_[n[:0:-1], n]
        object.__setattr__(self, "_spline", CubicSpline(np.radians(psi), n, bc_type="periodic"))

    @property
    def symmetric(self) -> bool:
        return float(self.psi_deg[0]) >= 0.0

    def __call__(self, psi: np.ndarray, nu: int = 0) -> np.ndarray:
        """``d^nu n / d psi^nu`` at roll angles ``psi`` (rad, any, wrapped to the tooth space)."""
        p = np.mod(np.asarray(psi, dtype=float) + math.pi, 2.0 * math.pi) - math.pi
        return self._spline(p, nu)

    def as_dict(self) -> dict:
        return {
            "source": self.source,
            "rows": len(self.psi_deg),
            "symmetric": self.symmetric,
            "interpolation": "scipy CubicSpline, periodic over the tooth space (C2)",
            "min_mm": float(min(self.normal_mm)),
            "max_mm": float(max(self.normal_mm)),
        }


def validate_table(
    psi_deg, normal_mm, where: str = "normal_table"
) -> tuple[np.ndarray, np.ndarray]:
    """Check a normal table: one-line :class:`ProfileError` naming the row and what works."""
    psi = np.asarray(psi_deg, dtype=float).reshape(-1)
    n = np.asarray(normal_mm, dtype=float).reshape(-1)
    if psi.size != n.size:
        raise ProfileError(f"{where}: {psi.size} psi_deg values but {n.size} normal_mm values")
    if psi.size < 4:
        raise ProfileError(
            f"{where}: {psi.size} rows; need at least 4 (psi_deg, normal_mm) rows, "
            "e.g. psi_deg 0, 60, 120, 180"
        )
    bad = np.flatnonzero(~(np.isfinite(psi) & np.isfinite(n)))
    if bad.size:
        raise ProfileError(f"{where}: row {bad[0] + 1} is not a finite number pair")
    dif = np.diff(psi)
    if np.any(dif <= 0):
        k = int(np.flatnonzero(dif <= 0)[0]) + 2
        raise ProfileError(
            f"{where}: psi_deg = {psi[k - 1]:g} in row {k} is not above the row before "
            f"({psi[k - 2]:g}); psi_deg must increase strictly"
        )
    big = np.flatnonzero(np.abs(n) > 1.0)
    if big.size:
        raise ProfileError(
            f"{where}: normal_mm = {n[big[0]]:g} in row {big[0] + 1}: allowed range is "
            "[-1, 1] mm, e.g. 0.01"
        )
    if psi[0] >= 0.0:
        if psi[0] != 0.0 or psi[-1] != 180.0:
            raise ProfileError(
                f"{where}: psi_deg runs from {psi[0]:g} to {psi[-1]:g}; a symmetric table "
                "spans [0, 180] (tooth space to tooth tip), e.g. 0, 60, 120, 180"
            )
    else:
        if psi[0] != -180.0 or psi[-1] != 180.0:
            raise ProfileError(
                f"{where}: psi_deg runs from {psi[0]:g} to {psi[-1]:g}; an asymmetric table "
                "spans [-180, 180] (tip to tip), e.g. -180, -90, 0, 90, 180"
            )
        if n[0] != n[-1]:
            raise ProfileError(
                f"{where}: normal_mm at psi_deg = -180 is {n[0]:g} but {n[-1]:g} at 180; "
                "the tooth tip is shared by two tooth spaces, give the same value"
            )
    return psi, n


@dataclass(frozen=True)
class Modification:
    """A profile modification (mm, + = clearance): families add up."""

    equidistant_mm: float = 0.0
    shift_mm: float = 0.0
    normal_table: NormalTable | None = None

    @property
    def is_zero(self) -> bool:
        return not self.equidistant_mm and not self.shift_mm and self.normal_table is None

    def only(self, family: str) -> Modification:
        """This modification with only ``family`` kept."""
        return Modification(
            self.equidistant_mm if family == "equidistant" else 0.0,
            self.shift_mm if family == "shift" else 0.0,
            self.normal_table if family == "normal_table" else None,
        )

    def families(self) -> tuple[str, ...]:
        out = []
        if self.equidistant_mm:
            out.append("equidistant")
        if self.shift_mm:
            out.append("shift")
        if self.normal_table is not None:
            out.append("normal_table")
        return tuple(out)

    def as_dict(self) -> dict:
        return {
            "equidistant_mm": self.equidistant_mm,
            "shift_mm": self.shift_mm,
            "normal_table": self.normal_table.as_dict() if self.normal_table else None,
            "sign": "+ = clearance (material removed from the ring)",
        }


@dataclass(frozen=True)
class ModifiedProfileCurve(ProfileCurve):
    """``C(t) = P(t) + (offset + n(z t)) N(t)``: a working profile with a normal table.

    ``dC/dt = (1 + (offset + n) k) P' + z n'(z t) N`` (``N' = k P'``).
    Normals and curvature are those of ``C`` itself (the curvature from a
    central difference of the exact ``C'``, relative error ~1e-8).
    """

    normal: NormalTable | None = None

    def _o(self, t: np.ndarray) -> np.ndarray:
        return self.offset + self.normal(self.tooth_count * np.asarray(t, dtype=float))

    def points(self, t: np.ndarray) -> np.ndarray:
        z, e, L = self.tooth_count, self.eccentricity, self.link_length
        t = np.asarray(t, dtype=float)
        return kin.locus_points(t, z, e, L) + self._o(t)[..., None] * kin.locus_normals(t, z, e, L)

    def derivative(self, t: np.ndarray) -> np.ndarray:
        z, e, L = self.tooth_count, self.eccentricity, self.link_length
        t = np.asarray(t, dtype=float)
        k = kin.locus_curvature(z * t, z, e, L)
        d = kin.locus_derivative(t, z, e, L) * (1.0 + self._o(t) * k)[..., None]
        return d + (z * self.normal(z * t, 1))[..., None] * kin.locus_normals(t, z, e, L)

    def normals(self, t: np.ndarray) -> np.ndarray:
        d = self.derivative(t)
        n = np.stack([-d[..., 1], d[..., 0]], axis=-1)
        return n / np.linalg.norm(n, axis=-1, keepdims=True)

    def curvature(self, t: np.ndarray) -> np.ndarray:
        t = np.asarray(t, dtype=float)
        h = 1e-5 * self.tooth_pitch_rad
        d1 = self.derivative(t)
        d2 = (self.derivative(t + h) - self.derivative(t - h)) / (2.0 * h)
        cross = d1[..., 0] * d2[..., 1] - d1[..., 1] * d2[..., 0]
        # The curve runs clockwise for growing t: positive = centre towards the axis.
        return -cross / np.linalg.norm(d1, axis=-1) ** 3


def modified_profile(
    design: GearDesign, mod: Modification, conjugate: ProfileCurve | None = None
) -> ProfileCurve:
    """The modified working profile; validity (undercut) checked on the modified curve.

    Raises :class:`UndercutError` naming the ``[modification]`` keys when the
    modified curve runs backwards anywhere (a swallowtail). A trimmed tooth
    tip (``allow_undercut``) is not combined with a modification.
    """
    conj = conjugate if conjugate is not None else working_profile(design)
    if mod.is_zero:
        return conj
    if conj.has_corners:
        raise UndercutError(
            "[modification] needs a design without undercut (the tooth tips of "
            "allow_undercut = true are trimmed); reduce roller_radius or remove [modification]"
        )
    z, e = design.tooth_count, design.eccentricity
    L = design.link_length + mod.shift_mm
    off = design.roller_radius + mod.equidistant_mm
    if L - e <= 0.0 or off <= 0.0:
        raise UndercutError(
            f"[modification] shift_mm = {mod.shift_mm:g}, equidistant_mm = {mod.equidistant_mm:g}: "
            "the modified locus or offset collapses; allowed |values| well below the roller "
            "radius, e.g. 0.01"
        )
    if mod.normal_table is None:
        curve: ProfileCurve = ProfileCurve(z, e, L, off)
    else:
        curve = ModifiedProfileCurve(z, e, L, off, normal=mod.normal_table)
    # Validity: the modified curve must run forwards (C' . P' > 0) everywhere.
    t = np.linspace(-math.pi / z, math.pi / z, 8193)
    speed = np.sum(curve.derivative(t) * kin.locus_derivative(t, z, e, L), axis=-1)
    if np.any(speed <= 0.0):
        psi_bad = math.degrees(z * float(t[int(np.argmin(speed))]))
        raise UndercutError(
            f"[modification] equidistant_mm = {mod.equidistant_mm:g}, shift_mm = "
            f"{mod.shift_mm:g}: the modified working profile is undercut near psi = "
            f"{psi_bad:.4g} deg (it runs backwards); reduce the modification, e.g. "
            "equidistant_mm = 0.01"
        )
    return curve


def flank_clearance(
    design: GearDesign, curve: ProfileCurve, psi: np.ndarray, conjugate: bool = False
) -> np.ndarray:
    """Exact normal clearance along the flank, mm (+ = clearance).

    The distance from the nominal roller centre at roll angle ``psi`` (on the
    locus of ``L``, tooth 0) to ``curve``, less ``r``: a converged projection
    onto the curve (Newton on ``(C - q) . C' = 0``, seeded at ``t = psi / z``).
    """
    z, e, L = design.tooth_count, design.eccentricity, design.link_length
    t = np.asarray(psi, dtype=float).reshape(-1) / z
    q = kin.locus_points(t, z, e, L)
    d, _ = signed_normal_distance(curve, q, t)
    # The roller centre lies inside the opening: d < 0, |d| its distance.
    return -d - design.roller_radius


def family_clearances(
    design: GearDesign, mod: Modification, psi: np.ndarray
) -> dict[str, np.ndarray]:
    """Clearance along the flank of each family alone, and of the whole modification."""
    out = {}
    for fam in mod.families():
        out[fam] = flank_clearance(design, modified_profile(design, mod.only(fam)), psi)
    out["total"] = flank_clearance(design, modified_profile(design, mod), psi)
    return out


@dataclass(frozen=True, eq=False)
class ModificationGap:
    """The designed clearance as a gear profile deviation ``dev(t)`` (+ = material added).

    ``dev(t) = -c(z t)``, ``c`` the exact :func:`flank_clearance`, through a
    periodic cubic spline on :data:`GAP_GRID` points per tooth space
    (interpolation error below 1e-9 mm for the prototype). Tooth-periodic:
    every tooth space alike, so the windup still repeats after one mesh
    period (``tooth_periodic``). Picklable.
    """

    psi: np.ndarray
    clearance_mm: np.ndarray
    _spline: CubicSpline = field(init=False, repr=False)
    tooth_count: int = 0
    tooth_periodic: bool = True

    def __post_init__(self) -> None:
        object.__setattr__(
            self, "_spline", CubicSpline(self.psi, self.clearance_mm, bc_type="periodic")
        )

    def clearance(self, psi: np.ndarray) -> np.ndarray:
        p = np.mod(np.asarray(psi, dtype=float) + math.pi, 2.0 * math.pi) - math.pi
        return self._spline(p)

    def __call__(self, t: np.ndarray) -> np.ndarray:
        return -self.clearance(self.tooth_count * np.asarray(t, dtype=float))


def modification_gap(design: GearDesign, curve: ProfileCurve) -> ModificationGap:
    """The solver's gap of a modified profile, from the exact flank clearance."""
    psi = np.linspace(-math.pi, math.pi, GAP_GRID)
    c = flank_clearance(design, curve, psi)
    c[-1] = c[0]  # the tooth tip is one point (round-off apart)
    return ModificationGap(psi, c, tooth_count=design.tooth_count)


@dataclass(frozen=True, eq=False)
class CombinedDeviation:
    """Sum of profile deviations (e.g. a measured ring and the designed clearance)."""

    parts: tuple

    @property
    def tooth_periodic(self) -> bool:
        return all(getattr(p, "tooth_periodic", False) for p in self.parts)

    def __call__(self, t: np.ndarray) -> np.ndarray:
        out = np.zeros_like(np.asarray(t, dtype=float))
        for p in self.parts:
            out = out + np.asarray(p(t), dtype=float)
        return out


def with_modification(errors: ManufacturingErrors, gap: ModificationGap | None):
    """``errors`` with the designed clearance added as a gear-contact gap."""
    if gap is None:
        return errors
    dev = errors.profile_deviation
    return replace(errors, profile_deviation=gap if dev is None else CombinedDeviation((dev, gap)))


def _amount(v: float) -> str:
    """A length in mm, positional, with the digits that identify the float (never ``1e-05``)."""
    return np.format_float_positional(float(v), unique=True, trim="-", sign=True)


def _table_digest(table: NormalTable) -> str:
    text = ";".join(f"{p!r},{n!r}" for p, n in zip(table.psi_deg, table.normal_mm, strict=True))
    return hashlib.sha256(text.encode()).hexdigest()[:12]


def profile_id(design: GearDesign, mod: Modification | None) -> str:
    """12 hex digits of a SHA-256 over what fixes the ring's working profile.

    ``z, e, L, r`` of the design and the modification's amounts (a normal
    table's every row), each as its shortest exact repr: two different rings
    never share it.
    """
    vals = [design.tooth_count, design.eccentricity, design.link_length, design.roller_radius]
    text = ";".join(repr(v) for v in vals)
    if mod is not None and not mod.is_zero:
        text += f";eq={mod.equidistant_mm!r};sh={mod.shift_mm!r}"
        if mod.normal_table is not None:
            text += ";nt=" + _table_digest(mod.normal_table)
    return hashlib.sha256(text.encode()).hexdigest()[:12]


def describe_profile(design: GearDesign, mod: Modification | None) -> str:
    """One line naming the working profile a shop or inspection file describes.

    ``conjugate (exact, unmodified)`` or ``modified: equidistant +0.01 mm, ...``
    with every family and its amount, then the :func:`profile_id`.

    >>> from corr_cad.geometry.design import GearDesign
    >>> describe_profile(GearDesign(), Modification(equidistant_mm=0.01))[:56]
    'modified: equidistant +0.01 mm (+ = clearance, material '
    """
    pid = f"profile id {profile_id(design, mod)}"
    if mod is None or mod.is_zero:
        return f"conjugate (exact, unmodified), {pid}"
    return f"modified: {amounts_text(mod)} (+ = clearance, material removed from the ring), {pid}"


def amounts_text(mod: Modification) -> str:
    """Every family of ``mod`` with its amount: ``equidistant +0.01 mm, shift -0.002 mm``."""
    parts = []
    if mod.equidistant_mm:
        parts.append(f"equidistant {_amount(mod.equidistant_mm)} mm")
    if mod.shift_mm:
        parts.append(f"shift {_amount(mod.shift_mm)} mm")
    t = mod.normal_table
    if t is not None:
        name = re.sub(r"[^A-Za-z0-9._-]+", "_", t.source.removeprefix("normal_table "))[:32]
        parts.append(
            f"normal table {name} ({len(t.psi_deg)} rows, {_amount(min(t.normal_mm))} to "
            f"{_amount(max(t.normal_mm))} mm, sha256 {_table_digest(t)})"
        )
    return ", ".join(parts)


def profile_record(design: GearDesign, mod: Modification | None) -> dict:
    """The manifest's record of the profile a shop file describes (``profile`` key)."""
    out: dict = {
        "kind": "conjugate" if mod is None or mod.is_zero else "modified",
        "description": describe_profile(design, mod),
        "profile_id": profile_id(design, mod),
    }
    if out["kind"] == "modified":
        out["families"] = list(mod.families())
        out.update({k: v for k, v in mod.as_dict().items() if k != "sign"})
        if mod.normal_table is not None:
            out["normal_table"]["sha256_12"] = _table_digest(mod.normal_table)
    return out
