"""Design parameters of the second (oscillatory roller) stage, validated.

All lengths in mm, modulus in MPa. The classes are frozen: vary one parameter
with :func:`dataclasses.replace`, which re-runs the validation.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from corr_cad.bounds import out_of_range, range_text, show
from corr_cad.errors import DesignError

__all__ = ["Material", "GearDesign", "SLOT_END_CLEARANCE", "MIN_WEB", "BOUNDS", "PLAUSIBLE_FACTOR"]

#: Radial clearance (mm) between the roller's extreme positions and the ends of
#: the frame slots.
SLOT_END_CLEARANCE = 1.0

#: Thinnest material (mm) the frame keeps between two slots and between a slot
#: end and the plate edge, the gear ring beyond its tooth spaces and the cam
#: around its bore.
MIN_WEB = 1.0
#: Small rollers (r < 4 mm) need only a web of this fraction of r between slots.
MIN_WEB_FRACTION = 0.25

#: Static ranges ``(low, high)`` of every design and material number: low
#: open, high closed, ``(low, high]``. Scene files show and check the same.
#: The ends are plausibility limits (a 10 m cam, a 1e7 MPa modulus); the
#: design adds the ranges that depend on other keys (``e < Rj``, webs ...).
BOUNDS: dict[str, tuple[float, float]] = {
    "tooth_count": (2, 1000),
    "cam_radius": (0.0, 1.0e4),
    "roller_radius": (0.0, 1.0e3),
    "roller_length": (0.0, 1.0e4),
    "eccentricity": (0.0, 1.0e3),
    "ring_outer_radius": (0.0, 1.0e5),
    "face_width": (0.0, 1.0e4),
    "cam_bore_radius": (0.0, 1.0e4),
    "frame_inner_radius": (0.0, 1.0e5),
    "frame_outer_radius": (0.0, 1.0e5),
    "frame_thickness": (0.0, 1.0e4),
    "young_modulus": (0.0, 1.0e7),
}

#: Thinnest axial length (roller_length, face_width, frame_thickness), mm: ten
#: times Open CASCADE's confusion distance (1e-7 mm: its prism of 1e-9 mm
#: fails) and a hundred times the mesher's vertex merge distance (a 1e-9 mm
#: ring meshes with no volume). Checked on top of the static range.
MIN_AXIAL_LENGTH = 1e-6
#: Smallest eccentricity as a fraction of the cam radius: the tooth depth 2e
#: then keeps about seven significant digits in the float64 profile
#: coordinates (at 1e-16 of them it is lost entirely, and the solver divides
#: by it). The hard case e = 1e-6 mm on the 135 mm cam (7.4e-9 of it) solves
#: (tests/issues/test_tiny_eccentricity_huge_tooth_count.py).
MIN_RELATIVE_ECCENTRICITY = 1e-9
#: Smallest roller radius, mm (a micrometre): below it the roller's mesh has
#: no volume (1e-6 mm: zero volume; 1e-9 mm: manifold3d cannot build it) and
#: the errors and tolerances checked against it are refused naming other keys.
MIN_ROLLER_RADIUS = 1e-3
#: Softest material accepted, MPa: an elastomer. Below it the contact model
#: (small displacements) has no meaning, and at subnormal values 1/E overflows.
MIN_YOUNG_MODULUS = 1.0


def _axial(name: str, value: object) -> float:
    return _check_range(
        name,
        value,
        MIN_AXIAL_LENGTH,
        BOUNDS[name][1],
        low_open=False,
        high_open=False,
        why=f"thinner than {MIN_AXIAL_LENGTH:g} mm is below what the STEP kernel and the "
        f"mesher resolve; {name} = {MIN_AXIAL_LENGTH:g} would work",
    )


#: An outer radius (ring, frame) may be at most this many times the radius it
#: must clear; beyond that it is a unit slip, not a design (1e9 mm is refused).
PLAUSIBLE_FACTOR = 10.0


def _number(name: str, value: object) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)):
        raise DesignError(f"{name} = {show(value)}: must be a number")
    v = float(value)
    if not math.isfinite(v):
        raise DesignError(f"{name} = {show(value)}: must be a finite number")
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
    if name in BOUNDS:  # the static range first, worded as the scene schema words it
        lo_s, hi_s = BOUNDS[name]
        if out_of_range(v, lo_s, hi_s):
            raise DesignError(f"{name} = {v:g}: allowed range is {range_text(lo_s, hi_s)}")
    if out_of_range(v, low, high, low_open=low_open, high_open=high_open):
        rng = range_text(low, high, low_open=low_open, high_open=high_open)
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
            self,
            "young_modulus",
            _check_range(
                "young_modulus",
                self.young_modulus,
                MIN_YOUNG_MODULUS,
                BOUNDS["young_modulus"][1],
                low_open=False,
                high_open=False,
                why=f"softer than an elastomer's {MIN_YOUNG_MODULUS:g} MPa is no gear material; "
                "steel is 2.06e5",
            ),
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
                    f"tooth_count = {show(z)}: must be an integer in "
                    f"{range_text(*BOUNDS['tooth_count'])} (z teeth, z + 1 rollers)"
                )
        z = int(z)
        if out_of_range(z, *BOUNDS["tooth_count"]):
            raise DesignError(
                f"tooth_count = {z}: allowed range is {range_text(*BOUNDS['tooth_count'])}"
            )
        object.__setattr__(self, "tooth_count", z)
        Rj = _check_range("cam_radius", self.cam_radius, 0.0)
        r = _check_range(
            "roller_radius",
            self.roller_radius,
            MIN_ROLLER_RADIUS,
            BOUNDS["roller_radius"][1],
            low_open=False,
            high_open=False,
            why=f"a roller below {MIN_ROLLER_RADIUS:g} mm has no meshable volume and no "
            f"meaningful contact; roller_radius = {MIN_ROLLER_RADIUS:g} would work",
        )
        _axial("roller_length", self.roller_length)
        e = _check_range(
            "eccentricity",
            self.eccentricity,
            0.0,
            Rj,
            why="the crankshaft axis must lie inside the cam, e < cam_radius",
        )
        e_min = MIN_RELATIVE_ECCENTRICITY * Rj
        if e < e_min:
            raise DesignError(
                f"eccentricity = {e:g}: allowed range is [{e_min:g}, {Rj:g}) for cam_radius = "
                f"{Rj:g} (below {MIN_RELATIVE_ECCENTRICITY:g} of it the teeth, 2e deep, drown "
                "in the rounding of the "
                f"profile's coordinates); eccentricity = {e_min:g} would work"
            )
        if not isinstance(self.allow_undercut, bool):
            raise DesignError(
                f"allow_undercut = {show(self.allow_undercut)}: must be true or false"
            )
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
                    tooth_space_radius + MIN_WEB,
                    PLAUSIBLE_FACTOR * tooth_space_radius,
                    low_open=False,
                    high_open=False,
                    why=f"from the tooth-space radius e + Rj + 2r plus a {MIN_WEB:g} mm rim "
                    f"to {PLAUSIBLE_FACTOR:g} times it",
                ),
            )
        if self.face_width is None:
            object.__setattr__(self, "face_width", float(self.roller_length))
        else:
            object.__setattr__(self, "face_width", _axial("face_width", self.face_width))
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
                    Rj - e - MIN_WEB,
                    high_open=False,
                    why=f"the bore must lie inside the cam with a {MIN_WEB:g} mm web, "
                    "bore + e + web <= cam_radius",
                ),
            )
        if self.frame_thickness is None:
            object.__setattr__(self, "frame_thickness", max(5.0, r))
        else:
            object.__setattr__(
                self, "frame_thickness", _axial("frame_thickness", self.frame_thickness)
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
                    slot_in - MIN_WEB,
                    high_open=False,
                    why=f"the frame plate must reach {MIN_WEB:g} mm inside the slot ends",
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
                    slot_out + MIN_WEB,
                    PLAUSIBLE_FACTOR * slot_out,
                    low_open=False,
                    why=f"the frame plate must reach {MIN_WEB:g} mm beyond the slot ends, "
                    f"and at most {PLAUSIBLE_FACTOR:g} times their radius",
                ),
            )
        if self.frame_inner_radius >= self.frame_outer_radius:
            raise DesignError(
                f"frame_inner_radius = {self.frame_inner_radius:g}: must be below "
                f"frame_outer_radius = {self.frame_outer_radius:g}"
            )
        self._check_frame_webs()
        self._check_derived()

    def _check_frame_webs(self) -> None:
        """Adjacent slots keep a web of ``min(MIN_WEB, MIN_WEB_FRACTION r)`` between them.

        Slot ``i`` is the set of points within ``r`` of the radial segment from
        ``rho_in`` to ``rho_out`` at angle ``i p`` (``p = 2 pi / (z + 1)``). Two
        such segments are closest at their inner ends, ``2 rho_in sin(p/2)``
        apart (for ``p < pi``), so the web is ``2 rho_in sin(p/2) - 2 r``. With
        ``rho_in = Rj + r - e - c`` the largest roller radius keeping the web
        ``w`` is ``(2 (Rj - e - c) sin(p/2) - w) / (2 - 2 sin(p/2))`` (``w = f r``:
        ``2 (Rj - e - c) sin(p/2) / (2 - 2 sin(p/2) + f)``).
        """
        r, e, Rj = self.roller_radius, self.eccentricity, self.cam_radius
        half = math.sin(0.5 * self.slot_pitch_rad)
        rho_in = self.link_length - e - SLOT_END_CLEARANCE
        web = 2.0 * rho_in * half - 2.0 * r
        need = min(MIN_WEB, MIN_WEB_FRACTION * r)

        def web_at(radius: float) -> float:
            return 2.0 * (Rj + radius - e - SLOT_END_CLEARANCE) * half - 2.0 * radius

        def need_at(radius: float) -> float:
            return min(MIN_WEB, MIN_WEB_FRACTION * radius)

        if web < need:
            a = 2.0 * (Rj - e - SLOT_END_CLEARANCE) * half
            r_max = (a - MIN_WEB) / (2.0 - 2.0 * half)
            if MIN_WEB_FRACTION * r_max < MIN_WEB:  # a small roller: the web scales with r
                r_max = a / (2.0 - 2.0 * half + MIN_WEB_FRACTION)
            r_max = float(f"{r_max:.6g}")  # shown as %g: never above the true limit
            if web_at(r_max) < need_at(r_max):
                r_max = math.nextafter(r_max, 0.0) - 10 ** (math.floor(math.log10(r_max)) - 5)
            raise DesignError(
                f"roller_radius = {r:g}: the frame slots overlap or leave a web of "
                f"{web:.3g} mm (< {need:.3g} mm) between neighbours; allowed range is "
                f"{range_text(0.0, max(r_max, 0.0))} for this tooth count, cam radius and "
                "eccentricity"
            )

    def _check_derived(self) -> None:
        """Every derived length must be a finite number (no overflow to inf or NaN)."""
        derived = {
            "link_length": self.link_length,
            "min_roller_centre_distance": self.min_roller_centre_distance,
            **{k: v for k, v in self.as_dict().items() if isinstance(v, float)},
        }
        for name, v in derived.items():
            if not math.isfinite(v):
                raise DesignError(f"{name} = {v}: the design overflows; reduce the lengths")

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
