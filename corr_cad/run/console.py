"""The console summary of a run, and the drive-wide force peaks it reports.

:func:`force_peaks` condenses a :class:`~corr_cad.mechanics.solver.ForceResult` into
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

from corr_cad.mechanics import contact

__all__ = [
    "PRESSURE_BOUND_MPA",
    "MIN_TIP_RADIUS_MM",
    "force_peaks",
    "warnings",
    "failed_checks",
    "datasheet_lines",
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
    p = peak.get("pressure")
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
    return out


def passes_with_text(remedies: list[dict]) -> str:
    """``passes with a >= 1 mm or b <= 2 mm`` from a check's recorded remedies."""
    if not remedies:
        return "no single change of eccentricity, radii, roller length or load passes"
    return "passes with " + " or ".join(
        f"{r['parameter']} {r['sense']} {r['value']:.6g} {r['unit']}" for r in remedies
    )


def failed_checks(manifest: dict) -> list[str]:
    """Names of the failing checks: ``limit`` (nominal) or ``montecarlo <limit> (p = ..)``."""
    out = []
    for name, r in (manifest.get("checks") or {}).items():
        if name == "montecarlo":
            for lim, g in r.items():
                if not g["passed"]:
                    out.append(
                        f"montecarlo {lim} (failure probability {g['probability']:.4g} > "
                        f"allowed {g['allowed']:.4g})"
                    )
        elif not r["passed"]:
            line = f"{name} (value {r['value']:.4g}, limit {r['limit']:.4g})"
            if "passes_with" in r:
                line += "; " + passes_with_text(r["passes_with"])
            out.append(line)
    return out


def _where(p: dict) -> str:
    return f"roller {p['roller']} at crank angle {p['crank_angle_deg']:.2f} deg"


def datasheet_lines(d: dict | None) -> list[str]:
    """The datasheet table of the console summary (catalogue units), from its manifest entry."""
    if not d:
        return []
    p, rig = d["positions"], d["torsional_rigidity_Nm_per_arcmin"]
    lm, te = d["lost_motion_arcmin"], d["transmission_error_arcsec"]

    def mmm(x: dict) -> str:
        return f"{x['min']:.4g} / {x['mean']:.4g} / {x['max']:.4g}"

    ring = d.get("ring") or {}
    of = (
        f" of the measured ring {ring.get('file')} (other parts nominal)"
        if ring.get("profile") == "measured"
        else ""
    )
    out = [
        f"datasheet{of} at T_R = {d['rated_torque_Nm']:.5g} N*m, {p['count']} positions over "
        f"{p['span']} (min / mean / max):",
        f"  backlash            {mmm(d['backlash_arcmin'])} arcmin",
        f"  lost motion         {mmm(lm)} arcmin (at +-{100 * lm['band']:g} % T_R)",
    ]
    if rig["with_series"] is not None:
        out.append(
            f"  torsional rigidity  {mmm(rig['with_series'])} N*m/arcmin (series "
            f"{rig['series_rigidity_Nm_per_arcmin']:.4g} included)"
        )
    out.append(
        f"  rigidity, contacts  {mmm(rig['contact_only'])} N*m/arcmin "
        f"({rig['from_torque_Nm']:.4g}-{rig['to_torque_Nm']:.4g} N*m; the contacts alone: "
        "bearings, crank and housing are not in it)"
    )
    k = d["stiffness_Nm_per_arcmin"]
    out.append(
        f"  K1 / K2 / K3 (min)  {k['K1']['min']:.4g} / {k['K2']['min']:.4g} / "
        f"{k['K3']['min']:.4g} N*m/arcmin (breakpoints "
        + ", ".join(f"{b:.4g}" for b in k["breakpoints_Nm"])
        + " N*m)"
    )
    out.append(
        f"  transmission error  forward {te['forward_peak_to_peak']:.4g}, reverse "
        f"{te['reverse_peak_to_peak']:.4g} arcsec peak-to-peak over one output revolution"
    )
    out.append("  hysteresis loss     0: the model has no friction (both branches coincide)")
    rp = d.get("rated_torque_from_contact_pressure")
    if rp:
        out.append(
            f"  rated torque from contact pressure {rp['torque_Nm']:.5g} N*m "
            f"(peak Hertz pressure {rp['allowable_MPa']:.4g} MPa)"
        )
    return out


def summary_lines(manifest: dict, out) -> list[str]:
    """The console summary of a finished run, from its manifest."""
    lines = []
    acc = (manifest.get("accuracy") or {}).get("working_profile")
    if acc:
        lines.append(
            f"working profile: {acc['representation']}, tolerance {acc['tolerance_mm']:g} mm, "
            f"measured max deviation {acc['max_deviation_mm']:.3g} mm"
        )
    f = manifest.get("forces")
    if f:
        pk = f.get("peak") or {}
        if pk:
            lines.append(
                f"drive: peak F_n {pk['F_n']['value']:.1f} N on {_where(pk['F_n'])}; "
                f"peak F_j {pk['F_j']['value']:.1f} N on {_where(pk['F_j'])}; "
                f"peak |F_s| {abs(pk['F_s']['value']):.1f} N on {_where(pk['F_s'])}"
            )
            p = pk["pressure"]
            lines.append(
                f"drive: peak contact pressure {p['value']:.0f} MPa at the {p['contact']} "
                f"contact, {_where(p)}; loaded rollers {pk['loaded_rollers']['min']}-"
                f"{pk['loaded_rollers']['max']}"
            )
        lines.append(
            f"roller 1: F_j mean {f['F_j_mean']:.1f} N, peak {f['F_j_peak']:.1f} N; "
            f"F_n mean {f['F_n_mean']:.1f} N, peak {f['F_n_peak']:.1f} N; "
            f"F_s peak-to-peak {f['F_s_peak_to_peak']:.1f} N"
        )
    lines.extend(datasheet_lines(manifest.get("datasheet")))
    mc = manifest.get("montecarlo")
    if mc:
        lines.append(f"Monte Carlo, {mc['samples']} samples:")
        for metric, qs in (mc.get("percentiles") or {}).items():
            vals = ", ".join(f"{q} {v:.4g}" for q, v in qs.items() if v is not None)
            lines.append(f"  {metric}: {vals}")
        for name, prob in (mc.get("failure_probability") or {}).items():
            lines.append(f"  P(fail {name}) = {prob:.4g}")
        b = mc.get("binding_probability")
        if b:
            lo, hi = b["wilson_interval"]
            lines.append(
                f"  P(binds) = {b['probability']:.4g} ({b['binding_samples']} of {b['samples']}; "
                f"{100 * b['confidence']:g} % Wilson interval {lo:.4g}-{hi:.4g})"
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
        lines.append(
            f"clearance over {c['positions']} crank positions: smallest {smallest}; "
            f"working contacts within {working} of exact contact"
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
                    f"{g['probability']:.4g}, allowed {g['allowed']:.4g})"
                )
        else:
            state = "pass" if r["passed"] else "FAIL"
            line = f"check {name}: {state} (value {r['value']:.4g}, limit {r['limit']:.4g})"
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
