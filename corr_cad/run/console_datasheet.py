"""The console's datasheet block: the catalogue figures, friction, losses, the
compliance budget, the first stage and the whole drive (one list of lines each)."""

from __future__ import annotations

from corr_cad.export.datasheet_html import life_short, nominal_geometry
from corr_cad.figure_text import figure

#: Said under the rigidity of the paper's one-row model.
PAPER_RIGIDITY_NOTE = (
    'note: model = "paper" counts the contacts of one row only (at load_share): the rigidity '
    'is an upper bound, not a catalogue figure (model = "drive" solves both rows and bearings)'
)


__all__ = [
    "PAPER_RIGIDITY_NOTE",
    "budget_lines",
    "datasheet_lines",
    "friction_lines",
    "losses_lines",
    "first_stage_lines",
    "whole_drive_lines",
]


def budget_lines(b: dict | None) -> list[str]:
    """The compliance budget's line: each component's share of the windup at T_R."""
    if not b:
        return []
    parts = [
        f"{name.replace('_', ' ')} {100 * v['share']:.1f} %"
        for name, v in b["components"].items()
        if v["in_model"] and v["windup_arcmin"] != 0.0
    ]
    absent = [name.replace("_", " ") for name, v in b["components"].items() if not v["in_model"]]
    out = [
        f"  compliance budget   windup {figure(b['windup_arcmin'])} arcmin at T_R: "
        + ", ".join(parts)
        + " (compliance.png)"
    ]
    if absent:
        out.append(f"                      not in it: {', '.join(absent)}")
    for i, s in enumerate(b.get("support_bearings", []), 1):
        life = s.get("L10_h")
        life_text = (
            f", L10 {figure(life)} h"
            if life is not None
            else (
                f", L10 {figure(s['L10_million_crank_revolutions'])} million crank turns"
                if "L10_million_crank_revolutions" in s
                else ""
            )
        )
        out.append(
            f"  support bearing {i}   radial load up to "
            f"{figure(s['radial_load_at_rated_N']['max'])} N at +-T_R{life_text}"
        )
    return out


def datasheet_lines(d: dict | None) -> list[str]:
    """The datasheet table of the console summary (catalogue units), from its manifest entry."""
    if not d:
        return []
    p, rig = d["positions"], d["torsional_rigidity_Nm_per_arcmin"]
    lm, te = d["lost_motion_arcmin"], d["transmission_error_arcsec"]

    def mmm(x: dict) -> str:
        return f"{figure(x['min'])} / {figure(x['mean'])} / {figure(x['max'])}"

    ring = d.get("ring") or {}
    of = (
        f" of the measured ring {ring.get('file')} (other parts nominal)"
        if ring.get("profile") == "measured"
        else ""
    )
    whole = d.get("whole_drive")
    stage = " (second stage, crank locked)" if whole else ""
    out = [
        f"datasheet{of} at T_R = {figure(d['rated_torque_Nm'], 5)} N*m, {p['count']} positions "
        f"over {p['span']} (min / mean / max):",
        f"  backlash            {mmm(d['backlash_arcmin'])} arcmin{stage}",
        f"  lost motion         {mmm(lm)} arcmin (at +-{100 * lm['band']:g} % T_R){stage}",
    ]
    if whole:
        out.append(
            f"  whole drive         backlash {figure(whole['backlash_arcmin']['value'])} arcmin, "
            f"lost motion {figure(whole['lost_motion_arcmin']['value'])} arcmin (pinion held: "
            f"the first stage's {figure(d['first_stage']['backlash_arcmin'])} and "
            f"{figure(d['first_stage']['lost_motion_arcmin'])} arcmin at the output included)"
        )
    if rig["with_series"] is not None:
        out.append(
            f"  torsional rigidity  {mmm(rig['with_series'])} N*m/arcmin (series "
            f"{figure(rig['series_rigidity_Nm_per_arcmin'])} included)"
        )
    if d.get("compliances"):
        comp = d["compliances"]
        what = "in it: " + "; ".join(comp["in_figure"])
        what += "; not in it: " + "; ".join(comp["not_in_figure"])
    elif d.get("model") == "drive" and isinstance(d.get("bodies"), dict):
        what = (
            "the contacts of both rows"
            + (", the cams' eccentric bearings" if isinstance(d.get("bearing"), dict) else "")
            + ", the elastic gear rings, frame and cams (FE): crank, its bearings, output "
            "bearings and housing are not in it"
        )
    elif d.get("model") == "drive":
        what = (
            "the contacts of both rows and the cams' eccentric bearings, ring, frame and cams "
            "rigid: crank, output bearings and housing are not in it"
            if isinstance(d.get("bearing"), dict)
            else "the contacts of both rows, cams fixed, ring, frame and cams rigid: bearings, "
            "crank and housing are not in it"
        )
    else:
        what = "the contacts alone: bearings, crank and housing are not in it"
    label = "rigidity, model   " if d.get("compliances") else "rigidity, contacts"
    out.append(
        f"  {label}  {mmm(rig['contact_only'])} N*m/arcmin "
        f"({figure(rig['from_torque_Nm'])}-{figure(rig['to_torque_Nm'])} N*m; {what})"
    )
    if d.get("model") != "drive":
        out.append(f"  {PAPER_RIGIDITY_NOTE}")
    by = d.get("row_a_share_by_direction")
    if by:  # each direction: the asymmetry a mean over both would hide
        out.append(
            "  row A share         "
            + ", ".join(
                f"{figure(by[k]['min'], 4)}-{figure(by[k]['max'], 4)} at {s}T_R"
                for k, s in (("positive", "+"), ("negative", "-"))
            )
            + " (row B carries the rest)"
        )
    out.extend(budget_lines(d.get("compliance_budget")))
    k = d["stiffness_Nm_per_arcmin"]
    out.append(
        f"  K1 / K2 / K3 (min)  {figure(k['K1']['min'])} / {figure(k['K2']['min'])} / "
        f"{figure(k['K3']['min'])} N*m/arcmin (breakpoints "
        + "; ".join(figure(b) for b in k["breakpoints_Nm"])
        + " N*m)"
    )
    out.append(
        f"  transmission error  forward {figure(te['forward_peak_to_peak'])}, reverse "
        f"{figure(te['reverse_peak_to_peak'])} arcsec peak-to-peak over one output revolution"
        + (" (nominal geometry: a perfect drive's)" if nominal_geometry(d) else "")
    )
    if "efficiency_forward" in d:
        out.extend(friction_lines(d))
    else:
        out.append("  hysteresis loss     0: the model has no friction (both branches coincide)")
    out.extend(losses_lines(d))
    rp = d.get("rated_torque_from_contact_pressure")
    if rp:
        out.append(
            f"  rated torque from contact pressure {figure(rp['torque_Nm'], 5)} N*m "
            f"(peak Hertz pressure {figure(rp['allowable_MPa'])} MPa)"
        )
    return out


def friction_lines(d: dict) -> list[str]:
    """Efficiency, hysteresis, starting torque and life rows of the datasheet table."""

    def mmm(x: dict) -> str:
        return f"{figure(x['min'], 4)} / {figure(x['mean'], 4)} / {figure(x['max'], 4)}"

    fw, bk = d["efficiency_forward"], d["efficiency_backdriving"]
    out = [
        f"  efficiency forward  {mmm(fw)} over the map",
        f"  efficiency backdriving {mmm(bk)}"
        + (" (SELF-LOCKING at some torques)" if bk["self_locking"] else ""),
        f"  hysteresis loss     {figure(d['hysteresis_loss_arcmin'], 4)} arcmin (width at T_R "
        f"{figure(d['hysteresis_width_at_rated_arcmin']['max'], 4)} arcmin)",
        f"  starting torque     {figure(d['starting_torque_Nm']['max'], 4)} N*m at the crank",
    ]
    if d.get("friction", {}).get("forces", "").startswith("drive"):
        out.insert(0, "  friction and life   from the drive: both rows, each cam's bearing")
    life = d.get("life_h")
    if life:
        parts = ", ".join(
            f"{k} {'inf' if v is None else f'{figure(v, 4)}'}"
            for k, v in life.items()
            if isinstance(v, (int, float)) or v is None
            if k not in ("at_torque_Nm", "at_output_speed_rpm")
        )
        rt = d["rated_torque_from_life_Nm"]
        out.append(
            f"  life L10, h         {parts} (at {figure(life['at_torque_Nm'], 5)} N*m, "
            f"{life['at_output_speed_rpm']:g} rpm out)"
        )
        out.append(
            f"  rated torque from life {figure(rt['value'], 5)} N*m "
            f"(L10 {rt['rated_life_h']:g} h at {rt['rated_speed_rpm']:g} rpm)"
            + (" < T_R: the life at T_R is SHORT of the rated life" if life_short(d) else "")
        )
    return out


def losses_lines(d: dict) -> list[str]:
    """``[lubrication]`` / ``[thermal]`` rows of the datasheet table (none without them)."""
    li = d.get("load_independent_losses")
    if not li:
        return []
    e, st = d["efficiency_total"], d["starting_torque_total_Nm"]

    def span(v: list) -> str:
        return f"{figure(min(v), 4)}-{figure(max(v), 4)}"

    def each(v: list) -> str:
        return " / ".join("-" if x is None else figure(x, 4) for x in v)

    speeds = each(li["input_speed_rpm"])
    out = [
        f"  efficiency, total   {figure(e['forward_min'], 4)}-{figure(e['forward_max'], 4)} over "
        f"{span(e['temperatures_C'])} C oil, {span(e['input_speed_rpm'])} rpm at the crank "
        f"(Coulomb friction + Palmgren drag + seals{' + churning' if 'churning' in li else ''})",
        f"  drag at {figure(li['at_temperature_C'])} C oil   {each(li['torque_at_crank_Nm'])} "
        f"N*m at the crank at {speeds} rpm ({d['lubrication']['source']})",
        f"  starting torque, total {figure(st['at_input'], 4)} N*m at the input (drag at "
        f"standstill + preload friction)",
    ]
    ec = d.get("modified_life", {}).get("contamination_factor_eC")
    for tag, m in d.get("modified_life", {}).items():
        if isinstance(m, dict) and "a_ISO" in m:
            life = "inf" if m["L10m_h"] is None else figure(m["L10m_h"], 4)
            out.append(
                f"  life L10m {tag} {life} h (ISO 281 a_ISO {figure(m['a_ISO'], 3)}, kappa "
                f"{figure(m['kappa'], 3)}, e_C {figure(ec)})"
            )
    th = d.get("thermal")
    if th:
        s, r = th["steady_temperature_C"], th["thermal_rating"]
        out.append(
            f"  steady oil, no load {each(s['no_load'])} C at {speeds} rpm (one node, hA "
            f"{figure(th['hA_W_per_K'], 4)} W/K, ambient {figure(th['ambient_C'])} C)"
        )
        rated = r["input_speed_at_rated_torque_rpm"]
        out.append(
            f"  thermal rating      {'-' if rated is None else figure(rated, 4)} rpm at the "
            f"crank at T_R, {each([r['input_speed_at_no_load_rpm']])} rpm at no load (oil "
            f"{figure(r['max_oil_temperature_C'])} C; ISO/TR 14179-1 heat balance)"
        )
    tt = d.get("thermal_test")
    if tt:
        out.append(
            f"  temperature test    final {figure(tt['final_temperature_C'], 4)} C, max "
            f"{figure(tt['max_temperature_C'], 4)} C over {figure(tt['duration_min'])} min "
            "(temperature.csv)"
        )
    return out


def first_stage_lines(fs: dict | None) -> list[str]:
    """The first gear stage in two lines: ratio and centre distance, then both meshes."""
    if not fs:
        return []
    g = fs["gears"]
    teeth = "/".join(str(g[k]["teeth"]) for k in ("pinion", "wheel", "crank_gear"))
    meshes = "; ".join(
        f"{name.replace('_', '-', 1).replace('_', ' ')}: working pressure angle "
        f"{m['working_pressure_angle_deg']:.4g} deg, contact ratio {m['contact_ratio']:.3f}, "
        f"backlash {1e3 * m['backlash_mm']:.3g} um"
        for name, m in fs["meshes"].items()
    )
    return [
        f"first stage: pinion/wheel/crank gear {teeth} teeth, module {fs['module_mm']:g} mm, "
        f"i1 = {fs['ratio_i1']:.6g}, centre distance {fs['centre_distance_mm']:.6g} mm",
        f"  {meshes}",
    ]


def whole_drive_lines(d: dict | None) -> list[str]:
    """The whole drive: ratio, mass, inertia at the input; the first stage's loads."""
    if not d:
        return []
    out = [
        f"whole drive: total ratio {d['total_ratio']:.6g}, mass {d['mass_kg']:.4g} kg "
        f"(steel), inertia at the input {d['input_inertia_kg_m2']:.4g} kg m^2"
        + (
            " (cams floating on their needle bearings, spinning at 2 L / R_j times the "
            "output by the rolling kinematics; "
            f"{d['input_inertia_cams_fixed_kg_m2']:.4g} kg m^2 were they fixed to the crank)"
            if "input_inertia_cams_fixed_kg_m2" in d
            else ""
        )
    ]
    ld = d.get("first_stage_loads")
    if ld:
        w = ld["per_wheel"]
        out.append(
            f"  first stage at {ld['input_torque_Nmm'] / 1e3:.4g} N*m: M0 "
            f"{ld['crank_torque_M0_Nmm'] / 1e3:.4g} N*m (eta1 = 1); per wheel F_t "
            f"{w['pinion_mesh_tangential_N']:.4g} N, bearing {w['bearing_load_N']:.4g} N; "
            f"Lewis root stress up to {max(ld['root_bending_MPa'].values()):.4g} MPa, "
            f"Hertz up to {max(ld['contact_stress_MPa'].values()):.4g} MPa"
        )
    return out
