"""The two-row drive's part of a scene: ``[solver] model``, ``contact_law``,
``[errors.row_b]`` and the eccentric bearings (:mod:`corr_cad.run.scene.scene_schema_drive`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

from corr_cad.bounds import range_text, show
from corr_cad.errors import CorrCadError, SceneError
from corr_cad.geometry.deviations import ManufacturingErrors, harmonic_deviation
from corr_cad.mechanics.crank.bearing import EccentricBearing
from corr_cad.run.scene.scene_schema_drive import SECTIONS

__all__ = [
    "check_drive_tolerances",
    "check_inspection_row",
    "with_slot_fit",
    "SolverSpec",
    "split_drive_tables",
    "parse_drive",
    "recorded",
]


@dataclass(frozen=True)
class SolverSpec:
    """``[solver]``: positions, load share, angles, variants, the model and the contact law."""

    positions: int = 3600
    load_share: float = 0.55
    crank_angles_deg: tuple[float, ...] | None = None
    variants: tuple[str, ...] = ()
    #: ``"paper"``: one row carrying ``load_share``; ``"drive"``: both rows together.
    model: str = "paper"
    #: ``"paper"`` (Eqs. 9-12) or ``"palmgren"``.
    contact_law: str = "paper"
    #: ``"rigid"`` or ``"elastic"``: the ring and the frame (:mod:`corr_cad.mechanics.bodies`).
    bodies: str = "rigid"

    @property
    def contact_model(self) -> str:
        """The mechanics' ``contact_model`` of the contact law."""
        return "palmgren" if self.contact_law == "palmgren" else "nonlinear"

    @property
    def drive(self) -> bool:
        """True under ``model = "drive"``."""
        return self.model == "drive"


#: Keys of ``[solver]`` recorded in the run's inputs only when the scene gives them
#: (a scene without them keeps the bytes it had before they existed).
_NEW_SOLVER_KEYS = ("model", "contact_law", "bodies")


def split_drive_tables(data: dict) -> dict:
    """``[errors.row_b]`` and ``[bearings.eccentric(_b)]`` as sections of their own."""
    if not isinstance(data, dict):
        return data
    out = dict(data)
    err = data.get("errors")
    if isinstance(err, dict) and "row_b" in err:
        out["errors"] = {k: v for k, v in err.items() if k != "row_b"}
        out["errors.row_b"] = err["row_b"]
    if "bearings" in data:
        bearings = out.pop("bearings")
        if not isinstance(bearings, dict):
            raise SceneError(f"[bearings] must be a table, got {show(bearings)}")
        for k, v in bearings.items():
            if k not in ("eccentric", "eccentric_b", "crank"):
                raise SceneError(
                    f"unknown table {show(k)} in [bearings]; valid tables: eccentric, "
                    "eccentric_b, crank"
                )
            out[f"bearings.{k}"] = v
    return out


# Sections recorded in the run's inputs only where the scene gives them.
OPTIONAL_SECTIONS = (
    "friction",
    "life",
    "first_stage",
    "lubrication",
    "thermal",
    "thermal.test",
    "sizing",
    "sizing.requirements",
    "sizing.variables",
)


def recorded(section: str, key: str, data: dict) -> bool:
    """Whether ``[section] key`` goes into the run's recorded inputs."""
    if section in SECTIONS or section in OPTIONAL_SECTIONS:
        return section_given(section, data)
    if section == "solver" and key in _NEW_SOLVER_KEYS:
        return key in (data.get("solver") or {})
    return True


def section_given(section: str, data: dict) -> bool:
    return section in data


def _check(where: str, v: float, low: float, high: float) -> None:
    if not (low < v < high):
        raise SceneError(
            f"{where} = {v:g}: allowed range is {range_text(low, high, high_open=True)}, e.g. 0"
        )


def check_harmonic_sum(where: str, harmonics, half_r: float) -> None:
    """The harmonics' amplitudes may add up at one point: their magnitudes' sum is bounded
    as each amplitude is, below half the roller radius (100 rows of 3.9 mm on an 8 mm
    roller each passed and the drive's solver met a NaN)."""
    total = math.fsum(abs(a) for _, a, _ in harmonics or ())
    if total >= half_r:
        scale = math.floor(0.999 * half_r / total * 1e4) / 1e4
        raise SceneError(
            f"{where}: the amplitudes' magnitudes sum to {total:g} mm, and the deviation can "
            f"reach their sum; allowed is a sum below half the roller radius, {half_r:g} mm; "
            f"a value that works: every amplitude times {scale:g} (sum {total * scale:.4g} mm)"
        )


def _row_b_errors(rb: dict, design) -> ManufacturingErrors:
    half_r = 0.5 * design.roller_radius
    for key in ("cam_radius_error", "eccentricity_error", "roller_radius_error"):
        _check(f"[errors.row_b] {key}", rb[key], -half_r, half_r)
    per = rb["roller_radius_errors"]
    if per is not None and len(per) != design.roller_count:
        raise SceneError(
            f"[errors.row_b] roller_radius_errors has {len(per)} values; the design has "
            f"{design.roller_count} rollers (tooth_count + 1)"
        )
    for v in per or ():
        _check("[errors.row_b] roller_radius_errors", v, -half_r, half_r)
    harmonics = rb["profile_deviation_harmonics"]
    for order, amplitude, phase in harmonics or ():
        where = "[errors.row_b] profile_deviation_harmonics"
        if not (order == int(order) and 1 <= order <= 10000):
            raise SceneError(f"{where}: order {order:g} must be an integer in [1, 10000]")
        _check(f"{where} amplitude", amplitude, -half_r, half_r)
        if not -3600.0 <= phase <= 3600.0:
            raise SceneError(f"{where} phase = {phase:g}: allowed range is [-3600, 3600]")
    check_harmonic_sum("[errors.row_b] profile_deviation_harmonics", harmonics, half_r)
    return ManufacturingErrors(
        rb["cam_radius_error"],
        rb["eccentricity_error"],
        rb["roller_radius_error"],
        tuple(per) if per is not None else None,
        None,
        0.0,
        harmonic_deviation(harmonics) if harmonics else None,
    )


def _bearing(section: str, given: dict, base: dict | None) -> EccentricBearing:
    vals = {k: v for k, v in given.items() if v is not None}
    if base is not None:
        vals = {**base, **vals}
    missing = [k for k in ("needles", "needle_diameter", "needle_length") if k not in vals]
    if missing:
        raise SceneError(
            f"[{section}] {missing[0]} is not set; a bearing needs needles, needle_diameter and "
            "needle_length (e.g. needles = 40, needle_diameter = 6.0, needle_length = 12.0)"
        )
    try:
        return EccentricBearing(
            vals["needles"],
            vals["needle_diameter"],
            vals["needle_length"],
            vals.get("diametral_clearance") or 0.0,
        )
    except CorrCadError as exc:
        raise SceneError(f"[{section}] {exc}") from exc


def check_drive_tolerances(tolerances: dict, formats: tuple, solver, checks, data=None) -> None:
    """What the drive model and Palmgren's law do not reach yet, refused in one line."""
    if "slot_clearance" in tolerances and not solver.drive:
        raise SceneError(
            "[tolerances] slot_clearance: the slots' fit acts under [solver] model = "
            '"drive" only; set model = "drive" or remove it'
        )
    what = (
        'model = "drive"'
        if solver.drive
        else ('contact_law = "palmgren"' if solver.contact_law != "paper" else None)
    )
    if what is None:
        return
    if "modification" in formats and not solver.drive:
        raise SceneError(
            "[export] formats lists 'modification', whose design solves the paper's contact "
            'law only on the paper\'s row; with [solver] contact_law = "palmgren" use model = '
            '"drive" (its design takes the law) or remove it'
        )
    if {"montecarlo", "allocation"} & set(formats) and not solver.drive:
        raise SceneError(
            "[export] formats lists montecarlo or allocation, which solve the paper's contact "
            "law only; "
            'with [solver] contact_law = "palmgren" use model = "drive" (its Monte Carlo '
            "takes the law) or remove it"
        )


def check_inspection_row(row, formats, measured_a, drive: dict, model: str) -> None:
    """``[inspection] row``: which measured ring the inspection reads, refused in one line
    where that ring is not given (ring B exists under the drive only)."""
    if row == "b" and model != "drive":
        raise SceneError(
            '[inspection] row = "b": ring B is solved under [solver] model = "drive" only; '
            'remove it (row "a" is the default) or set model = "drive"'
        )
    if "inspection" not in formats:
        return
    if row == "b" and drive["measured_profile_b"] is None:
        raise SceneError(
            "[export] formats lists 'inspection' with [inspection] row = \"b\" but "
            "[errors.row_b] measured_profile is not set"
        )
    if row != "b" and measured_a is None:
        other = drive["measured_profile_b"] is not None  # ring B's file alone is given
        raise SceneError(
            "[export] formats lists 'inspection' but [errors] measured_profile is not set"
            + ('; to inspect ring B\'s file set [inspection] row = "b"' if other else "")
        )


def with_slot_fit(errors: ManufacturingErrors, slot_clearance, model: str):
    """The scene's errors with the slots' fit of ``[design] slot_clearance`` (the drive's)."""
    from dataclasses import replace

    if model != "drive":
        if slot_clearance:
            raise SceneError(
                f"[design] slot_clearance = {slot_clearance:g}: acts under [solver] model = "
                '"drive" only (the paper\'s row takes an oversize roller up in its slot); set '
                'model = "drive" or remove it'
            )
        return errors
    return replace(errors, slot_clearance=float(slot_clearance or 0.0))


def parse_drive(values: dict[str, dict[str, Any]], data: dict, design) -> dict:
    """The drive's settings: model, contact law, row B's errors and the bearings (a dict).

    The sections' values are checked first, whatever the model (a bad value is
    named as such), then whether the model uses them.
    """
    sv = values["solver"]
    model, law = sv["model"], sv["contact_law"]
    given = data.get("solver") or {}
    errors_b = _row_b_errors(values["errors.row_b"], design) if "errors.row_b" in data else None
    bearing = bearing_b = None
    if "bearings.eccentric" in data:
        base = {k: v for k, v in values["bearings.eccentric"].items() if v is not None}
        bearing = _bearing("bearings.eccentric", values["bearings.eccentric"], None)
        bearing_b = (
            _bearing("bearings.eccentric_b", values["bearings.eccentric_b"], base)
            if "bearings.eccentric_b" in data
            else bearing
        )
    elif "bearings.eccentric_b" in data:
        raise SceneError(
            "[bearings.eccentric_b] overrides [bearings.eccentric] for cam B; give "
            "[bearings.eccentric] too (both cams float on bearings, or neither)"
        )
    drive_sections = [s for s in SECTIONS if s in data]
    if model != "drive" and drive_sections:
        raise SceneError(
            f'[{drive_sections[0]}] acts under [solver] model = "drive" only; '
            'set model = "drive" or remove the section'
        )
    if sv["bodies"] == "elastic" and model != "drive":
        raise SceneError(
            '[solver] bodies = "elastic": the elastic ring and frame act under model = "drive" '
            'only; set model = "drive" or bodies = "rigid"'
        )
    if sv["bodies"] == "elastic" and design.allow_undercut:
        from corr_cad.geometry.profile import undercut_analysis

        if undercut_analysis(design).undercut:
            raise SceneError(
                '[solver] bodies = "elastic": the ring of an allowed undercut (trimmed tooth '
                'tips) is not modelled by finite elements; set bodies = "rigid" or a roller '
                f"radius below {undercut_analysis(design).admissible_roller_radius:.6g} mm"
            )
    if model == "drive" and "load_share" in given:
        raise SceneError(
            f'[solver] load_share = {sv["load_share"]:g}: has no meaning under model = "drive" '
            "(both rows carry M0 together; the share is a result); remove it, or use "
            'model = "paper"'
        )
    if model == "drive" and sv["variants"]:
        raise SceneError(
            f"[solver] variants = {sv['variants']!r}: the printed-paper variants reproduce the "
            'paper\'s one-row model; remove them, or use model = "paper"'
        )
    measured_b = values["errors.row_b"]["measured_profile"] if "errors.row_b" in data else None
    if measured_b is not None and values["errors.row_b"]["profile_deviation_harmonics"]:
        raise SceneError(
            "[errors.row_b] measured_profile and profile_deviation_harmonics both describe ring "
            "B's profile; keep one"
        )
    return {
        "model": model,
        "contact_law": law,
        "errors_b": errors_b,
        "measured_profile_b": measured_b,
        "bearing": bearing,
        "bearing_b": bearing_b,
    }
