"""Scene sections of the load-independent losses and the temperature: ``[lubrication]``,
``[thermal]`` and ``[thermal.test]`` (part of :data:`corr_cad.run.scene.scene_schema.SCHEMA`).

``[lubrication]`` makes the datasheet add the bearings' drag and the seals to the
efficiency (and turns the efficiency map on, with ``[friction]``'s defaults where
the scene has no ``[friction]``); ``[thermal]`` adds the steady temperature and the
thermal rating; ``[thermal.test]`` runs a speed programme and writes
``temperature.csv`` and ``temperature.png``.
"""

from __future__ import annotations

from corr_cad.errors import SceneError
from corr_cad.mechanics.losses.lubrication import ISO_VG_NU100, LUBRICANT_KINDS
from corr_cad.run.scene.scene_key import MAX_LIST, Key

__all__ = ["SECTIONS", "lubrication_sections", "split_thermal_test"]

_TEMP = {"low": -60.0, "high": 300.0}

SECTIONS: dict[str, dict[str, Key]] = {
    "lubrication": {
        "iso_vg": Key(
            "int",
            None,
            "ISO 3448 viscosity grade of a VI 95 mineral oil (or give viscosity_40C and "
            f"viscosity_100C); one of {', '.join(map(str, ISO_VG_NU100))}",
            low=0,
            high=3200,
            example=68,
        ),
        "viscosity_40C": Key(
            "float",
            None,
            "kinematic viscosity at 40 C, mm^2/s (the oil's, or the grease's base oil's)",
            low=2,
            high=1e5,
            example=68.0,
        ),
        "viscosity_100C": Key(
            "float",
            None,
            "kinematic viscosity at 100 C, mm^2/s, at least 2 and below viscosity_40C",
            low=2,
            high=1e5,
            low_open=False,
            example=8.53,
        ),
        "lubricant": Key("str", "oil", "oil, or grease", choices=LUBRICANT_KINDS),
        "temperature_C": Key(
            "float",
            40.0,
            "operating oil temperature, C: the datasheet's drag, starting torque and a_ISO",
            **_TEMP,
        ),
        "map_temperatures_C": Key(
            "list[float]",
            [20.0, 40.0, 60.0, 80.0],
            "oil temperatures of the total efficiency map, C",
            **_TEMP,
            max_len=20,
        ),
        "needle_f0": Key(
            "float",
            12.0,
            "Palmgren f0 of the eccentric needle bearings (Harris & Kotzalas: oil bath 12, "
            "oil mist 6, oil jet 24)",
            low=0,
            high=100,
            low_open=False,
        ),
        "support_f0": Key(
            "float",
            2.0,
            "Palmgren f0 of the first stage's crank bearings (deep groove ball: oil bath 2, "
            "oil mist 1); its wheel bearings take needle_f0",
            low=0,
            high=100,
            low_open=False,
        ),
        "input_seal_moment_Nmm": Key(
            "float",
            0.0,
            "friction moment of the input shaft's seal(s), N*mm (the seal maker's figure; 0: none)",
            low=0,
            high=1e7,
            low_open=False,
        ),
        "output_seal_moment_Nmm": Key(
            "float",
            0.0,
            "friction moment of the output's seal(s), N*mm (0: none)",
            low=0,
            high=1e8,
            low_open=False,
        ),
        "immersion_depth_mm": Key(
            "float",
            0.0,
            "depth one first stage wheel dips into the oil, mm, for its churning "
            "(Changenet & Velex; 0: no gear dips, no churning)",
            low=0,
            high=1e4,
            low_open=False,
        ),
        "sump_volume_l": Key(
            "float",
            1.0,
            "oil volume in the sump, litres (Changenet & Velex's V_0 of the churning)",
            low=0,
            high=1e4,
        ),
        "contamination_factor": Key(
            "float",
            0.5,
            "ISO 281 e_C of the eccentric bearings' a_ISO (Table 13, dm < 100 mm: normal "
            "cleanliness 0.6-0.5, slight contamination 0.5-0.3)",
            low=0,
            high=1,
            low_open=False,
        ),
    },
    "thermal": {
        "housing_area_m2": Key(
            "float",
            None,
            "housing surface giving off heat, m^2 (default: a cylinder round the rings, "
            "radius ring_outer_radius, length 2 face_width + 3 frame_thickness, both ends)",
            low=0,
            high=1e4,
            example=0.3,
        ),
        "heat_transfer_W_per_m2K": Key(
            "float",
            18.0,
            "heat transfer coefficient of the housing to the air, W/(m^2 K) (still air 15-20)",
            low=0,
            high=1e4,
        ),
        "ambient_C": Key("float", 20.0, "ambient air temperature, C", **_TEMP),
        "heat_capacity_J_per_K": Key(
            "float",
            None,
            "heat capacity of the drive and its oil, J/K (default: the parts' steel masses "
            "x 460 J/(kg K) + the oil's)",
            low=0,
            high=1e9,
            example=60000.0,
        ),
        "oil_volume_l": Key(
            "float",
            0.0,
            "oil fill, litres (870 kg/m^3, 1.9 kJ/(kg K)): its heat capacity",
            low=0,
            high=1e4,
            low_open=False,
        ),
        "max_oil_temperature_C": Key(
            "float",
            90.0,
            "oil temperature of the thermal rating (continuous duty), C",
            **_TEMP,
        ),
    },
    "thermal.test": {
        "time_min": Key(
            "list[float]",
            None,
            "times of the programme's points, min, from 0, increasing (required)",
            low=0,
            high=1e6,
            low_open=False,
            max_len=MAX_LIST,
            example=[0.0, 10.0, 180.0],
        ),
        "input_speed_rpm": Key(
            "list[float]",
            None,
            "input speed at each time, r/min, linear between (the pinion's with "
            "[first_stage], else the crank's; required)",
            low=0,
            high=1e6,
            low_open=False,
            max_len=MAX_LIST,
            example=[0.0, 2000.0, 2000.0],
        ),
        "output_torque_Nm": Key(
            "list[float]",
            None,
            "output torque at each time, N*m, linear between (default: 0, no load)",
            low=0,
            high=1e9,
            low_open=False,
            max_len=MAX_LIST,
            example=[0.0, 0.0, 0.0],
        ),
        "step_min": Key("float", 1.0, "time step of temperature.csv's rows, min", low=0, high=1e5),
        "start_C": Key(
            "float",
            None,
            "temperature of every part at time 0, C (default: the ambient)",
            **_TEMP,
            example=20.0,
        ),
    },
}


def split_thermal_test(data: dict) -> dict:
    """``[thermal.test]`` as a section of its own (the loader's flat sections)."""
    th = data.get("thermal") if isinstance(data, dict) else None
    if not isinstance(th, dict) or "test" not in th:
        return data
    out = dict(data)
    out["thermal"] = {k: v for k, v in th.items() if k != "test"}
    out["thermal.test"] = th["test"]
    return out


def _refuse(key: str, value, why: str, works: str) -> None:
    raise SceneError(f"{key} = {value!r}: {why}, e.g. {works}")


def lubrication_sections(values: dict, data: dict) -> dict:
    """``Scene.lubrication``, ``Scene.thermal`` and ``Scene.thermal_test`` (empty: not given)."""
    lub = values["lubrication"] if "lubrication" in data else {}
    thermal = values["thermal"] if "thermal" in data else {}
    test = values["thermal.test"] if "thermal.test" in data else {}
    if (thermal or test) and not lub:
        raise SceneError(
            "[thermal] needs [lubrication]: the oil whose viscosity sets the drag, e.g. "
            "[lubrication] iso_vg = 68"
        )
    if test and not thermal:
        raise SceneError("[thermal.test] needs [thermal] (an empty [thermal] takes its defaults)")
    if lub:
        _check_oil(lub)
    if test:
        _check_programme(test)
    return {"lubrication": lub, "thermal": thermal, "thermal_test": test}


def _check_oil(lub: dict) -> None:
    vg, v40, v100 = lub["iso_vg"], lub["viscosity_40C"], lub["viscosity_100C"]
    if vg is not None and (v40 is not None or v100 is not None):
        raise SceneError(
            "[lubrication] give iso_vg or viscosity_40C with viscosity_100C, not both, "
            "e.g. iso_vg = 68"
        )
    if vg is None and (v40 is None or v100 is None):
        raise SceneError(
            "[lubrication] needs iso_vg (e.g. 68) or both viscosity_40C and viscosity_100C "
            "(e.g. 68.0 and 8.53)"
        )
    if vg is not None and vg not in ISO_VG_NU100:
        _refuse(
            "[lubrication] iso_vg",
            vg,
            f"one of the ISO 3448 grades {', '.join(map(str, ISO_VG_NU100))}",
            "68",
        )
    if vg is None and not v100 < v40:
        _refuse(
            "[lubrication] viscosity_100C",
            v100,
            f"allowed range is [2, viscosity_40C = {v40:g}) mm^2/s",
            f"{v40 / 8:g}",
        )
    if not lub["map_temperatures_C"]:
        _refuse("[lubrication] map_temperatures_C", [], "give at least one temperature", "[40]")


def _check_programme(test: dict) -> None:
    t, n, q = test["time_min"], test["input_speed_rpm"], test["output_torque_Nm"]
    if t is None or n is None:
        raise SceneError(
            "[thermal.test] needs time_min and input_speed_rpm, e.g. time_min = [0, 10, 180], "
            "input_speed_rpm = [0, 2000, 2000]"
        )
    if len(t) < 2:
        _refuse("[thermal.test] time_min", t, "give at least two points", "[0, 180]")
    for key, v in (("input_speed_rpm", n), ("output_torque_Nm", q)):
        if v is not None and len(v) != len(t):
            _refuse(
                f"[thermal.test] {key}",
                v,
                f"{len(v)} values; time_min has {len(t)} (one per point)",
                f"{len(t)} values",
            )
    if t[0] != 0.0 or any(b <= a for a, b in zip(t[:-1], t[1:], strict=True)):
        _refuse(
            "[thermal.test] time_min",
            t,
            "must start at 0 and increase strictly",
            "[0, 10, 180]",
        )
    if (t[-1] - t[0]) / test["step_min"] > 1e5:
        _refuse(
            "[thermal.test] step_min",
            test["step_min"],
            "more than 100,000 rows of temperature.csv over the programme",
            f"{t[-1] / 200:g}",
        )
