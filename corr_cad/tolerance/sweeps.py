"""Parametric sweeps around a design (the paper's Section 4 studies), and the paper comparison.

Each sweep varies one design parameter or one error and solves a full cycle
per point. The range of each sweep is ``[sweeps] <name> = [min, max]`` (mm)
when given; otherwise +-20 % around the scene's design for the design
parameters and +-0.02 mm around the scene's error for the errors
(:data:`DEFAULT_ERROR_HALF_RANGE`). For the paper's Table 1 design the
default ranges are the paper's own, so that ``sweeps_vs_paper.csv`` compares
like with like. Every range is clipped to the valid design space: the
undercut limit (the working profile would self-intersect), the collision
limit (adjacent rollers touch) and the other limits of :class:`GearDesign`;
errors to less than half the roller radius. The limits are reported with
the points.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import replace

import numpy as np

from corr_cad.errors import CorrCadError, DesignError
from corr_cad.geometry.design import GearDesign
from corr_cad.geometry.deviations import ManufacturingErrors
from corr_cad.geometry.profile import min_speed_factor, undercut_analysis
from corr_cad.mechanics.row.solver import solve_forces

__all__ = [
    "PAPER_SWEEPS",
    "PAPER_QUOTES",
    "SWEEP_UNITS",
    "DEFAULT_DESIGN_SPAN",
    "DEFAULT_ERROR_HALF_RANGE",
    "is_paper_design",
    "sweep_range",
    "sweep_point",
    "run_sweeps",
    "comparison_rows",
]

#: name -> (what varies, start, end); the paper's Section 4 ranges.
PAPER_SWEEPS = {
    "eccentricity": ("design", 2.5, 4.0),
    "roller_radius": ("design", 7.0, 20.0),
    "cam_radius": ("design", 125.0, 170.0),
    "cam_radius_error": ("errors", -0.02, 0.02),
    "eccentricity_error": ("errors", -0.01, 0.05),
    "roller_radius_error": ("errors", -0.02, 0.02),
}

#: What the paper quotes at the ends of each range (N), Section 4 text.
PAPER_QUOTES = {
    "eccentricity": {"F_j_mean": (2430, 2050), "F_j_peak": (4100, 2100)},
    "roller_radius": {
        "F_j_mean": (1735, 1724),
        "F_n_mean": (1770, 1757),
        "F_s_mean": (229, 221),
        "F_j_peak": (2990, 2970),
        "F_s_peak_to_peak": (1140, 1050),
    },
    "cam_radius": {
        "F_j_mean": (1733, 1710),
        "F_n_mean": (1775, 1746),
        "F_s_mean": (245, 180),
        "F_j_peak": (2999, 2952),
        "F_n_peak": (3003, 2955),
        "F_s_peak_to_peak": (1200, 920),
    },
    "cam_radius_error": {
        "F_j_mean": (1745, 1710),
        "F_n_mean": (1784, 1749),
        "F_s_mean": (229, 225),
        "F_j_peak": (2960, 3230),
        "F_n_peak": (2958, 3022),
        "F_s_peak_to_peak": (1120, 1139),
    },
    "eccentricity_error": {"F_s_mean": (239, 181), "F_s_peak_to_peak": (1150, 960)},
    "roller_radius_error": {
        "F_j_mean": (1800, 1680),
        "F_n_mean": (1840, 1720),
        "F_s_mean": (246, 210),
        "F_j_peak": (2860, 3100),
    },
}

METRICS = ("F_j_mean", "F_n_mean", "F_s_mean", "F_j_peak", "F_n_peak", "F_s_peak_to_peak")


#: Unit of each swept value (all lengths).
SWEEP_UNITS = dict.fromkeys(PAPER_SWEEPS, "mm")

#: Default half-span of a design-parameter sweep, relative to the design value.
DEFAULT_DESIGN_SPAN = 0.20

#: Default half-range of an error sweep around the scene's value, mm: the
#: paper's +-0.02 mm, already ten times the elastic approach at rated load.
DEFAULT_ERROR_HALF_RANGE = 0.02

_DERIVED = ("ring_outer_radius", "cam_bore_radius", "frame_inner_radius", "frame_outer_radius")

#: The paper's Table 1 design (Wei et al. 2021): what ``GearDesign()`` defaults to.
_TABLE1 = {
    "tooth_count": 25,
    "cam_radius": 135.0,
    "roller_radius": 8.0,
    "eccentricity": 3.5,
    "roller_length": 12.0,
}


def is_paper_design(design: GearDesign) -> bool:
    """True for the paper's Table 1 design (z 25, Rj 135, r 8, e 3.5, l 12 mm, steel).

    >>> is_paper_design(GearDesign())
    True
    >>> is_paper_design(GearDesign(tooth_count=39))
    False
    """
    m = design.material
    return (
        all(getattr(design, k) == v for k, v in _TABLE1.items())
        and m.young_modulus == 2.06e5
        and m.poisson_ratio == 0.3
    )


def _design_at(design: GearDesign, name: str, value: float) -> GearDesign:
    """``design`` with one parameter changed; radii derived from it (ring rim,
    bore, frame plate) follow the swept value; they do not enter the forces."""
    return replace(design, **{name: value}, **dict.fromkeys(_DERIVED))


def _why_invalid(design: GearDesign, name: str, value: float) -> str | None:
    """``None`` if the design with ``name = value`` is valid, else the reason."""
    try:
        d = _design_at(design, name, value)
    except DesignError as exc:
        msg = str(exc)
        return "adjacent rollers collide" if "collide" in msg else msg.split(";")[0]
    # The closed-form undercut test (as undercut_analysis, without the extras).
    if min_speed_factor(d.tooth_count, d.eccentricity, d.link_length, d.roller_radius)[0] < 0:
        return "undercut"
    return None


def _boundary(design: GearDesign, name: str, good: float, bad: float) -> tuple[float, str]:
    """Last valid value between ``good`` (valid) and ``bad`` (invalid), to 1e-7 relative,
    and why the values just beyond it are invalid."""
    for _ in range(200):
        if abs(bad - good) <= 1e-7 * max(abs(good), abs(bad)):
            break
        mid = 0.5 * (good + bad)
        if _why_invalid(design, name, mid) is None:
            good = mid
        else:
            bad = mid
    return good, _why_invalid(design, name, bad) or "invalid"


def sweep_range(
    design: GearDesign,
    name: str,
    requested: tuple[float, float] | None = None,
    base_errors: ManufacturingErrors | None = None,
) -> dict:
    """The range a sweep runs over, clipped to the valid design space.

    Returns ``{"name", "unit", "source", "requested", "swept", "clipped_low",
    "clipped_high"}``: ``source`` is ``"scene"`` (``requested`` given),
    ``"paper"`` (the paper's Section 4 range, default for the Table 1 design)
    or ``"default"`` (+-20 % of the design value; +-0.02 mm around the
    scene's error); ``clipped_*`` name the limit that cut the range (or
    ``None``); ``swept`` is ``None`` when no valid value lies in the range.

    >>> d = GearDesign(tooth_count=39, eccentricity=2.0, roller_radius=6.0)
    >>> r = sweep_range(d, "roller_radius")
    >>> r["source"], r["requested"], round(r["swept"][1], 3), r["clipped_high"]
    ('default', [4.8, 7.2], 6.839, 'undercut')
    >>> r = sweep_range(GearDesign(), "roller_radius")
    >>> r["source"], round(r["swept"][1], 3), r["clipped_high"]
    ('paper', 10.053, 'undercut')
    """
    where, p_lo, p_hi = PAPER_SWEEPS[name]
    if requested is not None:
        lo, hi = (float(v) for v in requested)
        source = "scene"
    elif is_paper_design(design):
        lo, hi, source = p_lo, p_hi, "paper"
    elif where == "design":
        v = float(getattr(design, name))
        lo, hi, source = v * (1 - DEFAULT_DESIGN_SPAN), v * (1 + DEFAULT_DESIGN_SPAN), "default"
    else:
        base = getattr(base_errors or ManufacturingErrors(), name)
        lo, hi = base - DEFAULT_ERROR_HALF_RANGE, base + DEFAULT_ERROR_HALF_RANGE
        source = "default"
    lo, hi = round(lo, 12), round(hi, 12)
    out = {
        "name": name,
        "unit": SWEEP_UNITS[name],
        "source": source,
        "requested": [lo, hi],
        "swept": [lo, hi],
        "clipped_low": None,
        "clipped_high": None,
    }
    if where == "errors":
        # The small-displacement model takes errors below half the roller radius.
        cap = 0.5 * design.roller_radius * (1 - 1e-9)
        if lo < -cap:
            out["swept"][0], out["clipped_low"] = -cap, "error below half the roller radius"
        if hi > cap:
            out["swept"][1], out["clipped_high"] = cap, "error below half the roller radius"
        if out["swept"][0] > out["swept"][1]:
            out["swept"] = None
        return out
    v0 = float(getattr(design, name))
    centre_ok = lo <= v0 <= hi and _why_invalid(design, name, v0) is None
    if not centre_ok:
        # The design value is outside the range (or invalid): look for any valid point.
        grid = np.linspace(lo, hi, 65)
        good = [g for g in grid if _why_invalid(design, name, float(g)) is None]
        if not good:
            out["swept"] = None
            out["clipped_low"] = out["clipped_high"] = _why_invalid(design, name, lo)
            return out
        v0 = float(good[len(good) // 2])
    for end, side in ((lo, 0), (hi, 1)):
        if _why_invalid(design, name, end) is not None:
            out["swept"][side], why = _boundary(design, name, v0, end)
            out["clipped_low" if side == 0 else "clipped_high"] = why
    return out


def sweep_point(
    design: GearDesign,
    name: str,
    value: float,
    input_torque: float,
    positions: int,
    load_share: float,
    drive: dict | None = None,
) -> dict:
    """One sweep point: status ``ok``, ``undercut`` or ``invalid``, and roller 1's forces.

    ``drive``: the two-row drive model (keyword arguments of
    :func:`~corr_cad.mechanics.drive.drive.solve_drive`: ``bearing``, ``bearing_b``,
    ``contact_model``, ``crank``, ``bodies``); roller 1 is then row A's, and the
    swept error both rows'. An error's sweep solves on the nominal design's body
    tables; a design's sweep on that design's own (``bodies_for(design)``, where
    given), the crankshaft as the scene gives it. Without it, one row at
    ``load_share``; ``drive = {"contact_model": ...}`` with ``load_share`` given as
    None picks only the contact law.
    """
    where, _, _ = PAPER_SWEEPS[name]
    rec = {"sweep": name, "value": float(value), "status": "ok"}
    try:
        d = _design_at(design, name, value) if where == "design" else design
        info = undercut_analysis(d)
        if info.undercut:
            rec["status"] = (
                f"undercut (admissible roller radius {info.admissible_roller_radius:.4g} mm)"
            )
            return rec
        errors = ManufacturingErrors(**{name: value}) if where == "errors" else None
        if drive is not None and drive.get("model") == "drive":
            from corr_cad.mechanics.drive.drive import solve_drive

            kw = {k: v for k, v in drive.items() if k not in ("model", "bodies_for")}
            if where == "design" and drive.get("bodies_for") is not None:
                kw["bodies"] = drive["bodies_for"](d)  # the bodies of the swept design
            res = solve_drive(d, input_torque, positions=positions, errors=errors, **kw).rows[0]
        else:
            law = (drive or {}).get("contact_model", "nonlinear")
            res = solve_forces(
                d,
                input_torque,
                positions=positions,
                load_share=load_share,
                errors=errors,
                contact_model=law,
            )
    except CorrCadError as exc:
        rec["status"] = f"invalid: {exc}"
        return rec
    s = res.summary()
    rec.update({k: s[k] for k in METRICS})
    rec["loaded_rollers_min"] = s["loaded_rollers_min"]
    rec["loaded_rollers_max"] = s["loaded_rollers_max"]
    return rec


def run_sweeps(
    design: GearDesign,
    input_torque: float,
    points: int,
    positions: int,
    load_share: float = 0.55,
    executor=None,
    names=tuple(PAPER_SWEEPS),
    ranges: dict[str, dict] | None = None,
    progress: Callable[[int], None] | None = None,
    drive: dict | None = None,
) -> dict[str, list[dict]]:
    """All sweeps, each point a task on ``executor`` (``submit`` interface).

    ``drive``: the model and contact law of each point (:func:`sweep_point`).
    ``ranges`` maps a sweep name to a :func:`sweep_range` result; missing
    ones get the default range. A sweep with no valid range has no points.
    ``progress(n)`` is called with 1 after each point is back.
    """
    from corr_cad.tolerance.montecarlo import SerialExecutor

    executor = executor or SerialExecutor()
    ranges = dict(ranges or {})
    jobs = {}
    for name in names:
        rng = ranges.get(name) or sweep_range(design, name)
        if rng["swept"] is None:
            jobs[name] = []
            continue
        lo, hi = rng["swept"]
        values = np.linspace(lo, hi, points) if points > 1 else np.array([0.5 * (lo + hi)])
        jobs[name] = [
            executor.submit(
                sweep_point, design, name, float(v), input_torque, positions, load_share, drive
            )
            for v in values
        ]
    out = {}
    for name, futs in jobs.items():
        out[name] = []
        for f in futs:
            out[name].append(f.result())
            if progress:
                progress(1)
    return out


def comparison_rows(
    results: dict[str, list[dict]], ranges: dict[str, dict] | None = None
) -> list[dict]:
    """Our values at the ends of each range beside the paper's, with the change in %.

    With ``ranges`` (from :func:`sweep_range`), only sweeps over the paper's
    own range are compared; the caller runs this for the Table 1 design only.
    """
    rows = []
    for name, quotes in PAPER_QUOTES.items():
        pts = results.get(name)
        if not pts:
            continue
        if ranges is not None and (ranges.get(name) or {}).get("source") != "paper":
            continue
        ok = [p for p in pts if p["status"] == "ok"]
        if not ok:
            continue
        # Our end of range: the last point that could be computed (the paper's
        # range runs into undercut for the roller radius).
        first, last = ok[0], ok[-1]
        for metric, (p0, p1) in quotes.items():
            ours0 = first.get(metric)
            ours1 = last.get(metric)
            rows.append(
                {
                    "sweep": name,
                    "metric": metric,
                    "paper_range": f"{PAPER_SWEEPS[name][1]:g} .. {PAPER_SWEEPS[name][2]:g}",
                    "ours_range": f"{first['value']:g} .. {last['value']:g}",
                    "paper_start": p0,
                    "paper_end": p1,
                    "paper_change_pct": 100.0 * (p1 - p0) / p0,
                    "ours_start": ours0,
                    "ours_end": ours1,
                    "ours_change_pct": (
                        100.0 * (ours1 - ours0) / ours0 if ours0 and ours1 is not None else None
                    ),
                    "beyond_our_range": "; ".join(
                        sorted({p["status"].split(":")[0] for p in pts if p["status"] != "ok"})
                    ),
                }
            )
    return rows
