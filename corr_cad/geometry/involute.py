"""Involute spur gears: the involute function and the exact tooth outline, in numpy.

The first gear stage's pinion and wheels are external gears cut by a
generating rack (the basic rack of ISO 53 with a tip round
``rho = 0.38 m``, clamped to a full round where the tooth space is too
narrow); the crank gear is an internal gear whose root fillet is a circular
arc tangent to the involute and to the root circle (the tip round of a
shaper cutter, approximated by its envelope at rest: stated, not generated).

Coordinates follow the rest of the package: a polar angle is measured from
``+y`` and grows clockwise, a point is ``(R sin phi, R cos phi)``. Tooth
space 0 is centred on ``phi = 0``; the outline of one pitch runs from the
tooth centre at ``-pi/z`` to the tooth centre at ``+pi/z`` and is cut into
smooth *segments* (root arc, fillet, involute, tip arc, mirrored), each a
parametric curve on ``u`` in ``[0, 1]``, so the approximation never has to
span a corner.

References: the involute function and the working pressure angle of a
shifted pair, ``inv a_w = inv a + 2 tan a (x1 +- x2) / (z2 +- z1)``
(ISO 21771:2007, 4.3 and 5.2; Niemann & Winter, Maschinenelemente II,
21.2); the trochoid of a rack tip round (Litvin & Fuentes, Gear Geometry
and Applied Theory, 2nd ed., 10.4).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from corr_cad.errors import DesignError

__all__ = [
    "inv",
    "inv_inverse",
    "RACK_TIP_RADIUS",
    "GearTeeth",
    "Segment",
    "tooth_segments",
]

#: Tip round of the generating rack (ISO 53 profile A), in modules.
RACK_TIP_RADIUS = 0.38
#: Root fillet radius of the internal gear (a shaper cutter's tip round), in modules.
INTERNAL_FILLET_RADIUS = 0.25


def inv(alpha: float | np.ndarray) -> float | np.ndarray:
    """The involute function ``tan a - a`` (a in rad)."""
    return np.tan(alpha) - alpha


def inv_inverse(value: float) -> float:
    """The angle ``a`` in ``[0, pi/2)`` with ``inv(a) = value`` (Newton, to round-off)."""
    if not (value >= 0 and math.isfinite(value)):
        raise DesignError(f"inv(a) = {value:g}: allowed range is [0, inf)")
    a = min((3.0 * value) ** (1.0 / 3.0), 1.5) if value > 0 else 0.0
    for _ in range(60):
        t = math.tan(a)
        step = (t - a - value) / (t * t)  # d inv / da = tan^2 a
        if not math.isfinite(step) or a == 0.0:
            break
        a = min(max(a - step, 0.5 * a), 0.5 * (a + math.pi / 2))
        if abs(step) < 1e-16 * max(a, 1e-300):
            break
    return a


@dataclass(frozen=True)
class GearTeeth:
    """One gear's involute teeth: the numbers every check and outline uses.

    Attributes
    ----------
    teeth : int
    module : float, mm
    pressure_angle : float, rad
    shift : float
        Profile shift coefficient ``x``. External gear: ``+`` moves the rack
        away from the axis (thicker tooth). Internal gear: ``+`` moves the
        profile away from the axis (wider tooth space).
    internal : bool
    addendum, dedendum : float
        Factors of the module (1.0 and 1.25 for ISO 53).
    thinning : float, mm
        Backlash allowance: the circular tooth thickness at the reference
        circle is this much smaller (internal: the space this much wider).
    tip_radius : float, mm
        Tip circle (after any tip shortening); inner for an internal gear.
    """

    teeth: int
    module: float
    pressure_angle: float
    shift: float = 0.0
    internal: bool = False
    addendum: float = 1.0
    dedendum: float = 1.25
    thinning: float = 0.0
    tip_radius: float | None = None

    @property
    def pitch_radius(self) -> float:
        return 0.5 * self.module * self.teeth

    @property
    def base_radius(self) -> float:
        return self.pitch_radius * math.cos(self.pressure_angle)

    @property
    def nominal_tip_radius(self) -> float:
        m, x = self.module, self.shift
        if self.internal:
            return self.pitch_radius - (self.addendum - x) * m
        return self.pitch_radius + (self.addendum + x) * m

    @property
    def tip(self) -> float:
        return self.nominal_tip_radius if self.tip_radius is None else self.tip_radius

    @property
    def root_radius(self) -> float:
        m, x = self.module, self.shift
        if self.internal:
            return self.pitch_radius + (self.dedendum + x) * m
        return self.pitch_radius - (self.dedendum - x) * m

    @property
    def half_angle_at_base(self) -> float:
        """External: tooth half-angle on the base circle; internal: the space's, rad."""
        m, a, x = self.module, self.pressure_angle, self.shift
        if self.internal:  # the space of an internal gear is shaped like an external tooth
            width = m * (0.5 * math.pi + 2.0 * x * math.tan(a)) + self.thinning
        else:
            width = m * (0.5 * math.pi + 2.0 * x * math.tan(a)) - self.thinning
        return width / (2.0 * self.pitch_radius) + float(inv(a))

    def thickness_at(self, radius: float) -> float:
        """Circular tooth thickness at ``radius`` (internal gears too), mm."""
        half = self.half_angle_at_base - float(inv(math.acos(self.base_radius / radius)))
        if self.internal:  # tooth = pitch angle - space angle
            return radius * (2.0 * math.pi / self.teeth - 2.0 * half)
        return 2.0 * radius * half

    # -- generation ----------------------------------------------------------
    @property
    def rack_tip_radius(self) -> float:
        """Tip round of the generating rack (external) or the root fillet (internal), mm."""
        m, a = self.module, self.pressure_angle
        if self.internal:
            return INTERNAL_FILLET_RADIUS * m
        w, d_t = self._rack_half_width, self._rack_depth
        full = (w - d_t * math.tan(a)) / (1.0 / math.cos(a) - math.tan(a))
        return min(RACK_TIP_RADIUS * m, full)

    @property
    def _rack_half_width(self) -> float:
        """Half the rack tooth's width on the pitch line (half the gear's space), mm."""
        m, a = self.module, self.pressure_angle
        s = m * (0.5 * math.pi + 2.0 * self.shift * math.tan(a)) - self.thinning
        return 0.5 * (math.pi * m - s)

    @property
    def _rack_depth(self) -> float:
        """Depth of the rack tip below the pitch line, mm (= r - r_f)."""
        return (self.dedendum - self.shift) * self.module

    def undercut_depth(self) -> float:
        """How far the rack's straight flank reaches below the interference point, mm.

        The rack flank ends where its tip round begins, at depth
        ``d = (h_f - x) m - rho (1 - sin a)`` below the pitch line; the
        line of action meets the base circle at depth ``r sin^2 a``. A positive
        value is an undercut (external gears only).
        """
        a = self.pressure_angle
        rho = self.rack_tip_radius
        return self._rack_depth - rho * (1.0 - math.sin(a)) - self.pitch_radius * math.sin(a) ** 2

    def form_radius(self) -> float:
        """Where the involute ends and the fillet begins, mm."""
        rb, a = self.base_radius, self.pressure_angle
        if self.internal:
            return rb * math.sqrt(1.0 + self._internal_fillet_roll() ** 2)
        rho = self.rack_tip_radius
        d_fl = self._rack_depth - rho * (1.0 - math.sin(a))
        g = self.pitch_radius * math.sin(a) - d_fl / math.sin(a)
        return math.sqrt(rb * rb + max(g, 0.0) ** 2)

    def _internal_fillet_roll(self) -> float:
        """Roll angle of the involute point the internal root fillet touches, rad."""
        rb, rho = self.base_radius, self.rack_tip_radius
        rc = self.root_radius - rho
        return (math.sqrt(max(rc * rc - rb * rb, 0.0)) + rho) / rb


@dataclass(frozen=True)
class Segment:
    """A smooth piece of a tooth outline on ``u`` in ``[0, 1]``.

    ``kind`` is one of ``root``, ``fillet``, ``involute``, ``tip``;
    ``side`` is ``+1`` for the flank at positive polar angles, ``-1`` mirrored.
    """

    kind: str
    side: int
    fn: Callable[[np.ndarray], np.ndarray]

    def points(self, u: np.ndarray) -> np.ndarray:
        """Points at ``u``, (n, 2) mm."""
        p = self.fn(np.asarray(u, dtype=float))
        if self.side < 0:
            p = p * np.array([-1.0, 1.0])
        return p

    def derivative(self, u: np.ndarray) -> np.ndarray:
        """dP/du by a central difference of the closed form (O(h^2) = 1e-12), (n, 2) mm."""
        u = np.asarray(u, dtype=float)
        h = 1e-6
        return (self.points(u + h) - self.points(u - h)) / (2.0 * h)


def _polar(radius, phi) -> np.ndarray:
    radius, phi = np.broadcast_arrays(np.asarray(radius, float), np.asarray(phi, float))
    return np.stack([radius * np.sin(phi), radius * np.cos(phi)], axis=-1)


def _lerp(a: float, b: float, u: np.ndarray) -> np.ndarray:
    return a + (b - a) * u


def _external_half(g: GearTeeth) -> list[tuple[str, Callable]]:
    """Root arc, trochoidal fillet, involute, tip arc of tooth space 0's ``+`` side."""
    r, rb, a = g.pitch_radius, g.base_radius, g.pressure_angle
    rho, w, d_t = g.rack_tip_radius, g._rack_half_width, g._rack_depth
    d_c = d_t - rho  # depth of the tip round's centre below the pitch line
    x_c = w - d_c * math.tan(a) - rho / math.cos(a)  # its distance from the space centre
    phi_root, phi_flank = x_c / r, (x_c - d_c / math.tan(a)) / r

    def fillet(u):  # the envelope of the rack's tip round as the rack rolls (trochoid offset)
        phi = _lerp(phi_root, phi_flank, u)
        cx, cy = x_c - r * phi, np.full_like(phi, r - d_c)  # centre, frame fixed to the rack
        nx, ny = cx, cy - r  # from the pitch point (0, r): the common normal
        k = rho / np.hypot(nx, ny)
        px, py = cx + k * nx, cy + k * ny
        c, s = np.cos(phi), np.sin(phi)  # the gear turned back by phi
        return np.stack([px * c + py * s, -px * s + py * c], axis=-1)

    r_form = float(np.hypot(*fillet(np.array([1.0]))[0]))
    t_form = math.sqrt(max((r_form / rb) ** 2 - 1.0, 0.0))
    t_tip = math.sqrt((g.tip / rb) ** 2 - 1.0)
    eta_b = math.pi / g.teeth - g.half_angle_at_base  # space half-angle on the base circle

    def involute(u):
        t = _lerp(t_form, t_tip, u)
        return _polar(rb * np.sqrt(1.0 + t * t), eta_b + t - np.arctan(t))

    eta_tip = eta_b + t_tip - math.atan(t_tip)
    half_pitch = math.pi / g.teeth
    pieces = []
    if phi_root > 0:
        pieces.append(("root", lambda u: _polar(g.root_radius, _lerp(0.0, phi_root, u))))
    pieces += [("fillet", fillet), ("involute", involute)]
    pieces.append(("tip", lambda u: _polar(g.tip, _lerp(eta_tip, half_pitch, u))))
    return pieces


def _internal_half(g: GearTeeth) -> list[tuple[str, Callable]]:
    """Root arc, circular fillet, involute, tip arc of the internal gear's space 0, ``+`` side."""
    rb, rho = g.base_radius, g.rack_tip_radius
    eta_b = g.half_angle_at_base  # the space's half-angle on the base circle
    t_c = g._internal_fillet_roll()
    t_tip = math.sqrt(max((g.tip / rb) ** 2 - 1.0, 0.0))

    def inv_point(t):
        return _polar(rb * np.sqrt(1.0 + t * t), eta_b - t + np.arctan(t))

    p = inv_point(np.array([t_c]))[0]
    tangency = _polar(rb, eta_b - t_c)
    centre = p - rho * (p - tangency) / (rb * t_c)  # into the space, along the normal
    phi_c = math.atan2(centre[0], centre[1])
    if phi_c <= 0.0:
        raise DesignError(
            f"internal gear ({g.teeth} teeth): the tooth space is narrower at its root than "
            f"its {rho:g} mm fillets; reduce shift_crank_gear or the dedendum"
        )
    end = phi_c  # the root circle's tangency: straight out from the axis through the centre
    start = math.atan2(p[0] - centre[0], p[1] - centre[1])
    start = end + (start - end + math.pi) % (2 * math.pi) - math.pi

    def fillet(u):
        ang = _lerp(end, start, u)
        return centre + rho * np.stack([np.sin(ang), np.cos(ang)], axis=-1)

    eta_tip = eta_b - t_tip + math.atan(t_tip)
    half_pitch = math.pi / g.teeth
    return [
        ("root", lambda u: _polar(g.root_radius, _lerp(0.0, phi_c, u))),
        ("fillet", fillet),
        ("involute", lambda u: inv_point(_lerp(t_c, t_tip, u))),
        ("tip", lambda u: _polar(g.tip, _lerp(eta_tip, half_pitch, u))),
    ]


def _backwards(f: Callable) -> Callable:
    return lambda u: f(1.0 - u)


def tooth_segments(g: GearTeeth) -> list[Segment]:
    """The smooth segments of one pitch, in order of growing polar angle.

    From the tooth centre at ``-pi/z`` (``-`` side, reversed) through the
    space centre at 0 to the tooth centre at ``+pi/z``; consecutive segments
    share their end points.
    """
    half = _internal_half(g) if g.internal else _external_half(g)
    minus = [Segment(k, -1, _backwards(f)) for k, f in reversed(half)]
    return minus + [Segment(k, 1, f) for k, f in half]
