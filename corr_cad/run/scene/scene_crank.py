"""``[crankshaft]`` and ``[bearings.crank]``: the crankshaft on its support bearings
(:class:`~corr_cad.mechanics.drive.drive_crank.CrankSupport`), with defaults derived from the
design.

Either section puts the crankshaft and its support bearings into the drive's solve; a
scene with neither keeps the eccentrics rigid (as before the sections existed). What a
section leaves out is derived from the design (:func:`default_layout`), and the run says
so on the console and in ``datasheet.json``.
"""

from __future__ import annotations

import math
from typing import Any

from corr_cad.errors import CorrCadError, SceneError
from corr_cad.mechanics.crank.crankshaft import Crankshaft
from corr_cad.mechanics.crank.support_bearing import SupportBearing
from corr_cad.mechanics.drive.drive_crank import CrankSupport

__all__ = ["CRANK_SECTION_NAMES", "default_layout", "parse_crank"]

CRANK_SECTION_NAMES = ("crankshaft", "bearings.crank")


def default_layout(
    design, needle_diameter: float | None, shaft_diameter: float | None = None, width=None
) -> dict[str, Any]:
    """The shaft and support bearing a designer would draw for this design (mm).

    * eccentric journal: the cam's bore less two needles (``2 R_bore - 2 D_needle``) with
      ``[bearings.eccentric]``, the bore itself without (the cam sits on the eccentric);
      length the roller length;
    * eccentrics at the rows' mid-planes: ``w / 2`` and ``w + t + w / 2`` (``w`` the
      roller length, ``t`` the frame plate);
    * shaft: 0.8 of the largest shaft inside the eccentric journal (``d_e - 2 e``), to
      the whole millimetre below (or the scene's ``shaft_diameter``);
    * support bearing: a cylindrical roller bearing on the shaft (``d``): rollers of
      ``0.2 d``, as long as thick, on the pitch diameter ``1.45 d``, as many as fit
      with 25 % of gaps, width ``1.8 D`` (an NU 2xx series' proportions; or the scene's
      ``width``);
    * supports: each in a housing wall one plate (``t``) beyond the frame's outer
      plates, at half its width more: ``-2 t - B / 2`` and ``2 w + 3 t + B / 2``;
    * crank gear: one bearing width beyond the first support (a pure torque: three
      wheels 120 degrees apart).
    """
    w, t, e = design.roller_length, design.frame_thickness, design.eccentricity
    bore = 2.0 * design.cam_bore_radius
    d_e = bore - 2.0 * needle_diameter if needle_diameter is not None else bore
    d = float(math.floor(0.8 * (d_e - 2.0 * e))) if shaft_diameter is None else shaft_diameter
    D = max(float(round(0.2 * d)), 1.0)
    dm = 1.45 * d
    z = max(int(math.floor(math.pi * dm / (1.25 * D))), 3)
    B = float(round(1.8 * D)) if width is None else float(width)
    z1, z2 = -2.0 * t - 0.5 * B, 2.0 * w + 3.0 * t + 0.5 * B
    return {
        "shaft_diameter": d,
        "eccentric_diameter": d_e,
        "eccentric_length": w,
        "eccentric_positions": [0.5 * w, 1.5 * w + t],
        "support_positions": [z1, z2],
        "gear_position": z1 - B,
        "rollers": z,
        "roller_diameter": D,
        "roller_length": D,
        "pitch_diameter": dm,
        "width": B,
    }


def parse_crank(values: dict, data: dict, design, bearing, formats=()) -> CrankSupport | None:
    """The scene's crankshaft and support bearings (None without either section). Every
    output that solves the drive takes it (``formats`` is not consulted); with
    ``[solver] bodies = "elastic"`` the drive couples both."""
    given = [s for s in CRANK_SECTION_NAMES if s in data]
    if not given:
        return None
    return _parse(values, data, design, bearing)


def _parse(values: dict, data: dict, design, bearing) -> CrankSupport:
    shaft_v = values["crankshaft"]
    brg_v = values["bearings.crank"]
    needle = bearing.needle_diameter if bearing is not None else None
    dflt = default_layout(design, needle, shaft_v["shaft_diameter"], brg_v["width"])
    kind = brg_v["type"]
    derived: list[str] = []

    def pick(section: str, vals: dict, key: str):
        v = vals.get(key)
        if v is None:
            derived.append(f"[{section}] {key}")
            return dflt[key]
        return v

    support = None
    if kind == "cylindrical" and brg_v["contact_angle_deg"] is not None:
        raise SceneError(
            f"[bearings.crank] contact_angle_deg = {brg_v['contact_angle_deg']:g}: a "
            'cylindrical roller bearing has none; remove it or set type = "tapered_pair"'
        )
    if kind != "rigid":
        angle = brg_v["contact_angle_deg"]
        try:
            support = SupportBearing(
                kind,
                pick("bearings.crank", brg_v, "rollers"),
                pick("bearings.crank", brg_v, "roller_diameter"),
                pick("bearings.crank", brg_v, "roller_length"),
                pick("bearings.crank", brg_v, "pitch_diameter"),
                clearance=brg_v["clearance"],
                contact_angle_deg=0.0 if kind == "cylindrical" else (angle or 15.0),
                width=pick("bearings.crank", brg_v, "width"),
                dynamic_load_rating=brg_v["dynamic_load_rating_N"],
            )
        except CorrCadError as exc:
            raise SceneError(f"[bearings.crank] {exc}") from exc
        _check_support(support, dflt, brg_v["rollers"] is not None, brg_v["pitch_diameter"])
    for key in ("eccentric_positions", "support_positions"):
        v = shaft_v[key]
        if v is not None and len(v) != 2:
            raise SceneError(
                f"[crankshaft] {key} has {len(v)} values; give two, e.g. {dflt[key]!r}"
            )
    try:
        shaft = Crankshaft(
            pick("crankshaft", shaft_v, "shaft_diameter"),
            pick("crankshaft", shaft_v, "eccentric_diameter"),
            pick("crankshaft", shaft_v, "eccentric_length"),
            tuple(pick("crankshaft", shaft_v, "eccentric_positions")),
            tuple(pick("crankshaft", shaft_v, "support_positions")),
            pick("crankshaft", shaft_v, "gear_position"),
            bore_diameter=shaft_v["bore_diameter"],
            young_modulus=shaft_v["young_modulus_MPa"],
            poisson_ratio=shaft_v["poisson_ratio"],
        )
    except CorrCadError as exc:
        raise SceneError(f"[crankshaft] {exc}") from exc
    _check_layout(shaft, design, needle, dflt, derived)
    shaft_src = (
        "scene"
        if not any(s.startswith("[crankshaft]") for s in derived)
        else ("derived from the design" if "crankshaft" not in data else "scene, the rest derived")
    )
    brg_src = (
        "scene"
        if not any(s.startswith("[bearings.crank]") for s in derived)
        else (
            "derived from the design" if "bearings.crank" not in data else "scene, the rest derived"
        )
    )
    return CrankSupport(
        shaft,
        support,
        shaft_source=shaft_src,
        bearing_source=brg_src,
        derived=tuple(derived),
    )


def _check_layout(shaft: Crankshaft, design, needle: float | None, dflt: dict, derived) -> None:
    """The shaft the files draw: each eccentric journal under its own row's cam, the shaft
    inside the journal (``d <= d_e - 2 e``), the needles between the journal and the cam's
    bore (``d_e + 2 D <= 2 R_bore``). One line naming the key the scene gave."""
    w, t, e = design.roller_length, design.frame_thickness, design.eccentricity
    bore = 2.0 * design.cam_bore_radius
    tol = 1e-9
    given_de = "[crankshaft] eccentric_diameter" not in derived
    d, d_e = shaft.shaft_diameter, shaft.eccentric_diameter
    if needle is not None and d_e + 2.0 * needle > bore + tol:
        raise SceneError(
            f"[crankshaft] eccentric_diameter = {d_e:g}: the needles ({needle:g} mm) must fit "
            f"between the journal and the cam's bore ({bore:g} mm): allowed range is "
            f"(0, {bore - 2.0 * needle:g}] mm, e.g. {dflt['eccentric_diameter']:g}"
        )
    if d > d_e - 2.0 * e + tol:
        if given_de:
            raise SceneError(
                f"[crankshaft] eccentric_diameter = {d_e:g}: the journal must hold the shaft "
                f"(shaft_diameter {d:g} + 2 e = {d + 2.0 * e:g} mm at least), e.g. "
                f"{max(dflt['eccentric_diameter'], d + 2.0 * e):g}"
            )
        raise SceneError(
            f"[crankshaft] shaft_diameter = {d:g}: the shaft must lie inside the eccentric "
            f"journal (diameter {d_e:g} mm at eccentricity {e:g} mm): allowed range is "
            f"(0, {d_e - 2.0 * e:g}] mm, e.g. {math.floor(0.8 * (d_e - 2.0 * e)):g}"
        )
    spans = ((0.0, w), (w + t, 2.0 * w + t))
    for name, z, (lo, hi) in zip("AB", shaft.eccentric_positions, spans, strict=True):
        if not lo - tol <= z <= hi + tol:
            raise SceneError(
                f"[crankshaft] eccentric_positions = {list(shaft.eccentric_positions)}: "
                f"eccentric {name} must lie under row {name}'s cam, z in [{lo:g}, {hi:g}] mm, "
                f"e.g. {dflt['eccentric_positions']!r}"
            )


def _check_support(support: SupportBearing, dflt: dict, rollers_given: bool, pitch_given) -> None:
    """A support bearing that can be built: its rollers side by side on the pitch circle
    (``d_m sin(pi / Z) > D``) and its inner raceway on the shaft (``d_m - D >= d``)."""
    n, D, dm = support.rollers, support.roller_diameter, support.pitch_diameter
    shaft = dflt["shaft_diameter"]  # the scene's, or the derived one
    pitch = f"{dm:g}" + (
        "" if pitch_given is not None else f" (derived from the {shaft:g} mm shaft)"
    )
    if dm * math.sin(math.pi / n) <= D:
        most = math.ceil(math.pi / math.asin(min(1.0, D / dm))) - 1
        if not rollers_given or most < 3:  # name the pitch circle: no count fits, or derived
            least = D / math.sin(math.pi / n)
            how = " (derived)" if not rollers_given else ""
            raise SceneError(
                f"[bearings.crank] pitch_diameter = {pitch}: the {n} rollers of {D:g} mm{how} "
                f"do not fit on it; allowed range is ({least:.4g}, 5000] mm, e.g. "
                f"{max(dflt['pitch_diameter'], math.ceil(least + 1.0), shaft + D):g}"
            )
        raise SceneError(
            f"[bearings.crank] rollers = {n}: {n} rollers of {D:g} mm do not fit on the pitch "
            f"circle of {dm:g} mm; allowed range is [3, {most}], e.g. {min(dflt['rollers'], most)}"
        )
    if dm - D < shaft - 1e-9:
        raise SceneError(
            f"[bearings.crank] pitch_diameter = {pitch}: the inner raceway ({dm - D:g} mm) must "
            f"sit on the shaft ({shaft:g} mm): allowed range is [{shaft + D:g}, 5000] mm, e.g. "
            f"{max(dflt['pitch_diameter'], shaft + D):g}"
        )
