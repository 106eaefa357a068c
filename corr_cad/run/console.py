"""The console summary of a run, and the drive-wide force peaks it reports.

:func:`force_peaks` condenses a :class:`~corr_cad.mechanics.row.solver.ForceResult` into
the numbers an engineer signs off on (each peak with the roller and crank
angle where it occurs); the pipeline stores them in ``manifest.json`` under
``forces.peak``. :func:`summary_lines` formats the console summary from the
manifest alone, so what is printed is exactly what was recorded, and
:func:`warnings` lists what makes those numbers doubtful. :func:`failed_checks`
names the checks that fail (the nominal limits and, with
``[checks] max_failure_probability``, the Monte Carlo gate).
"""

from __future__ import annotations

import math
import os

import numpy as np

from corr_cad.export.datasheet_html import life_short
from corr_cad.figure_text import figure, unit_of
from corr_cad.mechanics import contact
from corr_cad.run.console_datasheet import (  # noqa: F401 (the console's API)
    PAPER_RIGIDITY_NOTE,
    budget_lines,
    datasheet_lines,
    first_stage_lines,
    friction_lines,
    losses_lines,
    whole_drive_lines,
)

__all__ = [
    "PRESSURE_BOUND_MPA",
    "MIN_TIP_RADIUS_MM",
    "force_peaks",
    "warnings",
    "failed_checks",
    "datasheet_lines",
    "assembly_line",
    "summary_lines",
    "ClosedPipeSafe",
]

#: Contact pressure beyond which the numbers are flagged (defined with the
#: contact model; the Monte Carlo plot draws it too).
PRESSURE_BOUND_MPA = contact.PRESSURE_BOUND_MPA

#: A tooth tip radius below this is a geometry warning (hard to make, and
#: the contact half-width soon exceeds it).
MIN_TIP_RADIUS_MM = 0.1

CONTACTS = ("cam", "slot", "gear")


def _at(res, arr: np.ndarray, index: int) -> dict:
    p, k = np.unravel_index(index, arr.shape)
    return {
        "value": float(arr[p, k]),
        "roller": int(k) + 1,
        "crank_angle_deg": float(math.degrees(res.crank_angles[p])),
    }


def drive_lines(f: dict) -> list[str]:
    """The drive model's lines: model, contact law, bearings, row A's share and bearing loads."""
    b = f.get("bearing")
    bearing = (
        f"{b['needles']} needles {b['needle_diameter_mm']:g} x {b['needle_length_mm']:g} mm, "
        f"Pd {b['diametral_clearance_mm']:g} mm"
        if isinstance(b, dict)
        else str(b)
    )
    sh = f["row_a_share"]
    bodies = f.get("bodies")
    if isinstance(bodies, dict):
        bearing += (
            "; ring, frame and cams elastic (FE, "
            + " + ".join(str(v) for v in bodies.get("mesh_nodes", {}).values())
            + " nodes)"
        )
    out = [
        f"drive model (both rows), contact law {f['contact_law']}, eccentric bearing: {bearing}",
        f"drive: row A share {sh['min']:.4f}-{sh['max']:.4f} (mean {sh['mean']:.4f})",
    ]
    for name, row in (f.get("rows") or {}).items():
        if "needle_load_max_N" in row:
            out.append(
                f"drive: cam {name} bearing load up to {row['bearing_load_N']['max']:.0f} N, "
                f"largest needle load {row['needle_load_max_N']['max']:.0f} N"
            )
    return out + crank_lines(f.get("crank"))


def crank_lines(c: dict | None) -> list[str]:
    """The crankshaft and its supports as the drive holds them, and what was derived."""
    if not c:
        return []
    sh, sup = c["crankshaft"], c["support_bearings"][0]
    kind = sup["type"]
    if kind != "rigid":
        play = round(1e3 * sup["clearance_mm"], 3) + 0.0  # um; no "-0"
        fit = f"{sup['clearance_meaning']} {play:g} um" + (": a preload" if play < 0 else "")
        kind += (
            f" ({sup['rollers_per_row']} x {sup['rows']} rollers {sup['roller_diameter_mm']:g} mm,"
            f" {fit})"
        )
    z1, z2 = sh["support_positions_mm"]
    out = [
        f"drive: crankshaft {sh['shaft_diameter_mm']:g} mm ({sh['source']}) on {kind} support "
        f"bearings at z = {z1:g} and {z2:g} mm ({sup['source']}); eccentrics at "
        + " and ".join(f"{v:g}" for v in sh["eccentric_positions_mm"])
        + " mm"
    ]
    if c.get("derived_from_design"):
        out.append(
            "drive: derived from the design (not in the scene): "
            + ", ".join(c["derived_from_design"])
        )
    return out


def force_peaks(res, design) -> dict:
    """Peaks over all rollers and positions of a :class:`ForceResult`, as a JSON-ready dict.

    ``F_j``, ``F_n``: largest values; ``F_s``: largest magnitude (signed value);
    ``pressure``: largest Hertz pressure of any contact, with the contact's
    name; ``half_width_mm``: largest contact half-width per contact;
    ``contacts_outside_validity``: loaded (position, roller) pairs whose
    half-width reaches a body's radius, per contact. Rollers are numbered
    from 1, crank angles in degrees.
    """
    out = {
        "F_j": _at(res, res.F_j, int(np.argmax(res.F_j))),
        "F_n": _at(res, res.F_n, int(np.argmax(res.F_n))),
        "F_s": _at(res, res.F_s, int(np.argmax(np.abs(res.F_s)))),
    }
    pressures = {"cam": res.p_cam, "slot": res.p_slot, "gear": res.p_gear}
    best = max(CONTACTS, key=lambda c: float(pressures[c].max()))
    top = int(np.argmax(pressures[best]))
    out["pressure"] = {"contact": best, **_at(res, pressures[best], top)}
    out["pressure_by_contact"] = {c: float(pressures[c].max()) for c in CONTACTS}
    geo = res.geometry
    forces = {"cam": res.F_j, "slot": np.abs(res.F_s), "gear": res.F_n}
    curv = {"cam": geo.k_cam, "slot": 0.0, "gear": geo.k_gear}
    length, modulus = design.roller_length, design.material.contact_modulus
    half = {}
    for c in CONTACTS:
        u = contact.half_width_sq_per_force(geo.k_roller, curv[c], length, modulus) * forces[c]
        half[c] = float(np.sqrt(np.max(u)))
    out["half_width_mm"] = half
    loaded = res.loaded
    valid = {"cam": res.valid_cam, "slot": res.valid_slot, "gear": res.valid_gear}
    out["contacts_outside_validity"] = {
        c: int(np.count_nonzero(~valid[c] & loaded)) for c in CONTACTS
    }
    out["loaded_rollers"] = {
        "min": int(res.loaded_count.min()),
        "max": int(res.loaded_count.max()),
    }
    return out


def warnings(manifest: dict) -> list[str]:
    """What makes the printed numbers doubtful, one sentence each."""
    out = []
    und = manifest.get("undercut") or {}
    tip = und.get("min_working_radius_mm")
    peak = (manifest.get("forces") or {}).get("peak") or {}
    if und.get("undercut") and und.get("trimmed_psi_deg"):
        out.append(
            "geometry: the tooth tips are trimmed (allowed undercut): a sharp corner, "
            f"rollers beyond psi = {und['trimmed_psi_deg']:.4g} deg find no flank"
        )
    elif tip is not None and math.isfinite(tip):
        if tip < MIN_TIP_RADIUS_MM:
            out.append(
                f"geometry: tooth tip radius {tip:.3g} mm is below {MIN_TIP_RADIUS_MM:g} mm "
                "(a knife edge; hard to make, wears fast)"
            )
        b = (peak.get("half_width_mm") or {}).get("gear")
        if b is not None and tip < b:
            out.append(
                f"geometry: tooth tip radius {tip:.3g} mm is below the largest gear contact "
                f"half-width {b:.3g} mm: the line-contact model does not hold at the tip"
            )
    bad = peak.get("contacts_outside_validity") or {}
    if any(bad.values()):
        parts = ", ".join(f"{c} {n}" for c, n in bad.items() if n)
        out.append(
            f"validity: contacts outside the Hertz model (half-width >= a radius): {parts} "
            "(position, roller) pairs; their pressures and approaches are extrapolated"
        )
    rows = (manifest.get("forces") or {}).get("rows") or {}
    tops = [(r.get("peak") or {}).get("pressure") for r in rows.values()] or [peak.get("pressure")]
    p = max((t for t in tops if t), key=lambda t: t["value"], default=None)
    if p and p["value"] > PRESSURE_BOUND_MPA:
        out.append(
            f"material: peak contact pressure {p['value']:.0f} MPa exceeds "
            f"{PRESSURE_BOUND_MPA:.0f} MPa (static capacity of through-hardened bearing "
            "steel, and the end of the elastic Hertz model)"
        )
    mc = manifest.get("montecarlo") or {}
    pp = (mc.get("percentiles") or {}).get("peak_pressure") or {}
    over = {q: v for q, v in pp.items() if v is not None and v > PRESSURE_BOUND_MPA}
    if over:
        q, v = max(over.items(), key=lambda kv: kv[1])
        out.append(
            f"validity: Monte Carlo peak pressure {q} = {v:.0f} MPa exceeds "
            f"{PRESSURE_BOUND_MPA:.0f} MPa: those samples are beyond the material and the "
            "elastic Hertz model; read them as 'fails', not as a pressure"
        )
    if short := life_short(manifest.get("datasheet") or {}):
        out.append(short)
    for edge in (manifest.get("modification_design") or {}).get("at_range_edge", []):
        out.append(
            f"modification design: the chosen {edge} (the search looked no further; "
            "the best may lie beyond)"
        )
    return out


def passes_with_text(remedies: list[dict]) -> str:
    """``passes with a >= 1 mm or b <= 2 mm`` from a check's recorded remedies."""
    if not remedies:
        return "no single change of eccentricity, radii, roller length or load passes"
    return "passes with " + " or ".join(
        f"{r['parameter']} {r['sense']} {r['value']:.6g} {r['unit']}" for r in remedies
    )


def _bounded(v) -> str:
    """A check's figure, positional (:func:`figure`) between 1e-6 and 1e12, else as
    ``1.096e+300``: a failed check never prints hundreds of digits."""
    try:
        x = float(v)
    except (TypeError, ValueError):
        return str(v)
    if x != 0 and math.isfinite(x) and not 1e-6 <= abs(x) < 1e12:
        return f"{x:.4g}"
    return figure(x)


def failed_checks(manifest: dict) -> list[str]:
    """Names of the failing checks: ``limit`` (nominal) or ``montecarlo <limit> (p = ..)``."""
    out = []
    for name, r in (manifest.get("checks") or {}).items():
        if name == "montecarlo":
            for lim, g in r.items():
                if not g["passed"]:
                    out.append(
                        f"montecarlo {lim} (failure probability {figure(g['probability'])} > "
                        f"allowed {figure(g['allowed'])})"
                    )
        elif not r["passed"]:
            line = f"{name} (value {_bounded(r['value'])}, limit {_bounded(r['limit'])}{_parts(r)})"
            if "passes_with" in r:
                line += "; " + passes_with_text(r["passes_with"])
            out.append(line)
    return out


def _parts(r: dict) -> str:
    """A whole-drive check's parts: the second stage's and the first stage's share."""
    if "first_stage" not in r:
        return ""
    return (
        f"; whole drive: second stage {figure(r['second_stage'])}, first stage "
        f"{figure(r['first_stage'])}"
    )


def _where(p: dict) -> str:
    return f"roller {p['roller']} at crank angle {p['crank_angle_deg']:.2f} deg"


#: Said wherever the paper model's rigidity is shown or checked.
def assembly_line(a: dict) -> str:
    """The selective assembly's verdict: the roller class to fit, on which ring.

    >>> assembly_line({"ring": "nominal ring", "chosen_class_um": -2.0,
    ...     "chosen_backlash_arcmin": 0.81234, "target_backlash_arcmin": 1.0})
    'selective assembly (nominal ring): fit roller class -2 um, backlash 0.8123 arcmin (target 1)'
    """
    head = f"selective assembly ({a['ring']}): "
    if a.get("chosen_class_um") is None:
        return head + f"NO CLASS FITS: {a.get('reason')}"
    return head + (
        f"fit roller class {a['chosen_class_um']:+g} um, backlash "
        f"{figure(a['chosen_backlash_arcmin'])} arcmin (target "
        f"{figure(a['target_backlash_arcmin'])})"
    )


def peak_lines(pk: dict, head: str) -> list[str]:
    """The two peak lines of one row (``head``: ``drive`` or ``drive (row B, the heavier)``)."""
    if not pk:
        return []
    p = pk["pressure"]
    return [
        f"{head}: peak F_n {pk['F_n']['value']:.1f} N on {_where(pk['F_n'])}; "
        f"peak F_j {pk['F_j']['value']:.1f} N on {_where(pk['F_j'])}; "
        f"peak |F_s| {abs(pk['F_s']['value']):.1f} N on {_where(pk['F_s'])}",
        f"{head}: peak contact pressure {p['value']:.0f} MPa at the {p['contact']} "
        f"contact, {_where(p)}; loaded rollers {pk['loaded_rollers']['min']}-"
        f"{pk['loaded_rollers']['max']}",
    ]


#: ``samples_chain``'s parts, as the Monte Carlo's console line names them.
_CHAIN_WORDS = (
    ("crankshaft", "the crankshaft on its support bearings"),
    ("elastic", "the elastic ring, frame and cams (FE)"),
)


def summary_lines(manifest: dict, out) -> list[str]:
    """The console summary of a finished run, from its manifest."""
    lines = []
    lines.extend(first_stage_lines(manifest.get("first_stage")))
    lines.extend(whole_drive_lines(manifest.get("drive")))
    acc = (manifest.get("accuracy") or {}).get("working_profile")
    if acc:
        lines.append(
            f"working profile: {acc['representation']}, tolerance {acc['tolerance_mm']:g} mm, "
            f"measured max deviation {acc['max_deviation_mm']:.3g} mm"
        )
    f = manifest.get("forces")
    if f:
        rows = f.get("rows") or {}
        heavier = f.get("heavier_row")
        if heavier in rows:  # the drive: the heavier row first, then the other, each named
            order = [heavier, *(r for r in rows if r != heavier)]
            for name in order:
                tag = f"row {name}, the heavier" if name == heavier else f"row {name}"
                lines.extend(peak_lines(rows[name].get("peak") or {}, f"drive ({tag})"))
        else:
            lines.extend(peak_lines(f.get("peak") or {}, "drive"))
        if f.get("model") == "drive":
            lines.extend(drive_lines(f))
        of = f"row {heavier} " if heavier in rows else ""
        lines.append(
            f"{of}roller 1: F_j mean {f['F_j_mean']:.1f} N, peak {f['F_j_peak']:.1f} N; "
            f"F_n mean {f['F_n_mean']:.1f} N, peak {f['F_n_peak']:.1f} N; "
            f"F_s peak-to-peak {f['F_s_peak_to_peak']:.1f} N"
        )
    lines.extend(datasheet_lines(manifest.get("datasheet")))
    if manifest.get("assembly"):
        lines.append(assembly_line(manifest["assembly"]))
    mc = manifest.get("montecarlo")
    if mc:
        lines.append(f"Monte Carlo, {mc['samples']} samples:")
        chain = mc.get("samples_chain") or ""
        on = [w for k, w in _CHAIN_WORDS if k in chain]
        if on:
            lines.append(f"  every sample solved on {' and '.join(on)} (model.samples_chain)")
        for metric, qs in (mc.get("percentiles") or {}).items():
            vals = ", ".join(f"{q} {figure(v)}" for q, v in qs.items() if v is not None)
            unit = unit_of(metric)
            lines.append(f"  {metric}{f' ({unit})' if unit else ''}: {vals}")
        for name, prob in (mc.get("failure_probability") or {}).items():
            lines.append(f"  P(fail {name}) = {figure(prob)}")
        b = mc.get("binding_probability")
        if b:
            lo, hi = b["wilson_interval"]
            lines.append(
                f"  P(binds) = {figure(b['probability'])} ({b['binding_samples']} of "
                f"{b['samples']}; {100 * b['confidence']:g} % Wilson interval "
                f"{figure(lo)} to {figure(hi)})"
            )
    c = manifest.get("clearance")
    if c:
        low, work = c["min_clearance_mm"], c["working_contacts_max_abs_mm"]
        # Within 1e-9 mm is exact contact: the rest is floating-point round-off.
        smallest = (
            "0 (exact contact, |c| <= 1e-9 mm)"
            if abs(low) <= 1e-9
            else f"{1e3 * low:.4g} um ({'interference' if low < 0 else 'clearance'})"
        )
        working = "<= 1e-9 mm" if work <= 1e-9 else f"{1e3 * work:.3g} um"
        both = " of both rows" if c.get("rows") else ""
        lines.append(
            f"clearance over {c['positions']} crank positions{both}: smallest {smallest}; "
            f"working contacts within {working} of exact contact"
        )
        if c.get("free_play_note"):
            lines.append(f"  {c['free_play_note']}")
    fc = (c or {}).get("first_stage")
    if fc:
        lines.append(
            f"first-stage meshes over {fc['positions']} positions of a pinion pitch: smallest gap "
            f"{1e3 * fc['pinion_wheel_min_gap_mm']:.3g} um (pinion-wheel), "
            f"{1e3 * fc['wheel_crank_gear_min_gap_mm']:.3g} um (wheel-crank gear)"
            + ("" if fc["ok"] else ": INTERFERENCE")
        )
    i = manifest.get("interference")
    if i:
        state = "none beyond tessellation" if i["ok"] else f"{i['violations']} violations"
        lines.append(f"interference over {i['positions']} crank positions: {state}")
    for row in manifest.get("allocation") or []:
        for key in ("why_zero", "why_zero_alone"):
            if key in row:
                lines.append(f"allocation {row['kind']}: 0, because {row[key]}")
    for row in manifest.get("allocation") or []:
        for key in ("why_zero", "why_zero_alone"):
            if key in row:
                lines.append(f"allocation {row['kind']}: 0, because {row[key]}")
    for name, r in (manifest.get("checks") or {}).items():
        if name == "montecarlo":
            for lim, g in r.items():
                state = "pass" if g["passed"] else "FAIL"
                lines.append(
                    f"check montecarlo {lim}: {state} (failure probability "
                    f"{figure(g['probability'])}, allowed {figure(g['allowed'])})"
                )
        else:
            state = "pass" if r["passed"] else "FAIL"
            line = (
                f"check {name}: {state} (value {figure(r['value'])}, limit "
                f"{figure(r['limit'])}{_parts(r)})"
            )
            if "passes_with" in r:
                line += "; " + passes_with_text(r["passes_with"])
            lines.append(line)
    lines.extend(f"warning: {w}" for w in warnings(manifest))
    lines.append(f"wrote {len(manifest['files']) + 1} files to {out}")
    return lines


class ClosedPipeSafe:
    """``sys.stdout`` that a closed pipe (``corr-cad run ... | head -1``) never stops.

    The first write to a closed pipe points the descriptor at ``/dev/null``:
    the rest of the console output is dropped, and the run goes on to its
    commit and exit status.
    """

    def __init__(self, stream):
        self._stream = stream
        self._closed = False

    def write(self, text: str) -> int:
        if not self._closed:
            try:
                return self._stream.write(text)
            except BrokenPipeError:
                self._gone()
        return len(text)

    def flush(self) -> None:
        if not self._closed:
            try:
                self._stream.flush()
            except BrokenPipeError:
                self._gone()

    def _gone(self) -> None:
        self._closed = True
        try:
            null = os.open(os.devnull, os.O_WRONLY)
            try:
                os.dup2(null, self._stream.fileno())  # Python's exit flush succeeds too
            finally:
                os.close(null)
        except (OSError, ValueError, AttributeError):
            pass

    def __getattr__(self, name: str):
        return getattr(self._stream, name)
