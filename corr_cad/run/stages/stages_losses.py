"""The datasheet's load-independent losses, total efficiency, temperature and a_ISO.

Runs inside the ``datasheet`` stage when the scene has ``[lubrication]``
(:func:`losses_figures`, after the friction figures), and writes
``temperature.csv`` and ``temperature.png`` under ``[thermal.test]``
(:func:`write_losses_files`). Scenes without ``[lubrication]`` never reach it.

The total efficiency at output torque ``T`` and crank speed ``n``::

    eta = P_out / (P_out + P_load + P_0)

``P_out = T omega_out``, ``P_load = P_out (1 / eta_load - 1)`` the
load-dependent (Coulomb) losses of the friction model at that torque, and
``P_0`` the load-independent losses (:mod:`corr_cad.mechanics.losses.bearing_drag`)
at the crank speed and the oil temperature. Backdriving:
``eta_b = eta_b,load - P_0 / P_out``, self-locking at or below 0.
"""

from __future__ import annotations

import math

import numpy as np

from corr_cad.mechanics.losses.bearing_drag import DragBearing, LoadIndependent
from corr_cad.mechanics.losses.lubrication import Lubricant
from corr_cad.mechanics.losses.thermal_network import ThermalNetwork

__all__ = ["load_independent", "losses_figures", "write_losses_files", "housing_area_m2"]

#: Specific heat of steel (J/(kg K)) and of a mineral oil (J/(kg K)), oil density (kg/m^3).
STEEL_HEAT = 460.0
OIL_HEAT = 1900.0
OIL_DENSITY = 870.0
_RPM = 2.0 * math.pi / 60.0


def lubricant(lub: dict) -> Lubricant:
    """The :class:`Lubricant` of ``[lubrication]``."""
    if lub["iso_vg"] is not None:
        return Lubricant.iso_vg(lub["iso_vg"], lub["lubricant"])
    return Lubricant(
        lub["viscosity_40C"], lub["viscosity_100C"], lub["lubricant"], "viscosity_40C/100C"
    )


def load_independent(scene, life, bearing_per_crank: float | None) -> LoadIndependent:
    """Every load-independent loss of the scene's drive.

    ``life`` the eccentric bearings' :class:`~corr_cad.mechanics.life.LifeSpec`
    (needles and pitch diameter), None where the cams are fixed on the crank;
    ``bearing_per_crank`` their relative speed per crank speed (None: 1, the
    crank's speed).
    """
    lub = scene.losses["lubrication"]
    d = scene.design
    bearings = []
    if life is not None:
        k = 1.0 if bearing_per_crank is None else bearing_per_crank
        bearings.append(
            DragBearing(
                "eccentric_needle_bearings",
                2,
                life.pitch_diameter,
                lub["needle_f0"],
                k,
                "the cams' needle rings: pitch diameter 2 cam_bore_radius - needle_diameter",
            )
        )
    i1 = 1.0
    fs = scene.first_stage
    if fs is not None:
        from corr_cad.geometry.first_stage_parts import first_stage_layout
        from corr_cad.run.stages.stages_bearing_parts import needle_rows_of

        lay = first_stage_layout(d, fs, needle_rows_of(scene))  # the bearings drawn
        i1 = abs(fs.ratio)
        zp, zw = fs.stage.pinion_teeth, fs.stage.wheel_teeth
        bearings.append(
            DragBearing(
                "first_stage_wheel_bearings",
                3,
                lay.wheel_bore + lay.wheel_bearing_inner,
                lub["needle_f0"],
                i1 * zp / zw,
                "the wheels' needle-bearing placeholders (bore and inner radius of the layout)",
            )
        )
        bearings.append(
            DragBearing(
                "crank_bearings",
                2,
                lay.crank_bearing_outer + lay.shaft_radius,
                lub["support_f0"],
                1.0,
                "the crankshaft's two placeholder bearings (shaft and outer radius of the layout)",
            )
        )
    churning = ()
    if fs is not None and lub["immersion_depth_mm"] > 0.0:
        from corr_cad.mechanics.losses.churning import ChurningGear

        churning = (
            ChurningGear(
                "first_stage_churning",
                1,
                0.5 * fs.stage.module * zw,
                fs.stage.face_width,
                lub["immersion_depth_mm"],
                lub["sump_volume_l"],
                i1 * zp / zw,
                OIL_DENSITY,
                "one of the first stage's wheels dips (reference pitch radius, face width)",
            ),
        )
    return LoadIndependent(
        lubricant=lubricant(lub),
        churning=churning,
        bearings=tuple(bearings),
        input_seal=lub["input_seal_moment_Nmm"],
        output_seal=lub["output_seal_moment_Nmm"],
        input_per_crank=i1,
        output_per_crank=1.0 / d.roller_count,
    )


def housing_area_m2(design) -> float:
    """Default housing area, m^2: a cylinder of ``ring_outer_radius`` over the stack, both ends."""
    r = design.ring_outer_radius * 1e-3
    length = (2.0 * design.face_width + 3.0 * design.frame_thickness) * 1e-3
    return 2.0 * math.pi * r * length + 2.0 * math.pi * r * r


def parts_mass_kg(ctx) -> tuple[float, str]:
    """The drive's steel mass and where it comes from."""
    d = ctx.manifest.get("drive")
    if isinstance(d, dict) and d.get("mass_kg"):
        return float(d["mass_kg"]), "the whole drive's parts (manifest drive mass_kg)"
    from corr_cad.geometry.parts import part_outlines
    from corr_cad.geometry.profile import working_profile
    from corr_cad.mechanics.gears.first_stage_loads import STEEL_DENSITY

    design = ctx.scene.design
    o = part_outlines(design, working_profile(design), 0.01)
    count = {"ring": 2, "frame": 3, "cam": 2, "roller": 2 * design.roller_count}
    mass = sum(STEEL_DENSITY * o[k].exact_volume * n for k, n in count.items())
    return mass, "the second stage's parts: 2 rings, 3 frame plates, 2 cams, 2 (z + 1) rollers"


def network(ctx) -> tuple[ThermalNetwork, dict]:
    """The one-node network of ``[thermal]`` and its parameters as the files state them."""
    th, design = ctx.scene.losses["thermal"], ctx.scene.design
    area = th["housing_area_m2"]
    area_source = "[thermal] housing_area_m2"
    if area is None:
        area, area_source = housing_area_m2(design), "cylinder round the rings, both ends"
    hA = area * th["heat_transfer_W_per_m2K"]
    oil = th["oil_volume_l"] * 1e-3 * OIL_DENSITY * OIL_HEAT
    cap = th["heat_capacity_J_per_K"]
    cap_source = "[thermal] heat_capacity_J_per_K"
    mass = None
    if cap is None:
        mass, why = parts_mass_kg(ctx)
        cap = mass * STEEL_HEAT + oil
        cap_source = f"steel {mass:.4g} kg x {STEEL_HEAT:g} J/(kg K) ({why}) + oil {oil:.4g} J/K"
    net = ThermalNetwork((cap,), (hA,))
    return net, {
        "model": "one node (oil, parts and housing at one temperature), losses into it, "
        "h A to the ambient; ISO/TR 14179-1 heat balance at steady state",
        "housing_area_m2": area,
        "housing_area_source": area_source,
        "heat_transfer_W_per_m2K": th["heat_transfer_W_per_m2K"],
        "hA_W_per_K": hA,
        "heat_capacity_J_per_K": cap,
        "heat_capacity_source": cap_source,
        "time_constant_min": net.time_constant_s() / 60.0,
        "ambient_C": th["ambient_C"],
    }


class _Loads:
    """The losses (W) at a crank speed, output torque and oil temperature."""

    def __init__(self, li: LoadIndependent, ff, ratio: float):
        self.li, self.ratio = li, ratio
        self.shares = np.asarray(ff.shares, dtype=float)
        self.rated = ff.rated_torque  # N*mm
        self.forward = np.asarray(ff.forward, dtype=float)

    def load_dependent_W(self, crank_rpm: float, torque_Nm: float) -> float:
        if torque_Nm <= 0.0 or crank_rpm <= 0.0:
            return 0.0
        share = torque_Nm * 1e3 / self.rated
        order = np.argsort(self.shares)
        eta = float(np.interp(share, self.shares[order], self.forward[order]))
        if eta <= 0.0:  # a friction model without a positive efficiency there: its lowest
            eta = float(np.min(self.forward[self.forward > 0.0], initial=1.0))
        p_out = torque_Nm * crank_rpm * _RPM / self.ratio
        return p_out * (1.0 / eta - 1.0)

    def total_W(self, crank_rpm: float, torque_Nm: float, temperature_C: float) -> float:
        p0 = float(self.li.power_W(crank_rpm, temperature_C))
        return p0 + self.load_dependent_W(crank_rpm, torque_Nm)


def _efficiency_map(li: LoadIndependent, ff, temps, speeds, ratio: float) -> dict:
    shares = np.asarray(ff.shares, dtype=float)
    torque_Nm = shares * ff.rated_torque / 1e3
    fwd = np.full((len(temps), len(speeds), len(shares)), np.nan)
    back = np.full_like(fwd, np.nan)
    for a, t in enumerate(temps):
        for b, n in enumerate(speeds):
            p0 = float(li.power_W(n, t))
            p_out = torque_Nm * n * _RPM / ratio
            f_ld = np.asarray(ff.forward, dtype=float)
            safe = np.where(f_ld > 0, f_ld, 1.0)
            with np.errstate(divide="ignore", invalid="ignore"):
                fwd[a, b] = np.where(f_ld > 0, p_out / (p_out / safe + p0), 0.0)
                back[a, b] = np.asarray(ff.backdriving, dtype=float) - p0 / p_out
    back = np.maximum(back, 0.0)

    def nested(x):
        return [[[float(v) for v in row] for row in plane] for plane in x]

    return {
        "definition": "P_out / (P_out + load-dependent losses + load-independent losses); "
        "backdriving: the friction model's backdriving efficiency less P_0 / P_out, 0 where "
        "self-locking; indices [temperature][input speed][torque]",
        "temperatures_C": [float(t) for t in temps],
        "input_speed_rpm": [float(n) for n in speeds],
        "input_speed_of": "the crank (the second stage's input)",
        "output_torque_Nm": [float(v) for v in torque_Nm],
        "forward": nested(fwd),
        "backdriving": nested(back),
        "forward_min": float(np.min(fwd)),
        "forward_max": float(np.max(fwd)),
        "self_locking_backdriving": bool(np.any(back <= 0.0)),
    }


def losses_figures(ctx, ff, life) -> dict:
    """``datasheet.json``'s figures of ``[lubrication]`` and ``[thermal]`` (plus the test's rows).

    ``ff`` the :class:`~corr_cad.mechanics.losses.efficiency.FrictionFigures`;
    ``life`` the eccentric bearings' LifeSpec (None: cams fixed on the crank).
    """
    s = ctx.scene
    lub = s.losses["lubrication"]
    ratio = float(s.design.roller_count)
    per_crank = None
    if ff.bearing is not None and life is not None and ff.life_spec is not None:
        per_crank = ff.bearing["relative_speed_rpm"] / (ff.life_spec.rated_speed_rpm * ratio)
    li = load_independent(s, life, per_crank)
    temp = lub["temperature_C"]
    speeds = np.asarray(ff.speeds_rpm, dtype=float)
    nu = float(li.lubricant.viscosity(temp))
    moments = li.moments(speeds, temp)
    start = float(li.crank_moment(0.0, temp))
    preload_start = 0.0
    preload_back = 0.0
    if ff.hysteresis is not None:
        preload_start = float(np.max(ff.hysteresis["starting_torque"]))
        preload_back = float(np.max(ff.hysteresis["backdriving_torque"]))
    out: dict = {
        "lubrication": {
            **li.lubricant.as_dict(),
            "temperature_C": temp,
            "viscosity_at_temperature_mm2_per_s": nu,
        },
        "load_independent_losses": {
            **li.as_dict(),
            "bearing_speed_source": "the eccentric bearings' mean relative speed of the "
            "friction model at T_R per crank speed"
            if per_crank is not None
            else "the crank's speed",
            "at_temperature_C": temp,
            "input_speed_rpm": [float(n) for n in speeds],
            "input_speed_of": "the crank (the second stage's input)",
            "torque_at_crank_Nm": [float(v) / 1e3 for v in li.crank_moment(speeds, temp)],
            "power_W": [float(v) for v in li.power_W(speeds, temp)],
            "by_element_torque_at_crank_Nm": {
                k: [float(x) / 1e3 for x in np.broadcast_to(v, speeds.shape)]
                for k, v in moments.items()
            },
        },
        "efficiency_total": _efficiency_map(li, ff, lub["map_temperatures_C"], speeds, ratio),
        "starting_torque_total_Nm": {
            "at_crank": (preload_start + start) / 1e3,
            "at_input": (preload_start + start) / 1e3 / li.input_per_crank,
            "backdriving_at_output": (preload_back + start * ratio) / 1e3,
            "drag_at_crank": start / 1e3,
            "preload_friction_at_crank": preload_start / 1e3,
            "definition": "torque to start the drive at no load: the hysteresis's preload "
            "friction (max over the positions) plus the load-independent drag at zero speed "
            "(Palmgren's constant branch and the seals) at the crank; at the input through "
            "the first stage's ratio; backdriving: the drag times z + 1 plus the preload's",
        },
    }
    lives = {}
    if life is not None and ff.lives is not None and ff.bearing is not None:
        lives = _modified_lives(ff, life, nu, lub, temp)
    support = _support_lives(ctx, nu, lub, temp)
    if support:
        lives = lives or {
            "temperature_C": temp,
            "contamination_factor_eC": lub["contamination_factor"],
            "definition": "",
        }
        lives.update(support)
        lives["definition"] = (lives["definition"] + "; " if lives["definition"] else "") + (
            SUPPORT_DEFINITION
        )
    if lives:
        out["modified_life"] = lives
    if s.losses["thermal"]:
        out.update(_thermal(ctx, li, ff, ratio, speeds))
    return out


def _modified_lives(ff, life, nu: float, lub: dict, temp: float) -> dict:
    from corr_cad.mechanics.life_modified import modified_life, static_rating_roller

    c0 = static_rating_roller(
        1, life.needles, life.needle_length, life.needle_diameter, life.pitch_diameter
    )
    rows = {}
    for tag, fig in (("bearing_row1", ff.bearing), ("bearing_row2", ff.bearing_b or ff.bearing)):
        if tag not in ff.lives:
            continue
        rows[tag] = modified_life(
            ff.lives[tag],
            nu,
            fig["relative_speed_rpm"],
            life.pitch_diameter,
            c0,
            fig["equivalent_load_N"],
            lub["contamination_factor"],
        )
    return {
        **rows,
        "temperature_C": temp,
        "contamination_factor_eC": lub["contamination_factor"],
        "definition": "ISO 281:2007 L10m = a_ISO L10 (a1 = 1, 90 %) of the eccentric needle "
        "bearings at T_R and rated_speed_rpm: kappa = nu / nu1 at the oil temperature, "
        "C_u = C_0r / 8.2 (ISO 281 Annex B), C_0r by ISO 76",
    }


#: ``modified_life``'s definition of the crankshaft's support bearings.
SUPPORT_DEFINITION = (
    "support bearings ([bearings.crank]): ISO 281:2007 L10m = a_ISO L10 at the crank speed "
    "(z + 1) rated_speed_rpm and the equivalent radial load of compliance_budget, "
    "C_u = C_0r / 8.2, C_0r = 44 (1 - D cos(alpha) / d_m) i Z L D cos(alpha) (ISO 76)"
)


def _support_lives(ctx, nu: float, lub: dict, temp: float) -> dict:
    """``modified_life`` rows of the crankshaft's support bearings (none without
    ``[bearings.crank]`` or without ``[life]``'s L10 in ``compliance_budget``)."""
    from corr_cad.mechanics.life_modified import modified_life, static_rating_roller

    crank = getattr(ctx.scene, "crank", None)
    ds = ctx.results.datasheet
    budget = getattr(ds, "compliance_budget", None) if ds is not None else None
    if crank is None or not budget:
        return {}
    rows = {}
    for i, (b, row) in enumerate(
        zip(crank.supports, budget.get("support_bearings", []), strict=True), 1
    ):
        if b is None or row.get("L10_h") is None:
            continue
        n = row["output_speed_rpm"] * ctx.scene.design.roller_count
        c0 = static_rating_roller(
            b.rows, b.rollers, b.roller_length, b.roller_diameter, b.pitch_diameter, b.cos_alpha
        )
        rows[f"support_bearing_{i}"] = {
            **modified_life(
                row["L10_h"],
                nu,
                n,
                b.pitch_diameter,
                c0,
                row["equivalent_load_N"],
                lub["contamination_factor"],
            ),
            "speed_rpm": n,
        }
    return rows


def _thermal(ctx, li: LoadIndependent, ff, ratio: float, speeds) -> dict:
    from scipy.optimize import brentq

    th = ctx.scene.losses["thermal"]
    net, params = network(ctx)
    amb, tmax = th["ambient_C"], th["max_oil_temperature_C"]
    loads = _Loads(li, ff, ratio)
    rated_Nm = ff.rated_torque / 1e3
    r = net.resistance()

    def steady(n: float, torque: float) -> float | None:
        return net.steady(lambda t: loads.total_W(n, torque, t), amb)

    def rating(torque: float) -> float | None:
        if tmax <= amb:
            return None

        def f(n: float) -> float:
            return loads.total_W(n, torque, tmax) * r - (tmax - amb)

        if f(1e6) < 0.0:
            return None
        return float(brentq(f, 0.0, 1e6, xtol=1e-9, rtol=1e-12)) if f(0.0) < 0.0 else 0.0

    n_rated = rating(rated_Nm)
    n_free = rating(0.0)
    out = {
        "thermal": {
            **params,
            "steady_temperature_C": {
                "input_speed_rpm": [float(n) for n in speeds],
                "input_speed_of": "the crank (the second stage's input)",
                "no_load": [steady(float(n), 0.0) for n in speeds],
                "at_rated_torque": [steady(float(n), rated_Nm) for n in speeds],
            },
            "thermal_rating": {
                "max_oil_temperature_C": tmax,
                "input_speed_at_rated_torque_rpm": n_rated,
                "output_power_at_rated_torque_kW": None
                if n_rated is None
                else rated_Nm * n_rated * _RPM / ratio / 1e3,
                "input_speed_at_no_load_rpm": n_free,
                "definition": "ISO/TR 14179-1 style thermal rating: the crank speed at which "
                "the steady oil temperature reaches max_oil_temperature_C, at T_R and at no "
                "load (None: not reached below 1e6 r/min)",
            },
        }
    }
    if ctx.scene.losses["thermal_test"]:
        out["thermal_test"] = _thermal_test(ctx, net, loads, amb)
    return out


def _thermal_test(ctx, net: ThermalNetwork, loads: _Loads, amb: float) -> dict:
    test = ctx.scene.losses["thermal_test"]
    t_min = np.asarray(test["time_min"], dtype=float)
    n_in = np.asarray(test["input_speed_rpm"], dtype=float)
    q = test["output_torque_Nm"]
    q = np.zeros_like(t_min) if q is None else np.asarray(q, dtype=float)
    i_in = loads.li.input_per_crank
    step = test["step_min"]
    rows_t = np.arange(0.0, t_min[-1] + 0.5 * step, step)
    rows_t = np.unique(np.concatenate([rows_t[rows_t <= t_min[-1]], [t_min[-1]]]))

    def loss(t_s: float, temp: float) -> float:
        tm = t_s / 60.0
        n = float(np.interp(tm, t_min, n_in)) / i_in
        return loads.total_W(n, float(np.interp(tm, t_min, q)), temp)

    start = test["start_C"]
    temps = net.simulate(rows_t * 60.0, t_min * 60.0, loss, amb, start)[:, 0]
    speed = np.interp(rows_t, t_min, n_in)
    torque = np.interp(rows_t, t_min, q)
    power = np.array([loss(t * 60.0, T) for t, T in zip(rows_t, temps, strict=True)])
    return {
        "rows": {
            "time_min": rows_t,
            "input_speed_rpm": speed,
            "output_torque_Nm": torque,
            "oil_temperature_C": temps,
            "loss_W": power,
        },
        "final_temperature_C": float(temps[-1]),
        "max_temperature_C": float(np.max(temps)),
        "duration_min": float(t_min[-1]),
        "input_speed_of": "the pinion" if i_in != 1.0 else "the crank",
        "definition": "the one-node network integrated over [thermal.test]'s programme "
        "(LSODA, tolerances 1e-10), losses at the oil temperature; temperature.csv",
    }


def public_figures(figs: dict) -> dict:
    """The figures as ``datasheet.json`` holds them (the test's rows go to temperature.csv)."""
    out = dict(figs)
    if "thermal_test" in out:
        out["thermal_test"] = {k: v for k, v in out["thermal_test"].items() if k != "rows"}
        out["thermal_test"]["file"] = "temperature.csv"
    return out


def write_losses_files(figs: dict, out_dir, name: str) -> list[str]:
    """``temperature.csv`` and ``temperature.png`` of ``[thermal.test]`` (none without it)."""
    test = figs.get("thermal_test")
    if not test:
        return []
    from corr_cad.export.temperature_io import temperature_png, write_temperature_csv

    write_temperature_csv(test["rows"], out_dir / "temperature.csv")
    temperature_png(test, out_dir / "temperature.png", name)
    return ["temperature.csv", "temperature.png"]
