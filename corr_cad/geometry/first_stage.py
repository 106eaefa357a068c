"""The first gear stage: input pinion, three wheels on fixed axes, internal crank gear.

The pinion and the crank gear (internal, on the crankshaft) are coaxial;
three equal wheels on axes fixed in the housing, 120 deg apart at the
centre distance ``a``, mesh with both. The pinion turns the wheels, the
wheels turn the crank gear: ``i1 = n_pinion / n_crank = -z_crank / z_pinion``.

Geometry (ISO 21771:2007; Niemann & Winter, Maschinenelemente II, 21.2):

- external mesh pinion-wheel at its zero-backlash centre distance,
  ``inv a_w = inv a + 2 tan a (x_p + x_w) / (z_p + z_w)``,
  ``a = m (z_p + z_w) / 2 * cos a / cos a_w``; the wheels sit there;
- internal mesh wheel-crank gear at the same ``a``; its zero-backlash
  distance follows from ``inv a_w = inv a + 2 tan a (x_c - x_w) / (z_c - z_w)``
  and the difference is backlash (refused when it is negative);
- tip circles shortened where needed to keep the bottom clearance
  ``c = (dedendum - addendum) m`` at ``a``;
- transverse contact ratio of each mesh from the lengths of action,
  ``eps = (sqrt(ra1^2 - rb1^2) +- sqrt(ra2^2 - rb2^2) -+ a sin a_w) / (pi m cos a)``;
- trochoid (tip) interference of the internal mesh by the condition of
  KHK's *Gear Technical Reference* (internal gears, "trochoid interference"):
  ``theta1 z1/z2 + inv a_w - inv a_a2 - theta2 >= 0``.

Every refusal is a :class:`~corr_cad.errors.DesignError` with one line that
names the key to change and a value that works.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

from corr_cad.errors import DesignError
from corr_cad.geometry.involute import GearTeeth, inv, inv_inverse

__all__ = [
    "FirstStage",
    "FirstStageGeometry",
    "first_stage_geometry",
    "zero_backlash_pressure_angle",
    "MIN_CONTACT_RATIO",
    "MIN_MODULE",
]

#: Smallest transverse contact ratio accepted for either mesh.
MIN_CONTACT_RATIO = 1.2
#: Largest difference of the two meshes' zero-backlash centre distances, in modules
#: (the wheels sit at the pinion mesh's; the internal mesh takes the rest as backlash).
MAX_CENTRE_MISMATCH = 0.1
#: Thinnest tooth tip accepted, in modules.
MIN_TIP_THICKNESS = 0.2
#: Smallest module, mm (a micrometre, the roller radius's floor): the teeth's
#: fillets and tips are a few tenths of it, and at 1e-300 the gear's radii
#: underflow (the stage divided by zero). A module this small is refused anyway
#: where the crank gear must hold the crankshaft; the floor keeps every refusal
#: a one-line one.
MIN_MODULE = 1e-3


@dataclass(frozen=True)
class FirstStage:
    """The ``[first_stage]`` keys (lengths in mm, angle in deg)."""

    pinion_teeth: int
    wheel_teeth: int
    crank_gear_teeth: int
    module: float
    face_width: float
    pressure_angle_deg: float = 20.0
    shift_pinion: float = 0.0
    shift_wheel: float = 0.0
    shift_crank_gear: float = 0.0
    addendum: float = 1.0
    dedendum: float = 1.25
    backlash_allowance: float = 0.0

    @property
    def pressure_angle(self) -> float:
        return math.radians(self.pressure_angle_deg)

    @property
    def ratio(self) -> float:
        """``i1 = n_pinion / n_crank = -z_crank / z_pinion`` (signed)."""
        return -self.crank_gear_teeth / self.pinion_teeth

    def gear(self, part: str, tip_radius: float | None = None) -> GearTeeth:
        """The :class:`GearTeeth` of ``pinion``, ``wheel`` or ``crank_gear``."""
        z, x = {
            "pinion": (self.pinion_teeth, self.shift_pinion),
            "wheel": (self.wheel_teeth, self.shift_wheel),
            "crank_gear": (self.crank_gear_teeth, self.shift_crank_gear),
        }[part]
        return GearTeeth(
            z,
            self.module,
            self.pressure_angle,
            x,
            part == "crank_gear",
            self.addendum,
            self.dedendum,
            self.backlash_allowance,
            tip_radius,
        )


@dataclass(frozen=True)
class FirstStageGeometry:
    """The first stage as built: gears, centre distance, both meshes' figures.

    Attributes
    ----------
    stage : FirstStage
    pinion, wheel, crank_gear : GearTeeth
        With their tip circles as cut (after tip shortening).
    centre_distance : float, mm
        Pinion (and crank) axis to each wheel axis.
    working_pressure_angle_deg : (external, internal) floats, deg
    zero_backlash_centre_distance : (external, internal) floats, mm
    contact_ratio : (external, internal) floats
    backlash : (external, internal) floats, mm
        Circumferential backlash on the working pitch circles.
    wheel_gap : float, mm
        Between the tip circles of two neighbouring wheels.
    """

    stage: FirstStage
    pinion: GearTeeth
    wheel: GearTeeth
    crank_gear: GearTeeth
    centre_distance: float
    working_pressure_angle_deg: tuple[float, float]
    zero_backlash_centre_distance: tuple[float, float]
    contact_ratio: tuple[float, float]
    backlash: tuple[float, float]
    wheel_gap: float

    @property
    def ratio(self) -> float:
        return self.stage.ratio

    @property
    def crank_backlash_rad(self) -> float:
        """Free turn of the crank with the pinion held, rad.

        The pinion mesh's play turns a wheel by ``j1 / r_w1`` (its working
        pitch radius in that mesh), which moves the crank gear by that arc
        on the wheel's other working circle ``r_w2``; the internal mesh adds
        ``j2``; both over the crank gear's working pitch radius ``r_wc``.
        """
        a1, a2 = (math.radians(a) for a in self.working_pressure_angle_deg)
        rb_w = self.wheel.base_radius
        r_w1, r_w2 = rb_w / math.cos(a1), rb_w / math.cos(a2)
        r_wc = self.crank_gear.base_radius / math.cos(a2)
        return (self.backlash[0] * r_w2 / r_w1 + self.backlash[1]) / r_wc

    def as_dict(self) -> dict:
        """The figures reported in ``manifest.json`` under ``first_stage``."""
        s = self.stage
        gears = {}
        for name in ("pinion", "wheel", "crank_gear"):
            g = getattr(self, name)
            gears[name] = {
                "teeth": g.teeth,
                "shift": g.shift,
                "pitch_radius_mm": g.pitch_radius,
                "base_radius_mm": g.base_radius,
                "tip_radius_mm": g.tip,
                "root_radius_mm": g.root_radius,
                "form_radius_mm": g.form_radius(),
                "tip_thickness_mm": g.thickness_at(g.tip),
            }
        return {
            "ratio_i1": s.ratio,
            "module_mm": s.module,
            "pressure_angle_deg": s.pressure_angle_deg,
            "face_width_mm": s.face_width,
            "backlash_allowance_mm": s.backlash_allowance,
            "centre_distance_mm": self.centre_distance,
            "gears": gears,
            "meshes": {
                name: {
                    "working_pressure_angle_deg": self.working_pressure_angle_deg[i],
                    "zero_backlash_centre_distance_mm": self.zero_backlash_centre_distance[i],
                    "contact_ratio": self.contact_ratio[i],
                    "backlash_mm": self.backlash[i],
                }
                for i, name in enumerate(("pinion_wheel", "wheel_crank_gear"))
            },
            "wheel_tip_gap_mm": self.wheel_gap,
            "crank_backlash_arcmin": math.degrees(self.crank_backlash_rad) * 60.0,
        }


def zero_backlash_pressure_angle(z1: int, z2: int, x_sum: float, alpha: float) -> float:
    """``inv a_w = inv a + 2 tan a x_sum / z_sum`` (``z_sum`` = z2 + z1 or z2 - z1)."""
    value = float(inv(alpha)) + 2.0 * math.tan(alpha) * x_sum / (z2 + z1)
    if value <= 0:
        raise DesignError(
            f"shift_wheel and shift_pinion/shift_crank_gear sum to {x_sum:g}: the mesh has "
            "no working pressure angle; allowed is a sum that leaves inv(a_w) > 0"
        )
    return inv_inverse(value)


def _fmt(v: float) -> str:
    return f"{v:.4g}"


#: Whether the refusals being built are a suggestion's own check (then no suggestion is
#: looked for: a candidate is only accepted or rejected).
_CHECKING: list[bool] = []


def _passes(s: FirstStage, change: dict) -> bool:
    """Whether the stage with ``change`` passes every check of :func:`first_stage_geometry`."""
    try:
        candidate = replace(s, **change)
    except (DesignError, ValueError, TypeError):
        return False
    _CHECKING.append(True)
    try:
        first_stage_geometry(candidate)
    except (DesignError, ValueError, ArithmeticError):
        return False
    finally:
        _CHECKING.pop()
    return True


def _shown(change: dict) -> dict:
    """``change`` as it will be printed (floats to 6 significant digits): what is verified."""
    return {k: v if isinstance(v, int) else float(f"{v:.6g}") for k, v in change.items()}


def _shown_change(change: dict) -> str:
    return " with ".join(
        f"{k} = {v}" if isinstance(v, int) else f"{k} = {v:.6g}" for k, v in change.items()
    )


def _suggest(s: FirstStage, candidates) -> str:
    """``"a value that works: key = v"`` for the first candidate change (a dict) that
    passes every check, verified here before it is printed; else what to do without one."""
    if _CHECKING:
        return "a value that works: (not looked for)"
    for change in candidates:
        if change and _passes(s, _shown(change)):
            return f"a value that works: {_shown_change(_shown(change))}"
    return (
        "no single change of one key passes every check here; the compound template's "
        "first stage works: pinion_teeth = 18, wheel_teeth = 36, crank_gear_teeth = 90, "
        "shift_pinion = 0.5, shift_wheel = 0, shift_crank_gear = 0.5"
    )


def _shifts(s: FirstStage, key: str) -> list[dict]:
    """Candidate values of a shift key, from its present value towards 0 and beyond."""
    now = getattr(s, key)
    steps = [round(now - 0.05 * k * math.copysign(1, now or 1), 2) for k in range(1, 101)]
    return [{key: x} for x in steps if -2 <= x <= 3] + [{key: 0.0}]


def _check_spacing(s: FirstStage) -> None:
    total = s.pinion_teeth + s.crank_gear_teeth
    if total % 3:
        up = s.crank_gear_teeth + (3 - total % 3)
        near = sorted(range(up - 30, up + 31, 3), key=lambda c: abs(c - s.crank_gear_teeth))
        teeth = [{"crank_gear_teeth": c} for c in near if 4 <= c <= 3000]
        fitted = []
        for c in near[:4]:
            x = _fitting_crank_shift(replace(s, crank_gear_teeth=c), _centre(s)) if c > 4 else None
            if x is not None:
                fitted.append({"crank_gear_teeth": c, "shift_crank_gear": x})
        raise DesignError(
            f"crank_gear_teeth = {s.crank_gear_teeth}: three wheels cannot be spaced equally, "
            f"(pinion_teeth + crank_gear_teeth) / 3 = {total}/3 is not whole (crank_gear_teeth "
            f"= ..., {up - 3}, {up}, {up + 3}, ... make it whole); {_suggest(s, teeth + fitted)}"
        )
    if s.crank_gear_teeth <= s.wheel_teeth + 2:
        raise DesignError(
            f"crank_gear_teeth = {s.crank_gear_teeth}: the internal gear needs more teeth than "
            f"the wheel ({s.wheel_teeth}) plus 2; allowed range is > {s.wheel_teeth + 2}"
        )


def _centre(s: FirstStage) -> float:
    """The pinion mesh's zero-backlash centre distance, mm (the wheels' axes)."""
    aw1 = zero_backlash_pressure_angle(
        s.pinion_teeth, s.wheel_teeth, s.shift_pinion + s.shift_wheel, s.pressure_angle
    )
    return (
        0.5
        * s.module
        * (s.pinion_teeth + s.wheel_teeth)
        * math.cos(s.pressure_angle)
        / (math.cos(aw1))
    )


def _check_undercut(s: FirstStage) -> None:
    for part, key in (("pinion", "shift_pinion"), ("wheel", "shift_wheel")):
        g = s.gear(part)
        if g.undercut_depth() > 1e-12:
            a = s.pressure_angle
            # the shift that brings the flank end to the interference point (rho as clamped)
            x_min = (
                s.dedendum
                - g.rack_tip_radius * (1 - math.sin(a)) / s.module
                - 0.5 * g.teeth * math.sin(a) ** 2
            )
            ok = math.ceil(100 * x_min) / 100
            ups = [{key: round(ok + 0.05 * k, 2)} for k in range(0, 61) if ok + 0.05 * k <= 3]
            raise DesignError(
                f"{key} = {g.shift:g}: the {part} ({g.teeth} teeth) is undercut by the "
                f"generating rack; allowed range is {key} >= {x_min:.3f}; {_suggest(s, ups)}"
            )


def _working(a0: float, alpha: float, a: float) -> float:
    c = a0 * math.cos(alpha) / a
    return math.acos(min(c, 1.0))


def _tip_thickness(s: FirstStage, g: GearTeeth, part: str) -> None:
    t = g.thickness_at(g.tip)
    limit = MIN_TIP_THICKNESS * s.module
    if t < limit and g.thinning > 0 and _tip(g, 0.0) >= limit:
        # The backlash allowance, not the shift, thins the tip too far: name it,
        # with the largest allowance that keeps the tip (bisection, 1 um).
        lo, hi = 0.0, g.thinning
        while hi - lo > 1e-4:
            mid = 0.5 * (lo + hi)
            lo, hi = (mid, hi) if _tip(g, mid) >= limit else (lo, mid)
        ok = math.floor(lo * 1000) / 1000
        raise DesignError(
            f"backlash_allowance = {g.thinning:g}: the {part}'s tooth tip is {_fmt(t)} mm "
            f"thick; allowed is >= {MIN_TIP_THICKNESS:g} module = {_fmt(limit)} mm, "
            f"i.e. backlash_allowance <= {ok:g} mm; "
            + _suggest(s, [{"backlash_allowance": ok}, {"backlash_allowance": 0.0}])
        )
    if t < limit:
        key = {"pinion": "shift_pinion", "wheel": "shift_wheel"}.get(part, "shift_crank_gear")
        raise DesignError(
            f"{key} = {g.shift:g}: the {part}'s tooth tip is {_fmt(t)} mm thick; allowed is "
            f">= {MIN_TIP_THICKNESS:g} module = {_fmt(MIN_TIP_THICKNESS * s.module)} mm "
            f"(reduce the shift or the addendum); {_suggest(s, _shifts(s, key))}"
        )


def _tip(g: GearTeeth, thinning: float) -> float:
    """The tip thickness of ``g`` with another thinning, mm."""
    return replace(g, thinning=thinning).thickness_at(g.tip)


def _trochoid_margin(w: GearTeeth, c: GearTeeth, a: float, alpha_w: float) -> float:
    """KHK's trochoid-interference condition of an internal pair, rad (>= 0: clear)."""
    ra1, ra2 = w.tip, c.tip
    aa1 = math.acos(w.base_radius / ra1)
    aa2 = math.acos(c.base_radius / ra2)
    arg1 = (ra2 * ra2 - ra1 * ra1 - a * a) / (2.0 * a * ra1)
    arg2 = (a * a + ra2 * ra2 - ra1 * ra1) / (2.0 * a * ra2)
    if abs(arg1) > 1 or abs(arg2) > 1:  # the tip circles do not cross: no recess clash
        return math.inf
    theta1 = math.acos(arg1) + float(inv(aa1)) - float(inv(alpha_w))
    theta2 = math.acos(arg2)
    return theta1 * w.teeth / c.teeth + float(inv(alpha_w)) - float(inv(aa2)) - theta2


def _fitting_crank_shift(s: FirstStage, a: float) -> float | None:
    """The ``shift_crank_gear`` that puts the internal mesh's zero backlash at ``a``."""
    a02 = 0.5 * s.module * (s.crank_gear_teeth - s.wheel_teeth)
    c = a02 * math.cos(s.pressure_angle) / a
    if c >= 1:
        return None
    x = s.shift_wheel + (float(inv(math.acos(c))) - float(inv(s.pressure_angle))) * (
        s.crank_gear_teeth - s.wheel_teeth
    ) / (2 * math.tan(s.pressure_angle))
    x = math.ceil(x * 1e4) / 1e4
    return x if -2 <= x <= 3 else None


def _check_centre_distances(s: FirstStage, a: float, a2: float, a02: float) -> None:
    """Both meshes must want (nearly) the same centre distance: the wheel axes are shared."""
    if abs(a - a2) <= MAX_CENTRE_MISMATCH * s.module:
        return
    x = _fitting_crank_shift(s, a)
    standard = s.pinion_teeth + 2 * s.wheel_teeth
    candidates = [
        {"shift_crank_gear": x} if x is not None else {},
        # x_p + x_w = x_c - x_w: both meshes at the standard centre distance
        {"shift_pinion": round(s.shift_crank_gear - 2 * s.shift_wheel, 4)},
        {"shift_crank_gear": round(s.shift_pinion + 2 * s.shift_wheel, 4)},
        {"crank_gear_teeth": standard},
        {
            "crank_gear_teeth": standard,
            "shift_crank_gear": round(s.shift_pinion + 2 * s.shift_wheel, 4),
        },
    ]
    raise DesignError(
        f"crank_gear_teeth = {s.crank_gear_teeth}: the pinion mesh puts the wheel axes "
        f"{_fmt(a)} mm from the axis, the internal mesh wants {_fmt(a2)} mm; allowed is a "
        f"difference of at most {MAX_CENTRE_MISMATCH:g} module (at crank_gear_teeth = "
        f"pinion_teeth + 2 wheel_teeth = {standard} the shifts must satisfy "
        f"shift_crank_gear - shift_wheel = shift_pinion + shift_wheel); "
        f"{_suggest(s, candidates)}"
    )


def first_stage_geometry(s: FirstStage) -> FirstStageGeometry:
    """Centre distance, working pressure angles, contact ratios and every refusal.

    >>> g = first_stage_geometry(
    ...     FirstStage(18, 36, 90, 1.5, 15.0, shift_pinion=0.5, shift_crank_gear=0.5)
    ... )
    >>> round(g.centre_distance, 4), g.ratio, [round(e, 3) for e in g.contact_ratio]
    (41.2061, -5.0, [1.433, 1.782])
    """
    _check_spacing(s)
    _check_undercut(s)
    m, alpha = s.module, s.pressure_angle
    zp, zw, zc = s.pinion_teeth, s.wheel_teeth, s.crank_gear_teeth
    try:
        aw1 = zero_backlash_pressure_angle(zp, zw, s.shift_pinion + s.shift_wheel, alpha)
        aw2 = zero_backlash_pressure_angle(-zw, zc, s.shift_crank_gear - s.shift_wheel, alpha)
    except DesignError as exc:
        zeros = [{k: 0.0} for k in ("shift_wheel", "shift_pinion", "shift_crank_gear")]
        both = {"shift_pinion": 0.5, "shift_wheel": 0.0, "shift_crank_gear": 0.5}
        raise DesignError(f"{exc}; {_suggest(s, [*zeros, both])}") from exc
    a01, a02 = 0.5 * m * (zp + zw), 0.5 * m * (zc - zw)
    a = a01 * math.cos(alpha) / math.cos(aw1)
    a2_zero = a02 * math.cos(alpha) / math.cos(aw2)
    _check_centre_distances(s, a, a2_zero, a02)
    aw2_at_a = _working(a02, alpha, a)

    p0, w0, c0 = s.gear("pinion"), s.gear("wheel"), s.gear("crank_gear")
    c = (s.dedendum - s.addendum) * m  # bottom clearance kept at the centre distance a
    ra_p = min(p0.nominal_tip_radius, a - w0.root_radius - c)
    ra_w = min(w0.nominal_tip_radius, a - p0.root_radius - c, c0.root_radius - a - c)
    ra_c = max(c0.nominal_tip_radius, a + w0.root_radius + c)
    pin, whl, crk = s.gear("pinion", ra_p), s.gear("wheel", ra_w), s.gear("crank_gear", ra_c)
    if crk.tip <= crk.base_radius:
        raise DesignError(
            f"shift_crank_gear = {s.shift_crank_gear:g}: the crank gear's tip circle "
            f"({_fmt(crk.tip)} mm) lies inside its base circle ({_fmt(crk.base_radius)} mm), "
            "tip interference of the internal mesh; raise shift_crank_gear"
        )

    for part, g in (("pinion", pin), ("wheel", whl), ("crank_gear", crk)):
        _tip_thickness(s, g, part)

    def length(g: GearTeeth) -> float:  # tip to base tangency along the line of action
        return math.sqrt(g.tip**2 - g.base_radius**2)

    def form(g: GearTeeth) -> float:
        return math.sqrt(max(g.form_radius() ** 2 - g.base_radius**2, 0.0))

    pitch_b = math.pi * m * math.cos(alpha)
    t1 = a * math.sin(aw1)  # T_pinion to T_wheel
    t2 = a * math.sin(aw2_at_a)  # T_crank to T_wheel (same side)
    eps1 = (length(pin) + length(whl) - t1) / pitch_b
    eps2 = (length(whl) - length(crk) + t2) / pitch_b

    # Each flank must be in contact above its form circle (fillet interference).
    starts = (  # (gear, mesh, its key, where contact begins, where its involute begins)
        ("pinion", "pinion-wheel", "shift_pinion", t1 - length(whl), form(pin)),
        ("wheel", "pinion-wheel", "shift_wheel", t1 - length(pin), form(whl)),
        ("wheel", "wheel-crank gear", "shift_crank_gear", length(crk) - t2, form(whl)),
    )
    for part, mesh, key, got, need in starts:
        if got < need - 1e-9:
            kind = "fillet" if got >= 0 else "involute (below the base circle)"
            raise DesignError(
                f"{key} = {getattr(s, key):g}: in the {mesh} mesh the mating tip reaches the "
                f"{part}'s root, {_fmt(got)} mm along the line of action where its involute "
                f"begins at {_fmt(need)} mm: {kind} interference; raise {key}"
            )
    deep = t2 + length(whl)  # the wheel's tip in the crank gear's space, from T_crank
    if deep > form(crk) + 1e-9:
        raise DesignError(
            f"shift_crank_gear = {s.shift_crank_gear:g}: the wheel's tip reaches the crank "
            f"gear's root fillet ({_fmt(deep)} mm along the line of action, its involute ends "
            f"at {_fmt(form(crk))} mm): fillet interference of the internal mesh; "
            "raise dedendum or lower shift_wheel"
        )
    margin = _trochoid_margin(whl, crk, a, aw2_at_a)
    if margin < 0:
        raise DesignError(
            f"crank_gear_teeth = {zc}: the wheel's tips clash with the crank gear's teeth "
            f"leaving the mesh (trochoid interference, margin {margin:.3g} rad): tip "
            f"interference of the internal mesh; allowed is more teeth difference than "
            f"{zc - zw} (raise crank_gear_teeth by a multiple of 3) or a larger shift_crank_gear"
        )
    for eps, mesh in ((eps1, "pinion-wheel"), (eps2, "wheel-crank gear")):
        if eps < MIN_CONTACT_RATIO:
            raise DesignError(
                f"module = {m:g}: the {mesh} mesh has a contact ratio of {eps:.3f}; allowed "
                f"range is >= {MIN_CONTACT_RATIO:g}: use more teeth at a smaller module, "
                "smaller shifts or addendum = 1"
            )

    # Circumferential backlash on the working pitch circles at the centre distance a.
    rw_p, rw_w = pin.base_radius / math.cos(aw1), whl.base_radius / math.cos(aw1)
    j1 = 2 * math.pi * rw_p / zp - pin.thickness_at(rw_p) - whl.thickness_at(rw_w)
    rw_w2, rw_c = whl.base_radius / math.cos(aw2_at_a), crk.base_radius / math.cos(aw2_at_a)
    j2 = 2 * math.pi * rw_c / zc - crk.thickness_at(rw_c) - whl.thickness_at(rw_w2)
    if j2 < -1e-9:
        x = _fitting_crank_shift(s, a)
        raise DesignError(
            f"shift_crank_gear = {s.shift_crank_gear:g}: at the wheels' centre distance "
            f"{_fmt(a)} mm (set by the pinion mesh) the internal mesh jams (backlash "
            f"{_fmt(j2)} mm, its own zero-backlash distance {_fmt(a2_zero)} mm); "
            + _suggest(s, [{"shift_crank_gear": x} if x is not None else {}])
        )
    gap = a * math.sqrt(3.0) - 2.0 * whl.tip
    if gap <= 0:
        raise DesignError(
            f"wheel_teeth = {zw}: neighbouring wheels collide (tip circles overlap by "
            f"{_fmt(-gap)} mm at {_fmt(a)} mm from the axis, 120 deg apart); use fewer wheel "
            "teeth and more crank gear teeth, or a larger pinion"
        )
    return FirstStageGeometry(
        s,
        pin,
        whl,
        crk,
        a,
        (math.degrees(aw1), math.degrees(aw2_at_a)),
        (a, a2_zero),
        (eps1, eps2),
        (j1, j2),
        gap,
    )
