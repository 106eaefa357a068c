"""Design parameters of the second (oscillatory roller) stage, validated.

All lengths in mm, modulus in MPa. The classes are frozen: vary one parameter
with :func:`dataclasses.replace`, which re-runs the validation.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from .errors import DesignError

__all__ = ["Material", "GearDesign", "SLOT_END_CLEARANCE"]

#: Radial clearance (mm) between the roller's extreme positions and the ends of
#: the frame slots.
SLOT_END_CLEARANCE = 1.0


def _number(name: str, value: object) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)):
        raise DesignError(f"{name} = {value!r}: must be a number")
    v = float(value)
    if not math.isfinite(v):
        raise DesignError(f"{name} = {value!r}: must be a finite number")
    return v


def _check_range(
    name: str,
    value: object,
    low: float,
    high: float = math.inf,
    *,
    low_open: bool = True,
    high_open: bool = True,
    why: str = "",
) -> float:
    v = _number(name, value)
    bad_low = v <= low if low_open else v < low
    bad_high = v >= high if high_open else v > high
    if bad_low or bad_high:
        lo = "(" if low_open else "["
        hi = ")" if high_open else "]"
        rng = f"{lo}{low:g}, {high:g}{hi}"
        suffix = f" ({why})" if why else ""
        raise DesignError(f"{name} = {v:g}: allowed range is {rng}{suffix}")
    return v


@dataclass(frozen=True)
class Material:
    """Linear-elastic material shared by cam, rollers, frame and gear.

    Parameters
    ----------
    young_modulus : float, MPa
    poisson_ratio : float, in (-1, 0.5)
    """

    young_modulus: float = 2.06e5
    poisson_ratio: float = 0.3

    def __post_init__(self) -> None:
        object.__setattr__(
            self, "young_modulus", _check_range("young_modulus", self.young_modulus, 0.0)
        )
        object.__setattr__(
            self, "poisson_ratio", _check_range("poisson_ratio", self.poisson_ratio, -1.0, 0.5)
        )

    @property
    def contact_modulus(self) -> float:
        """E' with 1/E' = (1-nu1^2)/E1 + (1-nu2^2)/E2 for two bodies of this material, MPa."""
        return self.young_modulus / (2.0 * (1.0 - self.poisson_ratio**2))


@dataclass(frozen=True)
class GearDesign:
    """Geometry of the second stage.

    Parameters
    ----------
    tooth_count : int
        ``z``, teeth of the fixed inner gear; there are ``z + 1`` rollers.
    cam_radius : float, mm
        ``Rj``, radius of the disk cam.
    roller_radius : float, mm
        ``r``.
    roller_length : float, mm
        Contact length of each roller.
    eccentricity : float, mm
        ``e``, cam eccentricity.
    ring_outer_radius : float or None, mm
        Outer radius of the gear ring; default leaves a rim of ``max(10, 3 r)``
        beyond the tooth spaces, rounded up to 5 mm.
    face_width : float or None, mm
        Axial width of the gear ring and cam; default ``roller_length``.
    cam_bore_radius : float or None, mm
        Radius of the cam's eccentric bore (crankshaft bearing seat); default
        ``min(0.35 Rj, (Rj - e) / 2)`` rounded to 0.1 mm.
    frame_inner_radius, frame_outer_radius : float or None, mm
        Radii of the slotted frame plates; defaults leave ``max(5, r)`` of
        material beyond the slot ends.
    frame_thickness : float or None, mm
        Thickness of each frame plate (the rollers run through the plates on
        both sides of their row); default ``max(5, r)``.
    allow_undercut : bool
        Accept a design whose working profile self-intersects; the profile
        is then the true swept boundary.
    material : Material
    """

    tooth_count: int = 25
    cam_radius: float = 135.0
    roller_radius: float = 8.0
    roller_length: float = 12.0
    eccentricity: float = 3.5
    ring_outer_radius: float | None = None
    face_width: float | None = None
    cam_bore_radius: float | None = None
    frame_inner_radius: float | None = None
    frame_outer_radius: float | None = None
    frame_thickness: float | None = None
    allow_undercut: bool = False
    material: Material = field(default_factory=Material)

    def __post_init__(self) -> None:
        z = self.tooth_count
        if isinstance(z, bool) or not isinstance(z, (int, np.integer)):
            if isinstance(z, float) and z.is_integer():
                z = int(z)
            else:
                raise DesignError(
                    f"tooth_count = {z!r}: must be an integer in [3, 1000] (z teeth, z + 1 rollers)"
                )
        z = int(z)
        if not 3 <= z <= 1000:
            raise DesignError(f"tooth_count = {z}: allowed range is [3, 1000]")
        object.__setattr__(self, "tooth_count", z)
        Rj = _check_range("cam_radius", self.cam_radius, 0.0)
        r = _check_range("roller_radius", self.roller_radius, 0.0)
        _check_range("roller_length", self.roller_length, 0.0)
        e = _check_range(
            "eccentricity",
            self.eccentricity,
            0.0,
            Rj,
            why="the crankshaft axis must lie inside the cam, e < cam_radius",
        )
        if not isinstance(self.allow_undercut, bool):
            raise DesignError(f"allow_undercut = {self.allow_undercut!r}: must be true or false")
        if not isinstance(self.material, Material):
            raise DesignError("material must be a corr_cad.Material")
        for name in ("cam_radius", "roller_radius", "roller_length", "eccentricity"):
            object.__setattr__(self, name, float(getattr(self, name)))

        # Adjacent rollers must not collide anywhere in the cycle.
        gap = self.min_roller_centre_distance - 2.0 * r
        if gap <= 0.0:
            r_max = 0.5 * self.min_roller_centre_distance
            raise DesignError(
                f"roller_radius = {r:g}: adjacent rollers collide (closest centre distance "
                f"{self.min_roller_centre_distance:.4g} mm); allowed range is (0, {r_max:.4g}) "
                "for this tooth count, cam radius and eccentricity"
            )

        s_max = Rj + r + e
        s_min = Rj + r - e
        tooth_space_radius = s_max + r
        if self.ring_outer_radius is None:
            rim = max(10.0, 3.0 * r)
            object.__setattr__(
                self, "ring_outer_radius", 5.0 * math.ceil((tooth_space_radius + rim) / 5.0)
            )
        else:
            object.__setattr__(
                self,
                "ring_outer_radius",
                _check_range(
                    "ring_outer_radius",
                    self.ring_outer_radius,
                    tooth_space_radius,
                    why="must exceed the tooth-space radius e + Rj + 2r",
                ),
            )
        if self.face_width is None:
            object.__setattr__(self, "face_width", float(self.roller_length))
        else:
            object.__setattr__(self, "face_width", _check_range("face_width", self.face_width, 0.0))
        if self.cam_bore_radius is None:
            bore = min(0.35 * Rj, 0.5 * (Rj - e))
            object.__setattr__(self, "cam_bore_radius", round(bore, 1) if bore > 1.0 else bore)
        else:
            object.__setattr__(
                self,
                "cam_bore_radius",
                _check_range(
                    "cam_bore_radius",
                    self.cam_bore_radius,
                    0.0,
                    Rj - e,
                    why="the bore must lie inside the cam, bore + e < cam_radius",
                ),
            )
        if self.frame_thickness is None:
            object.__setattr__(self, "frame_thickness", max(5.0, r))
        else:
            object.__setattr__(
                self, "frame_thickness", _check_range("frame_thickness", self.frame_thickness, 0.0)
            )
        slot_in = s_min - r - SLOT_END_CLEARANCE
        slot_out = s_max + r + SLOT_END_CLEARANCE
        margin = max(5.0, r)
        if self.frame_inner_radius is None:
            object.__setattr__(self, "frame_inner_radius", max(slot_in - margin, 0.5 * slot_in))
        else:
            object.__setattr__(
                self,
                "frame_inner_radius",
                _check_range(
                    "frame_inner_radius",
                    self.frame_inner_radius,
                    0.0,
                    slot_in,
                    why="the frame plate must reach inside the slot ends",
                ),
            )
        if self.frame_outer_radius is None:
            object.__setattr__(self, "frame_outer_radius", slot_out + margin)
        else:
            object.__setattr__(
                self,
                "frame_outer_radius",
                _check_range(
                    "frame_outer_radius",
                    self.frame_outer_radius,
                    slot_out,
                    why="the frame plate must reach beyond the slot ends",
                ),
            )

    # --- derived quantities -------------------------------------------------
    @property
    def roller_count(self) -> int:
        """z + 1."""
        return self.tooth_count + 1

    @property
    def link_length(self) -> float:
        """L = Rj + r, distance from cam centre to roller centre (corrected Eqs. 1, 6, 7)."""
        return self.cam_radius + self.roller_radius

    @property
    def slot_pitch_rad(self) -> float:
        """2 pi / (z + 1)."""
        return 2.0 * math.pi / self.roller_count

    @property
    def min_roller_centre_distance(self) -> float:
        """Closest approach of two adjacent roller centres over a cycle, mm."""
        z1 = self.tooth_count + 1
        e = float(self.eccentricity)
        L = float(self.cam_radius) + float(self.roller_radius)
        psi = np.linspace(0.0, 2.0 * np.pi, 4097)
        pitch = 2.0 * np.pi / z1

        def s_of(p: np.ndarray) -> np.ndarray:
            return e * np.cos(p) + np.sqrt(L * L - (e * np.sin(p)) ** 2)

        s1 = s_of(psi)
        s2 = s_of(psi - pitch)
        d2 = s1**2 + s2**2 - 2.0 * s1 * s2 * np.cos(pitch)
        return float(np.sqrt(d2.min()))

    def as_dict(self) -> dict:
        """Plain dictionary of every parameter (defaults resolved)."""
        return {
            "tooth_count": self.tooth_count,
            "cam_radius": self.cam_radius,
            "roller_radius": self.roller_radius,
            "roller_length": self.roller_length,
            "eccentricity": self.eccentricity,
            "ring_outer_radius": self.ring_outer_radius,
            "face_width": self.face_width,
            "cam_bore_radius": self.cam_bore_radius,
            "frame_inner_radius": self.frame_inner_radius,
            "frame_outer_radius": self.frame_outer_radius,
            "frame_thickness": self.frame_thickness,
            "allow_undercut": self.allow_undercut,
            "young_modulus": self.material.young_modulus,
            "poisson_ratio": self.material.poisson_ratio,
        }
